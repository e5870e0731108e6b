"""Bed-impact figures (seed 002 Figs 20-23) from the aggregate of ``millsim aggregate bed_impact``
(``results/aggregate/bed_breakage.nc``, with the seed statistics of millsim.analysis.bed_impact):

- ``bed_broken_mass`` (seed Fig. 22): broken mass (% passing 4.75 mm) per bed configuration and
  material, at the reference energy (3.05 J, or the energy closest to it);
- ``bed_capture_radius`` (seed Fig. 20): capture radius against impact energy;
- ``bed_size_energy`` (seed Fig. 21): product size distributions per impact energy;
- ``bed_size_configuration`` (seed Fig. 23): product size distributions per bed configuration.

The seed's measured values exist only as figures; nothing here draws or stores them.
"""

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

REFERENCE_ENERGY = 3.05  # J, seed Figs 22-23


def _configs(ds):
    """(rings, layers, label) of the bed configurations present, monolayers first."""
    out = []
    for layers in ds["layers"].values:
        for rings in ds["rings"].values:
            sel = ds["broken_fraction_mean"].sel(rings=rings, layers=layers)
            if bool(sel.notnull().any()):
                n = 1 + 3 * int(rings) * (int(rings) + 1)
                label = (f"{n} ({int(rings)} rings)" if int(layers) == 1
                         else f"{int(layers)} layers ({int(rings)} rings)")
                out.append((rings, layers, label))
    return sorted(out, key=lambda c: (c[1], c[0]))


def _reference_energy(ds):
    e = ds["impact_energy"].values
    return e[int(np.argmin(np.abs(e - REFERENCE_ENERGY)))]


def _save(fig, out):
    fig.tight_layout()
    fig.savefig(out, dpi=120)


def broken_mass(ds: xr.Dataset, out: str) -> None:
    """Seed Fig. 22: broken mass per bed configuration and material (mean +- sd over seeds)."""
    e = _reference_energy(ds)
    sub = ds.sel(impact_energy=e)
    configs = _configs(sub)
    mats = list(sub["material"].values)
    fig = Figure(figsize=(max(6.0, 1.1 * len(configs) + 2), 4.2))
    ax = fig.add_subplot()
    width = 0.8 / max(len(mats), 1)
    x = np.arange(len(configs))
    for k, mat in enumerate(mats):
        mean = [float(sub["broken_fraction_mean"].sel(material=mat, rings=r, layers=n)) * 100
                for r, n, _ in configs]
        std = [float(sub["broken_fraction_std"].sel(material=mat, rings=r, layers=n)) * 100
               for r, n, _ in configs]
        ax.bar(x + (k - (len(mats) - 1) / 2) * width, mean, width, yerr=np.nan_to_num(std),
               capsize=3, label=str(mat).replace("_", " "))
    ax.set_xticks(x, [c[2] for c in configs], rotation=20, ha="right")
    ax.set_xlabel("bed configuration (particles per layer)")
    ax.set_ylabel("broken mass, passing 4.75 mm [%]")
    ax.set_title(f"Single impact at {e:g} J (88 mm ball); mean +- sd over seeds", fontsize=9)
    ax.legend()
    _save(fig, out)


def capture_radius(ds: xr.Dataset, out: str) -> None:
    """Seed Fig. 20: capture radius against impact energy (each seed, and the mean), for the
    beds run at more than one energy (or every bed, when none was)."""
    fig = Figure(figsize=(6.0, 4.2))
    ax = fig.add_subplot()
    e = ds["impact_energy"].values
    swept = bool((ds["capture_radius_mean"].notnull().sum("impact_energy") > 1).any())
    for mat in ds["material"].values:
        for rings, layers, label in _configs(ds.sel(material=mat)):
            sub = ds.sel(material=mat, rings=rings, layers=layers)
            mean = sub["capture_radius_mean"].values * 1e3
            ok = np.isfinite(mean)
            if not ok.any() or (swept and ok.sum() < 2):
                continue
            line = ax.plot(e[ok], mean[ok], "o-", label=f"{str(mat).replace('_', ' ')}, {label}")[0]
            per_seed = sub["capture_radius"].values * 1e3  # (energy, seed)
            for s in range(per_seed.shape[-1]):
                ax.plot(e, per_seed[:, s], ".", color=line.get_color(), alpha=0.5)
    ax.set_xlabel("impact energy [J]")
    ax.set_ylabel("capture radius [mm]")
    ax.set_title("Capture radius (largest distance of a broken bed particle from the ball axis)",
                 fontsize=9)
    ax.legend(fontsize=8)
    _save(fig, out)


def _psd_panels(ds, groups, title, out):
    """One panel per (material, fixed selection); a line per entry of ``groups``."""
    panels = [p for p in groups if p[1]]
    fig = Figure(figsize=(5.0 * max(1, len(panels)), 4.2))
    sieve = ds["sieve"].values * 1e3
    for k, (name, lines) in enumerate(panels):
        ax = fig.add_subplot(1, max(1, len(panels)), k + 1)
        for label, var in lines:
            y = var.values * 100
            ax.loglog(sieve, np.where(y > 0, y, np.nan), "o-", ms=3, label=label)
        ax.set_xlabel("size [mm]")
        ax.set_ylabel("cumulative passing [%]")
        ax.set_title(name, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    _save(fig, out)


def size_energy(ds: xr.Dataset, out: str) -> None:
    """Seed Fig. 21: product size distributions (mean over seeds) per impact energy."""
    groups = []
    for mat in ds["material"].values:
        for rings, layers, label in _configs(ds.sel(material=mat)):
            lines = []
            for e in ds["impact_energy"].values:
                var = ds["passing_fraction_mean"].sel(material=mat, rings=rings, layers=layers,
                                                      impact_energy=e)
                if bool(var.notnull().all()):
                    lines.append((f"{e:g} J", var))
            groups.append((f"{str(mat).replace('_', ' ')}, {label}", lines))
    _psd_panels(ds, groups, "Product size distributions against impact energy (incl. fines)", out)


def size_configuration(ds: xr.Dataset, out: str) -> None:
    """Seed Fig. 23: product size distributions (mean over seeds) per bed configuration."""
    e = _reference_energy(ds)
    sub = ds.sel(impact_energy=e)
    groups = []
    for mat in sub["material"].values:
        lines = []
        for rings, layers, label in _configs(sub.sel(material=mat)):
            var = sub["passing_fraction_mean"].sel(material=mat, rings=rings, layers=layers)
            if bool(var.notnull().all()):
                lines.append((label, var))
        groups.append((str(mat).replace("_", " "), lines))
    _psd_panels(sub, groups, f"Product size distributions per bed configuration at {e:g} J", out)
