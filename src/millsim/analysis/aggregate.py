"""Stack case files along their swept parameters into one Dataset (pure xarray).

The aggregate keeps what is compared across cases: scalars, size distributions, maps and
force-chain statistics. Per-case records (time series, fracture events, size snapshots) differ in
length from case to case and stay in the case files; scene summaries reduce them first.
"""

import json
import os
from collections.abc import Callable, Iterable, Sequence

import pandas as pd
import xarray as xr

from ..io import case_parameters, read_case

__all__ = ["aggregate", "stack_cases", "swept_parameters", "write_aggregate"]

PER_CASE_DIMS = ("time", "event", "snapshot")


def swept_parameters(cases: Sequence[xr.Dataset]) -> list[str]:
    """Names of the parameters whose values differ between ``cases``, sorted."""
    params = [case_parameters(ds) for ds in cases]
    first, *rest = params
    return [key for key in sorted(first) if any(p.get(key) != first[key] for p in rest)]


def stack_cases(cases: Sequence[xr.Dataset], over: Sequence[str],
                coord_attrs: dict[str, dict] | None = None) -> xr.Dataset:
    """One Dataset with a dimension per parameter in ``over``, sorted by value.

    Variables along the per-case dimensions are dropped, and so is a scalar variable named like a
    stacking dimension (it becomes that coordinate). Global attributes equal in every case are kept
    (scene, fixed parameters, engine hash); those that differ are dropped. ``coord_attrs`` gives the
    units and long name of each stacking coordinate.
    """
    if not over:
        raise ValueError("over: name at least one parameter to stack the cases along")
    keys = []
    for ds in cases:
        params = case_parameters(ds)
        for name in over:
            if name not in params:
                raise ValueError(f"{name}: not a parameter of scene {ds.attrs.get('scene')!r}")
        keys.append(tuple(params[name] for name in over))
    if len(set(keys)) < len(keys):
        raise ValueError(f"over: several cases share the same values of {', '.join(over)}")

    trimmed = [ds.drop_vars([name for name, var in ds.variables.items()
                             if name in over or set(var.dims) & set(PER_CASE_DIMS)])
               for ds in cases]
    stacked = xr.concat(trimmed, dim="case", data_vars="all", coords="minimal", compat="override",
                        join="outer", combine_attrs="drop_conflicts")
    index = pd.MultiIndex.from_tuples(keys, names=list(over))
    stacked = stacked.assign_coords(xr.Coordinates.from_pandas_multiindex(index, "case"))
    stacked = stacked.unstack("case").sortby(list(over)).transpose(*over, ...)
    for name in over:
        stacked[name].attrs.update((coord_attrs or {}).get(name, {"units": "1"}))
    stacked.attrs["stacked_over"] = json.dumps(list(over))
    return stacked


def _ballmill_case_summary(ds: xr.Dataset) -> xr.Dataset:
    """Reduce the size snapshots of one ball-mill case to their mean and spread."""
    if "size_distribution" not in ds:
        return ds
    mass = ds["size_distribution"]
    fraction = mass / mass.sum("size_class")
    return ds.assign(
        size_distribution_mean=mass.mean("snapshot").assign_attrs(
            units=mass.attrs["units"], long_name="mass per size class, mean over snapshots"),
        mass_fraction=fraction.mean("snapshot").assign_attrs(
            units="1", long_name="mass fraction per size class, mean over snapshots"),
        mass_fraction_std=fraction.std("snapshot").assign_attrs(
            units="1", long_name="standard deviation of the mass fraction over snapshots"),
    )


def _ballmill_summary(ds: xr.Dataset) -> xr.Dataset:
    """Comminution rate relative to its maximum over n/n_c (as in Fig. 6 of seed 000)."""
    if "chain_count" in ds:  # a chain length absent from one case was counted zero times there
        ds["chain_count"] = ds["chain_count"].fillna(0.0)
    if "comminution_rate" not in ds:
        return ds
    if "n_over_nc" not in ds.dims:
        raise ValueError("over: the ball-mill rate is normalised along n_over_nc; stack over it")
    peak = ds["comminution_rate"].max("n_over_nc")
    ds["relative_rate"] = (ds["comminution_rate"] / peak).assign_attrs(
        units="1", long_name="comminution rate relative to its maximum over n/n_c")
    # the maximum is taken as exact, so the relative interval is the absolute one scaled
    ds["relative_rate_ci"] = (ds["comminution_rate_ci"] / peak).assign_attrs(
        units="1", long_name="95% half-width of the relative comminution rate")
    return ds


# scene -> (per-case summary, summary of the stacked dataset)
SCENE_SUMMARIES: dict[str, tuple[Callable, Callable]] = {
    "ballmill2d": (_ballmill_case_summary, _ballmill_summary),
}


def aggregate(scene: str, paths: Iterable[str | os.PathLike[str]],
              over: Sequence[str] | None = None,
              coord_attrs: dict[str, dict] | None = None) -> xr.Dataset:
    """Read the case files of ``scene`` and stack them along ``over``.

    ``over`` defaults to the parameters that differ between the cases.
    """
    paths = [os.fspath(p) for p in paths]
    cases = [read_case(p) for p in paths]
    for path, ds in zip(paths, cases):
        if ds.attrs.get("scene") != scene:
            raise ValueError(f"{path}: a case of scene {ds.attrs.get('scene')!r}, not {scene!r}")
    over = list(over or swept_parameters(cases))
    per_case, summary = SCENE_SUMMARIES.get(scene, (lambda ds: ds, lambda ds: ds))
    stacked = summary(stack_cases([per_case(ds) for ds in cases], over, coord_attrs))
    stacked.attrs["source_cases"] = json.dumps(paths)
    return stacked


def write_aggregate(ds: xr.Dataset, path: str | os.PathLike[str]) -> None:
    """Write an aggregate to netCDF4 (CF: no fill values on coordinates)."""
    encoding = {name: {"_FillValue": None} for name in ds.coords}
    ds.to_netcdf(path, engine="netcdf4", format="NETCDF4", encoding=encoding)
