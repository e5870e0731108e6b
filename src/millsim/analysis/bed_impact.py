"""Bed-impact study (Tavares et al. 2021, section 4.2): seed statistics of the aggregate.

``millsim aggregate bed_impact`` stacks the cases along material, rings, layers, impact_energy and
seed (a sparse grid: missing combinations are NaN); :func:`summary` (SCENE_SUMMARIES of
:mod:`.aggregate`) adds the mean, standard deviation and count over the replicates (seed). The
figures drawn from that aggregate (``results/aggregate/bed_breakage.nc``) are millsim.plots.bed_impact.
"""

import math

import xarray as xr

STATS = ("broken_fraction", "broken_mass", "capture_radius", "touched_radius", "broken_particles",
         "breakage_events", "passing_fraction", "contact_time", "breakage_energy")


def summary(ds: xr.Dataset) -> xr.Dataset:
    """Mean, standard deviation (ddof 1) and count over ``seed`` of the main outputs."""
    if "seed" not in ds.dims:
        return ds
    for name in STATS:
        if name not in ds:
            continue
        var = ds[name]
        units, long = var.attrs.get("units", "1"), var.attrs.get("long_name", name)
        n = var.count("seed")
        ds[f"{name}_mean"] = var.mean("seed").assign_attrs(units=units, long_name=f"{long}, mean over seeds")
        ds[f"{name}_std"] = var.std("seed", ddof=1).where(n > 1).assign_attrs(
            units=units, long_name=f"{long}, standard deviation over seeds")
        if name == "broken_fraction":
            ds["replicates"] = n.assign_attrs(units="1", long_name="cases (seeds) per condition")
    return ds


# Tavares et al. (2021), section 4.2 (Figs 20-23), states trends in words; these are the
# conditions of config/paper.yaml's bed matrix in which each can be read.
STANDARD_ENERGY = 3.05  # J, the energy of the material and bed comparisons
LADDER = dict(material="copper_ore", rings=3, layers=1)  # the energy ladder's bed
FINE_SIEVE = 1.18e-3  # m, the sieve of "finer product"
MATERIALS = ("copper_ore", "granulite", "limestone")
ROUNDING = 1e-9  # fractions summed from fragment masses: 1 - 3e-16 is a bed broken completely
# the capture radius moves in steps of a ring (5.5 mm); the same ring after another settling
# differs by micrometres, which is no change of radius
SAME_RING = 1e-4  # m


def _mean(ds, name, impact_energy=None, sieve=None, **at):
    """The mean over seeds of ``name`` at a point; NaN where the aggregate does not have it."""
    try:
        value = ds[f"{name}_mean"].sel(**at)
        for dim, x in (("impact_energy", impact_energy), ("sieve", sieve)):
            if x is not None:  # floats from a config: matched to rounding
                value = value.sel({dim: x}, method="nearest", tolerance=1e-9 * abs(x))
        return float(value)
    except KeyError:
        return float("nan")


def _rising(values, tolerance=0.0):
    """Non-decreasing (a fall within ``tolerance`` is no fall) and the last above the first by
    more than ``tolerance``."""
    return all(b >= a - tolerance for a, b in zip(values, values[1:])) and \
        values[-1] > values[0] + tolerance


def paper_claims(ds: xr.Dataset):
    """The paper's trends, each read point by point from the aggregate's means over seeds:
    [(claim, what is here, rule, "followed" | "not followed" | "not testable here")]."""
    rows = []
    energy = dict(impact_energy=STANDARD_ENERGY)
    beds = sorted({(int(r), int(n)) for r in ds["rings"].values for n in ds["layers"].values})
    compared, followed = [], 0
    for rings, layers in beds:
        by = {m: _mean(ds, "broken_fraction", material=m, rings=rings, layers=layers, **energy)
              for m in MATERIALS}
        if any(math.isnan(v) for v in by.values()) or min(by.values()) >= 1.0 - ROUNDING:
            continue  # not run for every material, or every bed broke completely
        compared.append(f"{rings}r{layers}l")
        followed += by["limestone"] >= max(by.values()) - ROUNDING
    rows.append(("more broken mass in limestone",
                 f"limestone largest in {followed} of {len(compared)} beds at {STANDARD_ENERGY} J "
                 f"({', '.join(compared) or 'none'}; beds broken completely left out)",
                 "limestone's mean broken fraction the largest of the three in every bed",
                 "not testable here" if not compared else
                 "followed" if followed == len(compared) else "not followed"))
    mono = _mean(ds, "broken_fraction", material="copper_ore", rings=3, layers=1, **energy)
    multi = {n: _mean(ds, "broken_fraction", material="copper_ore", rings=3, layers=n, **energy)
             for n in (3, 5)}
    multi = {n: v for n, v in multi.items() if not math.isnan(v)}
    rows.append(("less broken mass in multi-layer copper ore beds",
                 f"3-ring copper ore: {100 * mono:.3g} % as a monolayer"
                 + "".join(f", {100 * v:.3g} % in {n} layers" for n, v in multi.items()),
                 "every multi-layer bed's broken fraction below the monolayer's",
                 "not testable here" if math.isnan(mono) or not multi else
                 "followed" if all(v < mono for v in multi.values()) else "not followed"))
    energies = sorted(float(e) for e in ds["impact_energy"].values)
    radius = [_mean(ds, "capture_radius", impact_energy=e, **LADDER) for e in energies]
    passing = [_mean(ds, "passing_fraction", impact_energy=e, sieve=FINE_SIEVE, **LADDER)
               for e in energies]
    ladder = [(e, r, p) for e, r, p in zip(energies, radius, passing) if not math.isnan(r)]
    for claim, column, unit, scale, tolerance in (
            ("capture radius growing with energy", 1, "mm", 1e3, SAME_RING),
            ("finer product with energy (passing 1.18 mm)", 2, "%", 100.0, 0.0)):
        values = [row[column] for row in ladder]
        rows.append((claim, "3-ring copper ore monolayer: " + (", ".join(
            f"{scale * v:.3g} {unit} at {e:g} J" for e, v in zip([r[0] for r in ladder], values))
            or "not run"),
            "non-decreasing with energy, the highest energy's above the lowest's"
            + (f" (within {scale * tolerance:g} {unit}: the same ring)" if tolerance else ""),
            "not testable here" if len(values) < 2 or any(math.isnan(v) for v in values) else
            "followed" if _rising(values, tolerance) else "not followed"))
    return rows
