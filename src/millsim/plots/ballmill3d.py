"""3D ball-mill study figures from an aggregate of ``millsim aggregate ballmill3d`` (stacked over
n_over_nc x filling; millsim.analysis.ballmill3d adds the Morrell references).

Each function draws one figure of the registry (millsim.plots: ``ballmill3d_<name>``).
Matplotlib without pyplot state.
"""

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from ..analysis.ballmill3d import FILLING, PEAK_RANGE, SPEED, reference_power
from .style import SYMBOL, dense, dodge_step, few_points_note, label, points

N_NC = SYMBOL["n_over_nc"]
# ballmill3d contact types, one colour each (the scene's order)
CONTACT_COLOURS = {"ball-ball": "C0", "ball-ore": "C1", "ore-ore": "C2", "ball-liner": "C3",
                   "ore-liner": "C4"}


def _fill(j):
    return f"J = {j:g}"


def power(ds: xr.Dataset, out: str) -> None:
    """Mean drive power against n/n_c per filling with its 95 % half-width, Morrell's net power
    scaled by least squares beside it, the 0.7-0.9 band and the interpolated maxima."""
    fig = Figure(figsize=(7, 4.8), layout="constrained")
    ax = fig.subplots()
    fillings = ds[FILLING].values
    step = dodge_step(ds[SPEED].values, len(fillings))
    grid = dense(float(ds[SPEED].min()) * 0.9, min(float(ds[SPEED].max()) * 1.05, 1.2))
    curve = reference_power(ds, grid)
    ax.axvspan(*PEAK_RANGE, color="0.9", lw=0, label=f"{PEAK_RANGE[0]:g}-{PEAK_RANGE[1]:g} "
                                                     "of critical")
    n = 0
    for k, j in enumerate(fillings):
        sub, colour = ds.sel({FILLING: j}), f"C{k % 10}"
        n = max(n, points(ax, sub[SPEED], sub["power"], sub["power_half_width"],
                          dodge=(k - (len(fillings) - 1) / 2) * step, color=colour,
                          label=f"simulation, {_fill(j)}, 95 % interval"))
        scale = float(sub["power_reference_scale"])
        ax.plot(grid, curve.sel({FILLING: j}), "--", color=colour, lw=1,
                label=f"Morrell (1996) C-model x {scale:.3g}, {_fill(j)}")
        peak = float(sub["power_peak_speed"])
        if np.isfinite(peak):
            ax.axvline(peak, color=colour, lw=0.8, ls=":",
                       label=f"simulated maximum at {N_NC} = {peak:.3f}")
    few_points_note(ax, n, "speed", dodged=len(fillings) > 1)
    top = float((ds["power"] + ds["power_half_width"]).max())
    ax.set(xlabel=label(f"rotation speed {N_NC}"), ylabel=label("mean drive power", "W"),
           ylim=(0, 1.6 * top), title="Drive power vs rotation speed (3D ball mill)")
    ax.legend(loc="upper left", ncols=2)
    fig.savefig(out)


def charge_shape(ds: xr.Dataset, out: str) -> None:
    """Toe and shoulder angles against n/n_c per filling, with Morrell's empirical relations."""
    fig = Figure(figsize=(7, 4.8), layout="constrained")
    ax = fig.subplots()
    for k, j in enumerate(ds[FILLING].values):
        sub, colour = ds.sel({FILLING: j}), f"C{k % 10}"
        for name, marker in (("shoulder", "o"), ("toe", "s")):
            points(ax, sub[SPEED], np.degrees(sub[f"{name}_angle"]), color=colour,
                   marker=marker, label=f"{name}, simulation, {_fill(j)}")
            ax.plot(sub[SPEED], np.degrees(sub[f"{name}_angle_morrell"]), ls="--", lw=1,
                    color=colour, label=f"{name}, Morrell (1996), {_fill(j)}")
    ax.axhline(0.0, color="0.5", lw=0.6)
    ax.set(xlabel=label(f"rotation speed {N_NC}"),
           ylabel="angle from the vertical below the axis [deg]\n(positive: direction of rotation)",
           ylim=(-180, 300), title="Charge toe and shoulder vs rotation speed")
    ax.legend(loc="upper left", ncols=2)
    fig.savefig(out)


def spectra(ds: xr.Dataset, out: str) -> None:
    """Impacts per second against impact energy per contact type, one panel per speed and
    filling (log-log); normal solid, tangential dashed. Says so where the cases hold none."""
    if "impact_rate_normal" not in ds:
        fig = Figure(figsize=(6, 2.5), layout="constrained")
        ax = fig.subplots()
        ax.axis("off")
        ax.text(0.5, 0.5, "The cases hold no impact-energy spectra\n(impact_rate_normal): "
                "run the scene with the spectra recorded.", ha="center", va="center")
        fig.savefig(out)
        return
    speeds, fillings = ds[SPEED].values, ds[FILLING].values
    fig = Figure(figsize=(3.2 * len(speeds), 2.9 * len(fillings) + 0.8), layout="constrained")
    axes = fig.subplots(len(fillings), len(speeds), squeeze=False, sharex=True, sharey=True)
    energy = ds["energy_bin"].values
    for row, j in enumerate(fillings):
        for col, s in enumerate(speeds):
            ax, case = axes[row, col], ds.sel({FILLING: j, SPEED: s})
            for kind in ds["contact_type"].values:
                colour = CONTACT_COLOURS.get(str(kind), "k")
                for name, ls in (("impact_rate_normal", "-"), ("impact_rate_tangential", "--")):
                    rate = case[name].sel(contact_type=kind).values
                    ax.loglog(energy, np.where(rate > 0, rate, np.nan), ls=ls, color=colour,
                              marker=".", label=str(kind) if ls == "-" else None)
            ax.set_title(f"{N_NC} = {s:g}, {_fill(j)}")
            if col == 0:
                ax.set_ylabel(label("impacts per second", "s-1"))
            if row == len(fillings) - 1:
                ax.set_xlabel(label("impact energy", "J"))
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=len(labels),
               title="contact type (solid: normal, dashed: tangential energy)")
    fig.savefig(out)


def breakage_rate(ds: xr.Dataset, out: str) -> None:
    """Selection function (breakage rate per size class) per speed, one panel per filling."""
    fillings = ds[FILLING].values
    fig = Figure(figsize=(6.4, 4.4 * len(fillings)), layout="constrained")
    axes = fig.subplots(len(fillings), 1, squeeze=False)[:, 0]
    size = ds["size_class"].values * 1e3
    for ax, j in zip(axes, fillings):
        drawn = 0
        for k, s in enumerate(ds[SPEED].values):
            case = ds.sel({FILLING: j, SPEED: s})
            rate, half = case["breakage_rate"].values, case["breakage_rate_half_width"].values
            ok = rate > 0  # a class without breakage has no point on log axes
            if not ok.any():
                continue
            drawn += int(ok.sum())
            # the lower bar stops short of zero, which log axes cannot show
            low = np.minimum(half[ok], 0.999 * rate[ok])
            ax.errorbar(size[ok], rate[ok], yerr=[low, half[ok]], marker="o",
                        color=f"C{k % 10}", label=f"{N_NC} = {s:g}")
        ax.set(title=f"Breakage rate per size class, {_fill(j)}",
               xlabel=label("lower edge of the size class", "mm"),
               ylabel=label("breakage rate (selection function)", "s-1"))
        if drawn:
            ax.set(xscale="log", yscale="log")
            ax.legend(loc="lower right", title="rotation speed")
        else:  # nothing to put on log axes
            ax.text(0.5, 0.5, "no breakage recorded in these cases", transform=ax.transAxes,
                    ha="center")
    fig.savefig(out)
