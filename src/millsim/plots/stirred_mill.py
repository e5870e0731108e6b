"""Stirred-mill figures (the LabStar LS1 paper): power curves, calibration residuals (Figs 5-7),
contact typology bars (Fig 9), collision-frequency region maps (Fig 8) and coarse-grained velocity
fields (Fig 11). Matplotlib without pyplot state; inputs are the aggregate netCDF of
``millsim aggregate stirred_mill`` or the calibration CSV tables of
``millsim analyse stirred-mill``.
"""

import numpy as np
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from ..analysis.stirred_mill import (
    ENERGY_BALANCE_TOLERANCE,
    _parabola_min,
    friction_interval,
    friction_ssr,
)
from .style import SYMBOL, dodge_step, few_points_note, label, points

SYNTHETIC_NOTE = ("reference: see config/reference/SOURCES.md "
                  "(shipped: SYNTHETIC twin, not a measurement)")
RPM = label("agitator speed", "min-1")
POWER = label("net power", "W")
ETA, ETA_SIM, ETA_EXP, MU = SYMBOL["eta"], SYMBOL["eta_sim"], SYMBOL["eta_exp"], SYMBOL["mu"]
TYPOLOGY_COLOURS = {"impact": "C0", "shearing": "C2", "rolling": "C3", "torsion": "C1"}


def _cases(ds):
    """(label, sub-dataset) for every (eta, rpm) of an aggregate stacked over eta and rpm."""
    for eta in ds["eta"].values:
        for rpm in ds["rpm"].values:
            yield f"{ETA} = {eta:g} Pa s, {rpm:g} min$^{{-1}}$", ds.sel(eta=eta, rpm=rpm)


def domain(ds):
    """The simulated domain, from the aggregate's fixed parameters ('' where they are missing):
    the quick study's slice draws the power of a slice, not of the LS1, so every figure says
    which."""
    if "param_slice" not in ds.attrs:
        return ""
    scale, disks = float(ds.attrs["param_scale"]), int(ds.attrs["param_disks"])
    beads = f", {int(ds['n_bead'].max()):,} beads" if "n_bead" in ds else ""
    if int(ds.attrs["param_slice"]):
        return (f"periodic slice around 1 of {disks} disks, scale {scale:g}{beads}: "
                "not the LS1's power")
    spheres = (f" + {int(ds['n_agitator_particles'].max()):,} agitator spheres"
               if "n_agitator_particles" in ds else "")
    return f"full chamber, {disks} disks, scale {scale:g}{beads}{spheres}"


def _domain_suptitle(fig, ds):
    where = domain(ds)
    if where:
        fig.suptitle(where, fontsize=9)


def _with_domain(title, ds):
    where = domain(ds)
    return f"{title}\n{where}" if where else title


def power(ds, out):
    """Net power vs agitator speed, one set of points per simulation viscosity (95% intervals)."""
    fig = Figure(figsize=(6.0, 4.2), layout="constrained")
    ax = fig.subplots()
    n = 0
    for eta in ds["eta"].values:
        sub = ds.sel(eta=eta)
        n = points(ax, sub["rpm"], sub["net_power"], sub["net_power_ci"],
                   label=f"{ETA_SIM} = {eta:g} Pa s")
    few_points_note(ax, n, "speed")
    fr = ds.attrs.get("param_friction", "")
    ax.set(xlabel=RPM, ylabel=POWER, ylim=(0, None),
           title=f"Net power vs speed and viscosity ({MU} = {fr})")
    _domain_suptitle(fig, ds)
    ax.legend()
    fig.savefig(out)


def typology_figure(ds):
    """The typology figure: signed shares of the dissipated energy per case, bars from 0 (a
    negative share goes below 0, no bar above 100 %), each case's net total annotated; below, the
    energy-balance residual on its own scale with each value written."""
    cases = list(_cases(ds))
    names = [str(n) for n in ds["typology"].values]
    fracs = np.array([100 * sub["typology_fraction"].values for _, sub in cases])
    shown = [k for k, n in enumerate(names) if np.any(fracs[:, k] != 0)]
    fig = Figure(figsize=(max(6.0, 1.6 * len(cases) + 1), 6.6), layout="constrained")
    ax, ax2 = fig.subplots(2, 1, height_ratios=(3, 1.3))
    x = np.arange(len(cases))
    width = 0.8 / max(len(shown), 1)
    for j, k in enumerate(shown):
        bars = ax.bar(x + (j - (len(shown) - 1) / 2) * width, fracs[:, k], width,
                      color=TYPOLOGY_COLOURS.get(names[k]), label=names[k])
        ax.bar_label(bars, fmt="%.1f", fontsize=6.5, padding=1)
    ax.axhline(0, color="k", lw=0.8)
    lo = min(0.0, float(np.nanmin(fracs))) - 8
    for i, (_, sub) in enumerate(cases):
        total = float(np.nansum(fracs[i]))
        watts = float(sub["dissipation_power"].sum())
        ax.text(i, 100, f"sum {total:.0f} %\nof {watts:.2g} W", ha="center", va="bottom",
                fontsize=7.5)
    ax.set_xticks(x, [lab.replace(", ", "\n") for lab, _ in cases])
    ax.set(ylabel="share of the dissipated energy [%]", ylim=(lo, 118),
           title="Dissipation by contact typology (signed shares; torsion = 0: no twisting "
                 "torque in the model)")
    ax.legend(ncols=len(shown), loc="upper left")
    ax.grid(False, axis="x")
    errors = np.array([100 * float(sub["energy_balance_error"]) for _, sub in cases])
    ax2.bar(x, errors, 0.5, color="0.45")
    ax2.axhline(0, color="k", lw=0.8)
    span = max(float(np.nanmax(np.abs(errors))), 1e-6) * 1.8
    for i, e in enumerate(errors):
        ax2.text(i, e, f"{e:+.3g} %", ha="center", va="bottom" if e >= 0 else "top", fontsize=7.5)
    tol = 100 * ENERGY_BALANCE_TOLERANCE
    ax2.set(ylim=(-span, span), ylabel="residual\n[% of input]",
            title=f"Energy-balance residual (own scale; tolerance \u00b1{tol:g} %"
                  + (", off scale)" if span < tol else ")"))
    if span >= tol:
        for sign in (-1, 1):
            ax2.axhline(sign * tol, color="r", lw=0.8, ls="--")
    ax2.set_xticks(x, [lab.replace(", ", "\n") for lab, _ in cases])
    ax2.grid(False, axis="x")
    _domain_suptitle(fig, ds)
    return fig


def typology(ds, out):
    """Dissipated energy by contact typology per case, and energy-balance closure."""
    typology_figure(ds).savefig(out)


def regions(ds, out):
    """Relative collision frequency (%) in the 9 regions: rings 1-3 x front/centre/back, one
    colour scale for all panels."""
    cases = list(_cases(ds))
    cols = min(2, len(cases))
    rows = int(np.ceil(len(cases) / cols))
    fig = Figure(figsize=(3.3 * cols + 1, 2.9 * rows + 0.4), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols)).ravel()
    grids = [sub["collision_frequency_relative"].values.reshape(3, 3)[::-1] for _, sub in cases]
    norm = Normalize(0, max(25.0, max(float(g.max()) for g in grids)))
    for ax, (lab, _), grid in zip(axes, cases, grids):  # outer ring on top
        im = ax.imshow(grid, cmap="Oranges", norm=norm)
        for r in range(3):
            for c in range(3):
                ax.text(c, r, f"{3 - r}{'FCB'[c]}\n{grid[r, c]:.1f} %", ha="center", va="center",
                        fontsize=7.5)
        ax.set(xticks=range(3), xticklabels=["front", "centre", "back"], yticks=range(3),
               yticklabels=["ring 3", "ring 2", "ring 1"], title=lab)
        ax.grid(False)
    for ax in axes[len(cases):]:
        ax.set_visible(False)
    fig.colorbar(im, ax=axes.tolist(), label="share of bead-bead collisions [%]", shrink=0.8)
    fig.suptitle(_with_domain("Relative bead-bead collision frequency by region (one colour scale)",
                              ds))
    fig.savefig(out)


def velocity(ds, out):
    """Coarse-grained translational and rotational speed on the axial slab, per case; one colour
    scale per quantity, shared by all cases."""
    cases = list(_cases(ds))
    fig = Figure(figsize=(7.2, 2.9 * len(cases) + 0.4), layout="constrained")
    axes = np.atleast_2d(fig.subplots(len(cases), 2))
    y, z = ds["gy"].values, ds["gz"].values
    ext = (y[0] * 1.05e3, y[-1] * 1.05e3, z[0] * 1.05e3, z[-1] * 1.05e3)
    # the scale ends at the 99th percentile of the cells: a corner cell crossed by a few beads
    # would otherwise set it for all
    speed = Normalize(0.0, float(np.nanpercentile(ds["cg_speed"].values, 99)))
    spin = Normalize(0.0, float(np.nanpercentile(ds["cg_spin"].values, 99)))
    step = max(1, len(y) // 12)
    Y, Z = np.meshgrid(y * 1e3, z * 1e3)
    for (lab, sub), (a1, a2) in zip(cases, axes):
        im1 = a1.imshow(sub["cg_speed"].values, origin="lower", extent=ext, cmap="viridis",
                        norm=speed)
        a1.quiver(Y[::step, ::step], Z[::step, ::step], sub["cg_vy"].values[::step, ::step],
                  sub["cg_vz"].values[::step, ::step], color="w", scale=None)
        im2 = a2.imshow(sub["cg_spin"].values, origin="lower", extent=ext, cmap="magma",
                        norm=spin)
        a1.set(title=f"translational, {lab}", xlabel=label("y", "mm"), ylabel=label("z", "mm"))
        a2.set(title=f"rotational, {lab}", xlabel=label("y", "mm"))
        for a in (a1, a2):
            a.grid(False)
    # under the last row only (the scale is shared): a colour bar over the whole column gets a
    # margin sized by the column's height, and a tall figure then cuts its label
    fig.colorbar(im1, ax=axes[-1, 0], label=label("|v|", "m s-1"), location="bottom",
                 extend="max")
    fig.colorbar(im2, ax=axes[-1, 1], label=label(f"|{SYMBOL['omega']}|", "rad s-1"),
                 location="bottom", extend="max")
    fig.suptitle(_with_domain("Coarse-grained bead speed on the axial slab\n(one colour scale per "
                              "quantity, ending at its 99th percentile over all cells)", ds))
    fig.savefig(out)


def _interval_text(iv, digits=3):
    """[lo, hi] of an interval; an end at the edge of the simulated grid (open: the grid does
    not bracket it) as <= lo / >= hi, as the report's landing page writes it."""
    lo = ("\u2264 " if iv.get("lo_open") else "") + f"{iv['lo']:.{digits}g}"
    hi = ("\u2265 " if iv.get("hi_open") else "") + f"{iv['hi']:.{digits}g}"
    return f"[{lo}, {hi}]"


def _replicates(t):
    """' (mean of R seeds)' where the table's points pool R > 1 replicates, else ''."""
    r = int(t["replicates"].max()) if "replicates" in t and len(t) else 1
    return f" (mean of {r} seeds)" if r > 1 else ""


def friction(t, out):
    """Fig. 5 of the LS1 paper: dry power vs speed per friction with the reference; residuals vs
    friction (from the stage 1 residual table), with the chosen friction and its 95 % interval."""
    s = friction_ssr(t)
    fig = Figure(figsize=(10.5, 4.2), layout="constrained")
    a, b = fig.subplots(1, 2)
    groups = list(t.groupby("friction"))
    n = t.groupby("friction")["rpm"].nunique().max()
    shift = dodge_step(t["rpm"], len(groups) + 1) if n < 3 else 0.0
    for k, (mu, sub) in enumerate(groups):
        points(a, sub["rpm"], sub["net_power"], sub["net_power_ci"],
               dodge=(k - len(groups)) * shift, label=f"simulation {MU} = {mu:g}{_replicates(sub)}")
    ref = t.drop_duplicates("rpm").sort_values("rpm")
    points(a, ref["rpm"], ref["reference"], ref.get("reference_ci"), color="k", marker="s",
           mfc="none", ls="--", label="reference (dry)")
    few_points_note(a, n, "speed", dodged=bool(shift))
    a.set(xlabel=RPM, ylabel=POWER, title="a. dry power vs speed")
    a.legend()
    b.plot(s["friction"], s["ssr"], "o", color="C0", label="sum of squared residuals")
    mu, ssr = s["friction"].to_numpy(float), s["ssr"].to_numpy(float)
    k = int(np.argmin(ssr))
    best = float(mu[k])
    b.axvline(best, color="C3", lw=1, label=f"calibrated {MU} = {best:g} (grid minimum)")
    refined = _parabola_min(mu, ssr)
    if 0 < k < len(mu) - 1:
        # the parabola through the minimum and its neighbours, whose vertex is the refined value
        x = np.linspace(mu[k - 1], mu[k + 1], 100)
        b.plot(x, np.polyval(np.polyfit(mu[k - 1:k + 2], ssr[k - 1:k + 2], 2), x), "--",
               color="C0", lw=1, label="parabola through the minimum and its neighbours")
    b.axvline(refined, color="k", ls="--", lw=1,
              label=f"refined {MU} = {refined:.3g} (parabola vertex)")
    if len(s) > 1:
        iv = friction_interval(t)
        b.axvspan(iv["lo"], iv["hi"], color="C3", alpha=0.12,
                  label=f"95 % interval {_interval_text(iv)}")
    b.set(xlabel=f"friction coefficient {MU}", ylabel=label("sum of squared residuals", "W2"),
          title=f"b. residuals (minimum = calibrated {MU})")
    b.legend()
    fig.suptitle(SYNTHETIC_NOTE)
    fig.savefig(out)


def viscosity(t, out):
    """Fig. 6 of the LS1 paper: power at the calibration speed vs eta_sim; reference per fluid at
    its viscosity, with the eta_sim interval consistent with it."""
    from ..analysis.stirred_mill import viscosity_interval

    fig = Figure(figsize=(6.5, 4.4), layout="constrained")
    ax = fig.subplots()
    sim = t.drop_duplicates("eta_sim").sort_values("eta_sim")
    n = points(ax, sim["eta_sim"], sim["net_power"], sim["net_power_ci"], color="C0",
               label=f"simulation vs {ETA_SIM}{_replicates(sim)}")
    few_points_note(ax, n, "viscosity")
    for k, (fluid, sub) in enumerate(t.groupby("fluid")):
        c = f"C{k + 1}"
        r = sub["reference"].iloc[0]
        r_ci = sub["reference_ci"].iloc[0] if "reference_ci" in sub else 0.0
        ax.errorbar(sub["eta_exp"].iloc[0], r, yerr=r_ci or None, fmt="s", ms=7, mfc="none",
                    color=c, label=f"reference {fluid} at {ETA_EXP}")
        iv = viscosity_interval(sub)
        ax.plot([iv["lo"], iv["hi"]], [r, r], "-", color=c, lw=4, alpha=0.45,
                label=f"{fluid}: {ETA_SIM} 95 % interval {_interval_text(iv, 2)} Pa s")
        # an open end: the interval goes on beyond the grid, an arrow says which way
        for end, sign in (("lo", -1), ("hi", 1)):
            if iv[f"{end}_open"]:
                tip = iv[end] * 1.4 ** sign
                ax.annotate("", (tip, r), (iv[end], r),
                            arrowprops=dict(arrowstyle="-|>", color=c, alpha=0.6, lw=1.5))
                ax.plot([tip], [r], alpha=0)  # autoscale to the arrow's tip
    ax.set(xscale="log", xlabel=label(f"viscosity {ETA}", "Pa s"), ylabel=POWER,
           title=f"Viscosity calibration at {t['rpm'].iloc[0]:g} min$^{{-1}}$")
    ax.legend()
    fig.suptitle(SYNTHETIC_NOTE, fontsize=8)
    fig.savefig(out)


def prediction(t, out):
    """Fig. 7 of the LS1 paper: calibrated power curves vs reference, per fluid."""
    fig = Figure(figsize=(6.5, 4.6), layout="constrained")
    ax = fig.subplots()
    n = t.groupby("fluid")["rpm"].nunique().max()
    shift = dodge_step(t["rpm"], 2) if n < 3 else 0.0
    handles = []
    for k, (fluid, sub) in enumerate(t.groupby("fluid", sort=False)):
        c = f"C{k}"
        points(ax, sub["rpm"], sub["net_power"], sub["net_power_ci"], color=c, dodge=-shift)
        points(ax, sub["rpm"], sub["reference"], sub.get("reference_ci"), color=c, marker="s",
               mfc="none", ls="--", dodge=shift)
        handles.append(Patch(color=c, label=f"{fluid}: {ETA_SIM} = {sub['eta_sim'].iloc[0]:g} "
                                            "Pa s"))
    # the colour names the fluid, the symbol the source: 2 + fluids entries, not 2 x fluids;
    # the legend fills column by column: fluids on its first row, sources on its second
    sources = [Line2D([], [], color="0.3", marker="o", label=f"simulation{_replicates(t)}"),
               Line2D([], [], color="0.3", marker="s", mfc="none", ls="--", label="reference")]
    cols = max(len(handles), len(sources))
    handles = [h for i in range(cols) for h in (handles[i:i + 1] + sources[i:i + 1])]
    few_points_note(ax, n, "speed", dodged=bool(shift))
    ax.set(xlabel=RPM, ylabel=POWER, ylim=(0, None),
           title="Calibrated model vs reference power (95 % intervals)")
    fig.legend(handles=handles, loc="outside lower center", ncols=cols)
    fig.suptitle(SYNTHETIC_NOTE, fontsize=8)
    fig.savefig(out)
