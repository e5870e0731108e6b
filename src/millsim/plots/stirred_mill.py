"""Stirred-mill figures (seed 004): power curves, calibration residuals (Figs 5-7), contact
typology bars (Fig 9), collision-frequency region maps (Fig 8) and coarse-grained velocity fields
(Fig 11). Matplotlib without pyplot state; inputs are the aggregate netCDF of
``millsim aggregate stirred_mill`` or the calibration CSV tables of ``millsim analyse stirred-mill``.
"""

import numpy as np
from matplotlib.figure import Figure

from ..analysis.stirred_mill import friction_ssr

SYNTHETIC_NOTE = "reference: see config/reference/SOURCES.md (shipped: synthetic twin, not a measurement)"


def _cases(ds):
    """(label, sub-dataset) for every (eta, rpm) of an aggregate stacked over eta and rpm."""
    for eta in ds["eta"].values:
        for rpm in ds["rpm"].values:
            yield f"eta {eta:g} Pa s, {rpm:g} rpm", ds.sel(eta=eta, rpm=rpm)


def power(ds, out):
    """Net power vs agitator speed, one curve per simulation viscosity (95% intervals)."""
    fig = Figure(figsize=(6.5, 4.5), layout="constrained")
    ax = fig.subplots()
    for eta in ds["eta"].values:
        sub = ds.sel(eta=eta)
        ax.errorbar(sub["rpm"], sub["net_power"], yerr=sub["net_power_ci"], fmt="o-", capsize=3,
                    label=f"eta_sim = {eta:g} Pa s")
    fr = ds.attrs.get("param_friction", "")
    ax.set(xlabel="agitator speed [min-1]", ylabel="net power [W]", ylim=(0, None),
           title=f"Net power vs speed and viscosity (mu = {fr}, domain of the case files)")
    ax.legend()
    fig.savefig(out, dpi=120)


def typology(ds, out):
    """Dissipated energy by contact typology per case (stacked %), and energy-balance closure."""
    labels, fracs, totals, errors = [], [], [], []
    for label, sub in _cases(ds):
        labels.append(label.replace(", ", "\n"))
        fracs.append(100 * sub["typology_fraction"].values)
        totals.append(float(sub["dissipation_power"].sum()))
        errors.append(100 * float(sub["energy_balance_error"]))
    fracs = np.array(fracs)
    fig = Figure(figsize=(max(6, 1.3 * len(labels)), 7), layout="constrained")
    ax, ax2 = fig.subplots(2, 1, height_ratios=(3, 1.2))
    bottom = np.zeros(len(labels))
    for k, name in enumerate(ds["typology"].values):
        ax.bar(labels, fracs[:, k], bottom=bottom, label=str(name))
        bottom += fracs[:, k]
    for x, tot in enumerate(totals):
        ax.text(x, 101, f"{tot:.2g} W", ha="center", fontsize="small")
    ax.set(ylabel="% of dissipated energy", ylim=(0, 112),
           title="Dissipation by contact typology\n(torsion = 0: no twisting torque in the model)")
    ax.legend(ncol=4, fontsize="small", loc="lower right")
    ax.tick_params(axis="x", labelsize="x-small")
    ax2.bar(labels, errors, color="grey")
    ax2.axhline(2, color="r", lw=0.8, ls="--")
    ax2.axhline(-2, color="r", lw=0.8, ls="--")
    ax2.set(ylabel="energy balance\nresidual [% of input]")
    ax2.tick_params(axis="x", labelsize="x-small")
    fig.savefig(out, dpi=120)


def regions(ds, out):
    """Relative collision frequency (%) in the 9 regions: rings 1-3 x front/centre/back."""
    cases = list(_cases(ds))
    cols = min(3, len(cases))
    rows = int(np.ceil(len(cases) / cols))
    fig = Figure(figsize=(3.2 * cols, 2.9 * rows), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols)).ravel()
    for ax, (label, sub) in zip(axes, cases):
        grid = sub["collision_frequency_relative"].values.reshape(3, 3)[::-1]  # outer ring on top
        ax.imshow(grid, cmap="Oranges", vmin=0, vmax=max(25, grid.max()))
        for r in range(3):
            for c in range(3):
                ax.text(c, r, f"{3 - r}{'FCB'[c]}\n{grid[r, c]:.1f}%", ha="center", va="center",
                        fontsize="small")
        ax.set(xticks=range(3), xticklabels=["front", "centre", "back"], yticks=range(3),
               yticklabels=["ring 3", "ring 2", "ring 1"], title=label)
        ax.title.set_fontsize("small")
    for ax in axes[len(cases):]:
        ax.set_visible(False)
    fig.suptitle("Relative bead-bead collision frequency by region")
    fig.savefig(out, dpi=120)


def velocity(ds, out):
    """Coarse-grained translational and rotational speed on the axial slab, per case."""
    cases = list(_cases(ds))
    fig = Figure(figsize=(7, 3.1 * len(cases)), layout="constrained")
    axes = np.atleast_2d(fig.subplots(len(cases), 2))
    y, z = ds["gy"].values, ds["gz"].values
    ext = (y[0] * 1.05e3, y[-1] * 1.05e3, z[0] * 1.05e3, z[-1] * 1.05e3)
    for (label, sub), (a1, a2) in zip(cases, axes):
        im = a1.imshow(sub["cg_speed"].values, origin="lower", extent=ext, cmap="viridis")
        fig.colorbar(im, ax=a1, label="|v| [m s-1]")
        step = max(1, len(y) // 12)
        Y, Z = np.meshgrid(y * 1e3, z * 1e3)
        a1.quiver(Y[::step, ::step], Z[::step, ::step], sub["cg_vy"].values[::step, ::step],
                  sub["cg_vz"].values[::step, ::step], color="w", scale=None)
        im = a2.imshow(sub["cg_spin"].values, origin="lower", extent=ext, cmap="magma")
        fig.colorbar(im, ax=a2, label="|w| [rad s-1]")
        a1.set(title=f"translational, {label}", xlabel="y [mm]", ylabel="z [mm]")
        a2.set(title="rotational", xlabel="y [mm]")
        a1.title.set_fontsize("small")
    fig.savefig(out, dpi=110)


def friction(t, out):
    """Seed Fig. 5: dry power vs speed per friction with the reference; residuals vs friction
    (from the stage 1 residual table)."""
    s = friction_ssr(t)
    fig = Figure(figsize=(11, 4.5), layout="constrained")
    a, b = fig.subplots(1, 2)
    for mu, sub in t.groupby("friction"):
        a.errorbar(sub["rpm"], sub["net_power"], yerr=sub["net_power_ci"], fmt="o-", capsize=2,
                   label=f"simulation mu = {mu:g}")
    ref = t.drop_duplicates("rpm").sort_values("rpm")
    a.plot(ref["rpm"], ref["reference"], "ks--", label="reference (dry)")
    a.set(xlabel="agitator speed [min-1]", ylabel="net power [W]", title="a. dry power vs speed")
    a.legend(fontsize="small")
    b.plot(s["friction"], s["ssr"], "o-")
    b.set(xlabel="friction coefficient mu", ylabel="sum of squared residuals [W2]",
          title="b. residuals (minimum = calibrated mu)")
    fig.suptitle(SYNTHETIC_NOTE, fontsize="small")
    fig.savefig(out, dpi=120)


def viscosity(t, out):
    """Seed Fig. 6: power at the calibration speed vs eta_sim; reference per fluid vs eta_exp."""
    fig = Figure(figsize=(6.5, 4.5), layout="constrained")
    ax = fig.subplots()
    sim = t.drop_duplicates("eta_sim").sort_values("eta_sim")
    ax.errorbar(sim["eta_sim"], sim["net_power"], yerr=sim["net_power_ci"], fmt="o-", capsize=3,
                label="simulation vs eta_sim")
    for fluid, sub in t.groupby("fluid"):
        ax.axhline(sub["reference"].iloc[0], ls="--", lw=0.8, color="grey")
        ax.plot(sub["eta_exp"].iloc[0], sub["reference"].iloc[0], "s", ms=8,
                label=f"reference {fluid} (at eta_exp)")
    ax.set(xscale="log", xlabel="viscosity [Pa s]", ylabel="net power [W]",
           title=f"Viscosity calibration at {t['rpm'].iloc[0]:g} rpm")
    ax.legend(fontsize="small")
    fig.savefig(out, dpi=120)


def prediction(t, out):
    """Seed Fig. 7: calibrated power curves vs reference, per fluid."""
    fig = Figure(figsize=(6.5, 4.5), layout="constrained")
    ax = fig.subplots()
    for k, (fluid, sub) in enumerate(t.groupby("fluid", sort=False)):
        c = f"C{k}"
        ax.errorbar(sub["rpm"], sub["net_power"], yerr=sub["net_power_ci"], fmt="o-", color=c,
                    capsize=2, label=f"simulation {fluid} (eta_sim {sub['eta_sim'].iloc[0]:g})")
        ax.plot(sub["rpm"], sub["reference"], "s--", color=c, mfc="none", label=f"reference {fluid}")
    ax.set(xlabel="agitator speed [min-1]", ylabel="net power [W]",
           title="Calibrated model vs reference power")
    ax.legend(fontsize="x-small")
    fig.savefig(out, dpi=120)
