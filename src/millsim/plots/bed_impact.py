"""Bed-impact figures (Figs 20-23 of Tavares et al. 2021) from the aggregate
of ``millsim aggregate bed_impact`` (``results/aggregate/bed_breakage.nc``, with the seed statistics
of millsim.analysis.bed_impact):

- ``bed_broken_mass`` (Fig. 22 of the paper): broken mass (% passing 4.75 mm) against impact energy
  per bed configuration and material; and, where several configurations were run at the reference
  energy (3.05 J, or the energy closest to it), one bar per configuration there;
- ``bed_capture_radius`` (Fig. 20 of the paper): capture radius against impact energy;
- ``bed_size_distributions`` (Figs 21 and 23 of the paper): product size distributions, one panel
  per bed run at several energies (a line per energy) and one per material run in several
  configurations at the reference energy (a line per configuration).

The paper's measured values exist only as figures; nothing here draws or stores them.
"""

import matplotlib
import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

from .style import few_points_note, label, points

REFERENCE_ENERGY = 3.05  # J, Figs 22-23 of the paper
ENERGY = label("impact energy", "J")


def _configs(ds):
    """(rings, layers, label) of the bed configurations present, monolayers first."""
    out = []
    for layers in ds["layers"].values:
        for rings in ds["rings"].values:
            sel = ds["broken_fraction_mean"].sel(rings=rings, layers=layers)
            if bool(sel.notnull().any()):
                n = 1 + 3 * int(rings) * (int(rings) + 1)
                ring = f"{int(rings)} ring{'s' if int(rings) != 1 else ''}"
                lab = (f"{n} particle{'s' if n != 1 else ''} ({ring})" if int(layers) == 1
                       else f"{int(layers)} layers ({ring})")
                out.append((rings, layers, lab))
    return sorted(out, key=lambda c: (c[1], c[0]))


def _beds(ds):
    """(material, rings, layers, label, sub-dataset along impact_energy and seed) of every bed."""
    for mat in ds["material"].values:
        for rings, layers, lab in _configs(ds.sel(material=mat)):
            yield (mat, rings, layers, f"{str(mat).replace('_', ' ')}, {lab}",
                   ds.sel(material=mat, rings=rings, layers=layers))


def _spaced(values, gap):
    """The values in ascending order, each kept only if at least ``gap`` above the last kept."""
    kept = []
    for v in sorted(float(v) for v in values):
        if not kept or v - kept[-1] >= gap:
            kept.append(v)
    return kept


def _plain_log_ticks(axis):
    """Log-axis ticks at 1, 2, 5 x 10^k written as plain numbers ("2", not "2 x 10^0")."""
    axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FormatStrFormatter("%g"))
    axis.set_minor_formatter(NullFormatter())


def _reference_energy(ds):
    e = ds["impact_energy"].values
    return e[int(np.argmin(np.abs(e - REFERENCE_ENERGY)))]


def _seeds_note(ds):
    n = int(ds["replicates"].max()) if "replicates" in ds else ds.sizes.get("seed", 1)
    return "one seed per point: no spread shown" if n < 2 else f"mean of up to {n} seeds, +- sd"


def broken_mass(ds: xr.Dataset, out: str) -> None:
    """Fig. 22 of the paper: broken mass against impact energy per bed (mean +- sd over seeds,
    single seeds as dots); bars per configuration at the reference energy where several were run."""
    e_ref = _reference_energy(ds)
    at_ref = ds.sel(impact_energy=e_ref)
    configs = _configs(at_ref)
    bars = len(configs) > 1
    fig = Figure(figsize=(11.0 if bars else 6.2, 4.3), layout="constrained")
    axes = fig.subplots(1, 2 if bars else 1, squeeze=False)[0]
    ax = axes[0]
    e = ds["impact_energy"].values
    n = 0
    beds = list(_beds(ds))
    if bars:  # the beds run at one energy are the bars; here only those run at several
        ladders = [bed for bed in beds if np.isfinite(bed[4]["broken_fraction_mean"]).sum() > 1]
        beds = ladders or beds
    for k, (_, _, _, lab, sub) in enumerate(beds):
        c = f"C{k % 10}"
        mean = 100 * sub["broken_fraction_mean"].values
        std = 100 * sub["broken_fraction_std"].values
        n = max(n, points(ax, e, mean, np.nan_to_num(std), color=c, label=lab))
        per_seed = 100 * sub["broken_fraction"].values  # (energy, seed)
        if per_seed.shape[-1] > 1:
            for s in range(per_seed.shape[-1]):
                ax.plot(e, per_seed[:, s], ".", color=c, alpha=0.4)
    few_points_note(ax, n, "energy")
    ax.axvline(e_ref, color="0.5", ls=":", lw=1,
               label=f"{e_ref:g} J (Fig. 22 of Tavares et al. 2021)")
    ax.set(xscale="log", xlabel=ENERGY, ylabel="broken mass, passing 4.75 mm [%]",
           ylim=(0, 105), title=f"Broken mass against impact energy ({_seeds_note(ds)})")
    _plain_log_ticks(ax.xaxis)
    ax.legend(loc="upper left")
    if bars:
        b = axes[1]
        mats = list(at_ref["material"].values)
        width = 0.8 / len(mats)
        x = np.arange(len(configs))
        for k, mat in enumerate(mats):
            sel = [at_ref.sel(material=mat, rings=r, layers=lay) for r, lay, _ in configs]
            b.bar(x + (k - (len(mats) - 1) / 2) * width,
                  [100 * float(s["broken_fraction_mean"]) for s in sel], width,
                  yerr=[100 * np.nan_to_num(float(s["broken_fraction_std"])) for s in sel],
                  label=str(mat).replace("_", " "))
        b.set_xticks(x, [c[2] for c in configs], rotation=20, ha="right")
        b.set(xlabel="bed configuration", ylabel="broken mass, passing 4.75 mm [%]",
              ylim=(0, 105),
              title=f"Per bed configuration at {e_ref:g} J (Fig. 22 of Tavares et al. 2021)")
        b.grid(False, axis="x")
        b.legend()
    fig.savefig(out)


def _site_radii(rings, layers, ds):
    """(radius [mm], name) of every distinct horizontal distance of a bed particle's site from the
    ball's axis: the values a broken original particle's distance takes (it barely moves before
    it breaks). Layer-A sites are named by their hexagonal ring, layer-B sites 'layer 2'."""
    from ..scenes.bed_impact import bed_positions

    d = float(ds.attrs.get("param_particle_diameter", np.nan))
    spacing = float(ds.attrs.get("param_spacing", np.nan))
    if not np.isfinite(d * spacing):
        return []
    sites = bed_positions(int(rings), int(layers), d, spacing)
    lowest = np.isclose(sites[:, 2], sites[:, 2].min())
    out = {}
    for xy, a in zip(sites[:, :2], lowest):
        r = round(float(np.hypot(*xy)) * 1e3, 6)
        # a hexagonal ring k spans k sqrt(3)/2 to k pitches from the centre
        ring = int(np.ceil(r / (spacing * d * 1e3) - 1e-6))
        out.setdefault(r, ("centre" if ring == 0 else f"ring {ring}") if a else "layer 2")
    return sorted(out.items())


def capture_radius(ds: xr.Dataset, out: str) -> None:
    """Fig. 20 of the paper: capture radius against impact energy. A seed's capture radius is the
    distance of one particle from the ball axis, at or just beyond its site's radius (it moves a
    little before it breaks), so each seed's value is a symbol near one of the site radii (guide
    lines, named on the right), symbol area the number of seeds with that value; no line joins
    the energies, as the radius jumps between sites."""
    fig = Figure(figsize=(6.6, 4.8), layout="constrained")
    ax = fig.subplots()
    beds = list(_beds(ds))
    sites = {}
    # colour by bed configuration, marker by material: 21 beds of the paper's matrix stay apart
    configs = sorted({(int(r), int(n)) for _, r, n, _, _ in beds}, key=lambda c: (c[1], c[0]))
    materials = list(dict.fromkeys(str(m) for m, *_ in beds))
    for k, (material, rings, layers, lab, sub) in enumerate(beds):
        c = f"C{configs.index((int(rings), int(layers))) % 10}"
        marker = "osD^v<>"[materials.index(str(material)) % 7]
        # beds side by side around each energy (log axis: a constant factor), within x/÷ 1.15
        # of it whatever their number, so that no bed seems to have run at another energy
        middle = max((len(beds) - 1) / 2, 1.0)
        shift = 1.15 ** ((k - (len(beds) - 1) / 2) / middle)
        per_seed = 1e3 * sub["capture_radius"].values.reshape(len(sub["impact_energy"]), -1)
        for e, values in zip(sub["impact_energy"].values, per_seed):
            values = np.sort(values[np.isfinite(values)])
            # seeds at one site differ by micrometres (the particle moves a little before it
            # breaks): one symbol per run of values less than 0.05 mm apart, at their mean
            groups = np.split(values, np.flatnonzero(np.diff(values) > 0.05) + 1)
            radius = [g.mean() for g in groups if g.size]
            count = np.array([g.size for g in groups if g.size])
            ax.scatter(np.full(len(radius), e * shift), radius, s=36 * count, color=c,
                       marker=marker, edgecolor="white", linewidth=0.5, zorder=3)
        ax.scatter([], [], s=36, color=c, marker=marker, label=lab)
        sites.update(_site_radii(rings, layers, ds))
    top = max([r for r in sites] + [float(np.nanmax(1e3 * ds["capture_radius"].values))])
    for r in sites:
        ax.axhline(r, color="0.6", ls=":", lw=0.8, zorder=1)
    ax.set(xscale="log", xlabel=ENERGY, ylabel=label("capture radius", "mm"),
           ylim=(-0.06 * top, 1.08 * top),
           title="Capture radius: largest distance of a broken bed particle\nfrom the ball axis "
                 "(0: only the central particle broke)")
    ax.grid(False)  # the site radii are the horizontal guides, the energies the ticks
    energies = _spaced(np.log(ds["impact_energy"].values), 0.04)
    ax.set_xticks(np.exp(energies), [f"{e:g}" for e in np.exp(energies)])
    ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
    if sites:
        # the values it can take are the ticks: in mm on the left, by ring on the right; labels
        # closer than 4 % of the axis would overprint, so only the first of such a group is named
        named = _spaced(list(sites), 0.06 * 1.14 * top)
        ax.set_yticks(named, [f"{r:.3g}" for r in named])
        names = ax.secondary_yaxis("right")
        names.set_yticks(named, [sites[r] for r in named], fontsize=7, color="0.35")
        names.tick_params(length=0)
    seeds = int(ds.sizes.get("seed", 1))
    fig.legend(loc="outside lower center", ncols=2,
               title="one symbol per seed" if seeds == 1 else
               f"symbols: {seeds} seeds; area: seeds within 0.05 mm of each other")
    fig.savefig(out)


def size_distributions(ds: xr.Dataset, out: str) -> None:
    """Figs. 21 and 23 of the paper: product size distributions (mean over seeds), per impact energy
    for every bed run at several energies, and per bed configuration at the reference energy for
    every material run in several configurations."""
    panels = []
    energies = ds["impact_energy"].values
    cmap, norm = matplotlib.colormaps["plasma"], matplotlib.colors.LogNorm(energies.min(),
                                                                            energies.max() * 1.0001)
    for *_, lab, sub in _beds(ds):
        lines = [(f"{e:g} J", cmap(0.85 * norm(e)),
                  sub["passing_fraction_mean"].sel(impact_energy=e))
                 for e in energies
                 if bool(sub["passing_fraction_mean"].sel(impact_energy=e).notnull().all())]
        # a product without fines (nothing broke) has no point on the log axes: say so
        lines = [(name if float(var[1:].max()) > 0 else f"{name}: nothing broke", c, var)
                 for name, c, var in lines]
        if len(lines) > 1:
            panels.append((f"{lab}\nper impact energy (Fig. 21 of Tavares et al. 2021)", lines))
    e_ref = _reference_energy(ds)
    at_ref = ds.sel(impact_energy=e_ref)
    for mat in at_ref["material"].values:
        configs = _configs(at_ref.sel(material=mat))
        if len(configs) > 1:
            panels.append((f"{str(mat).replace('_', ' ')}\nper bed configuration at {e_ref:g} J "
                           "(Fig. 23 of Tavares et al. 2021)",
                           [(lab, f"C{k % 10}", at_ref["passing_fraction_mean"].sel(
                               material=mat, rings=r, layers=lay))
                            for k, (r, lay, lab) in enumerate(configs)]))
    if not panels:  # one bed at one energy
        panels = [(lab, [(f"{e_ref:g} J", "C0", sub["passing_fraction_mean"].sel(
            impact_energy=e_ref))]) for *_, lab, sub in _beds(ds)]
    cols = min(len(panels), 2)
    rows = -(-len(panels) // cols)
    fig = Figure(figsize=(5.6 * cols, 4.2 * rows), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    sieve = ds["sieve"].values * 1e3
    for ax, (title, lines) in zip(axes, panels):
        for lab, colour, var in lines:
            y = var.values * 100
            ax.loglog(sieve, np.where(y > 0, y, np.nan), "o-", ms=3, color=colour, label=lab)
        ax.set(xlabel=label("size", "mm"), ylabel="cumulative passing [%]", title=title)
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(loc="lower right")
    for ax in axes[len(panels):]:
        ax.set_visible(False)
    fig.suptitle("Product size distributions, mean over seeds\n(dummy spheres and fines spread "
                 "below their size by eq 11)")
    fig.savefig(out)
