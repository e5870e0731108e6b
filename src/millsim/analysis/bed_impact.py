"""Bed-impact study (Tavares et al. 2021, section 4.2): seed statistics of the aggregate.

``millsim aggregate bed_impact`` stacks the cases along material, rings, layers, impact_energy and
seed (a sparse grid: missing combinations are NaN); :func:`summary` (SCENE_SUMMARIES of
:mod:`.aggregate`) adds the mean, standard deviation and count over the replicates (seed). The
figures drawn from that aggregate (``results/aggregate/bed_breakage.nc``) are millsim.plots.bed_impact.
"""

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
