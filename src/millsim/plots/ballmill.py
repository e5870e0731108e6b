"""Ball-mill figures (Buchholtz et al. 2000) from an aggregate of ``millsim aggregate ballmill2d``.

Each function draws one figure of the registry (millsim.plots: ``ballmill_<name>``). Axis labels
take their units from the variables' ``units`` attributes. Matplotlib without pyplot state.
"""

import itertools
import json

import numpy as np
import xarray as xr
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Circle
from matplotlib.ticker import LogFormatter, MaxNLocator

from ..analysis.ballmill import BOND_AUSTIN_END, bond_austin_speed_factor
from .style import SYMBOL, few_points_note, label, points

SPEED = "n_over_nc"
def _label(var: xr.DataArray, name: str | None = None) -> str:
    return label(name or var.attrs.get("long_name", var.name), var.attrs.get("units", "1"))


N_NC = SYMBOL["n_over_nc"]


def _variants(ds: xr.Dataset):
    """(label, dataset along n/n_c only) for each combination of the other swept parameters."""
    others = [d for d in json.loads(ds.attrs["stacked_over"]) if d != SPEED]
    for values in itertools.product(*(ds[d].values for d in others)):
        where = dict(zip(others, values))
        yield ", ".join(f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v}"
                        for k, v in where.items()), ds.sel(where)


def _speed_colours(ds: xr.Dataset):
    speeds = ds[SPEED].values
    # viridis without its last, pale yellow sixth: symbols stay visible on white
    span = speeds.max() - speeds.min()
    colour = ScalarMappable(Normalize(speeds.min(), speeds.max() + 0.2 * span), "viridis")
    return [(s, colour.to_rgba(s)) for s in speeds]


def rate(ds: xr.Dataset, out: str) -> None:
    """Fig. 6: relative comminution rate vs n/n_c, the empirical power shape, drive power."""
    fig = Figure(figsize=(7, 7.5), layout="constrained")
    ax_rate, ax_power = fig.subplots(2, 1, sharex=True, height_ratios=(3, 2))
    n = 0
    for k, (lab, sub) in enumerate(_variants(ds)):
        suffix = f" ({lab})" if lab else ""
        n = max(n, points(ax_rate, sub[SPEED], sub["relative_rate"], sub["relative_rate_ci"],
                          color=f"C{k % 10}", label=f"simulation, 95 % interval{suffix}"))
        points(ax_power, sub[SPEED], sub["mean_drive_power"], color=f"C{k % 10}",
               label=f"simulation{suffix}")
    few_points_note(ax_power, n, "speed")
    phi = np.linspace(0.0, BOND_AUSTIN_END, 400)
    ax_rate.plot(phi, bond_austin_speed_factor(phi), "k-", lw=1,
                 label="empirical reference shape: Bond/Austin speed factor\n"
                       r"$\varphi\,(1-0.1/2^{9-10\varphi})$, normalised")
    # head room above the highest interval for the legend
    top = max(1.0, float((ds["relative_rate"] + ds["relative_rate_ci"]).max()))
    ax_rate.set(ylabel=_label(ds["relative_rate"], "relative comminution rate"),
                ylim=(0, 1.4 * top), title="Comminution rate vs rotation speed")
    ax_rate.legend(loc="upper left")
    ax_power.set(xlabel=_label(ds[SPEED], f"rotation speed {N_NC}"),
                 ylabel=_label(ds["mean_drive_power"], "mean drive power"), ylim=(0, None),
                 title="Drive power")
    ax_power.legend()
    fig.savefig(out)


def size_distributions(ds: xr.Dataset, out: str) -> None:
    """Fig. 5: cumulative % passing against grain radius for each speed, on log axes (the way
    the field reads a product size distribution), from the mean mass fraction over snapshots."""
    variants = list(_variants(ds))
    fig = Figure(figsize=(6.4, 4.6 * len(variants)), layout="constrained")
    for ax, (lab, sub) in zip(fig.subplots(len(variants), 1, squeeze=False)[:, 0], variants):
        for speed, colour in _speed_colours(sub):
            case = sub.sel({SPEED: speed})
            # mass below each class's upper bound (CF bounds of size_class)
            upper = case["size_class_bounds"].values[:, 1] * 1e6
            passing = 100 * np.cumsum(case["mass_fraction"].values)
            ax.loglog(upper, np.where(passing > 0, passing, np.nan), "o-", ms=3.5, color=colour,
                      label=f"{N_NC} = {speed:g}")
        ax.set(xlabel=label("grain radius r (upper edge of a radius class)", r"$\mu$m"),
               ylabel="cumulative passing [%]",
               title="Fragment size distribution" + (f" ({lab})" if lab else "")
               + "\n% of the grain mass with radius below r, mean over the snapshots")
        ax.grid(True, which="both", alpha=0.25)
        ax.xaxis.set_major_formatter(LogFormatter())
        ax.xaxis.set_minor_formatter(LogFormatter(minor_thresholds=(2, 1)))
        ax.legend(loc="lower right", title="rotation speed")
    fig.savefig(out)


def _maps(ds: xr.Dataset, name: str, title: str, out: str, cap: float | None = None) -> None:
    """One map of ``name`` per case on one shared grey scale, with the drum outline; coordinates
    in mm. ``cap``: the scale ends at this percentile of the non-zero cells (a single hot cell
    would otherwise leave every other one white); cells above it are drawn black."""
    panels = [(lab, sub.sel({SPEED: s}), s)
              for lab, sub in _variants(ds) for s in sub[SPEED].values]
    ncols = min(len(panels), 4)
    nrows = -(-len(panels) // ncols)
    fig = Figure(figsize=(2.9 * ncols + 1, 2.9 * nrows + 0.6), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    values = ds[name].values
    top = float(np.nanmax(values))
    if cap is not None and (values > 0).any():
        top = float(np.nanpercentile(values[values > 0], cap))
    norm = Normalize(0.0, top or 1.0)  # all zero: white, not a symmetric scale
    for ax, (lab, case, speed) in zip(axes, panels):
        mesh = ax.pcolormesh(case["gx"] * 1e3, case["gy"] * 1e3, case[name], shading="nearest",
                             cmap="Greys", norm=norm)
        radius = float(case["drum_radius"]) if "drum_radius" in case.coords \
            else float(ds.attrs["param_drum_radius"])
        ax.add_patch(Circle((0.0, 0.0), radius * 1e3, fill=False, color="tab:red", lw=1))
        ax.set(aspect="equal", title=f"{N_NC} = {speed:g}" + (f"\n{lab}" if lab else ""),
               xlabel=label("x", "mm"), ylabel=label("y", "mm"))
        ax.grid(False)
        ax.locator_params(nbins=4)
    for ax in axes[len(panels):]:
        ax.set_visible(False)
    what = _label(ds[name], title.lower())
    if cap is not None and top < float(np.nanmax(values)):
        what += f"\n(scale ends at the {cap:g}th percentile: {top:.3g})"
    fig.colorbar(mesh, ax=axes.tolist(), label=what, shrink=0.8,
                 extend="max" if top < float(np.nanmax(values)) else "neither")
    fig.suptitle(f"{title} (drum outline in red; one grey scale for all panels)")
    fig.savefig(out)


def fragmentation_maps(ds: xr.Dataset, out: str) -> None:
    """Fig. 7: where grains break, per rotation speed."""
    _maps(ds, "fracture_frequency", "Fracture frequency", out)


def pressure_maps(ds: xr.Dataset, out: str) -> None:
    """Fig. 12: time-averaged local pressure, per rotation speed."""
    _maps(ds, "pressure", "Time-averaged pressure", out, cap=99.0)


def poisson_interval(k, level=0.95):
    """Exact (Garwood) interval of a Poisson mean from the count ``k``: chi-square quantiles,
    lower 0 at k = 0."""
    from scipy.stats import chi2

    k = np.asarray(k, dtype=float)
    tail = (1.0 - level) / 2
    lo = np.where(k > 0, chi2.ppf(tail, 2 * np.maximum(k, 1)) / 2, 0.0)
    return lo, chi2.ppf(1 - tail, 2 * k + 2) / 2


def force_chains(ds: xr.Dataset, out: str) -> None:
    """Figs. 10-11: chain counts per length (with Poisson intervals), the mean maximum pressure of
    the chains of each length, and the mean force along a chain. Counts are small integers in a
    short run, so the per-length panels draw symbols per speed, shifted sideways, no lines."""
    fig = Figure(figsize=(13, 4.6), layout="constrained")
    ax_count, ax_pressure, ax_force = fig.subplots(1, 3)
    lengths = ds["chain_length"].values
    variants = [(lab, speed, colour) for lab, sub in _variants(ds)
                for speed, colour in _speed_colours(sub)]
    width = 0.6 / len(variants)
    top = 0.0
    for k, (lab, speed, colour) in enumerate(variants):
        case = dict(_variants(ds))[lab].sel({SPEED: speed})
        name = f"{N_NC} = {speed:g}" + (f", {lab}" if lab else "")
        x = lengths + (k - (len(variants) - 1) / 2) * width
        count = case["chain_count"].fillna(0).values
        lo, hi = poisson_interval(count)
        top = max(top, float(hi.max()))
        ax_count.errorbar(x, count, yerr=[count - lo, hi - count], fmt="o", color=colour,
                          label=name)
        ax_pressure.plot(x, case["chain_max_pressure"], "o", color=colour, label=name)
        ax_force.plot(case["chain_position"], case["chain_force_profile"], "o-", ms=4,
                      color=colour, label=name)
    # counts up to a few tens read on a linear axis (a zero count and its interval stay visible);
    # a long run's counts span decades
    log = top > 50
    if not log:
        ax_count.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax_count.set(yscale="log" if log else "linear", ylim=(None if log else -0.03 * top, None),
                 xlabel=_label(ds["chain_length"], "chain length L [grains]"),
                 ylabel="number of chains (all records)",
                 title="Chain-length distribution\n(bars: 95 % Poisson interval of each count)")
    ax_pressure.set(xlabel=_label(ds["chain_length"], "chain length L [grains]"),
                    ylabel=_label(ds["chain_max_pressure"], "mean maximum pressure"),
                    title="Maximum pressure in a chain\n(mean over the chains of that length)")
    ax_force.set(xlabel=_label(ds["chain_position"], "relative position along the chain"),
                 ylabel=_label(ds["chain_force_profile"], "mean force"),
                 title="Force along a chain\n(mean over all chains)")
    # the last length class also holds every longer chain
    ticks = lengths[:: max(1, len(lengths) // 6)]
    ticks = np.append(ticks[ticks < lengths[-1]], lengths[-1])
    for ax in (ax_count, ax_pressure):
        ax.set_xticks(ticks, [f"{t:g}" for t in ticks[:-1]] + [f"\u2265{lengths[-1]:g}"])
        ax.grid(False, axis="x")
    fig.legend(*ax_count.get_legend_handles_labels(), loc="outside right upper",
               title="rotation speed")
    fig.suptitle("Force chains (run without fragmentation)")
    fig.savefig(out)
