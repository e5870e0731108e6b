"""Stack case files along their swept parameters into one Dataset (pure xarray).

The aggregate keeps what is compared across cases: scalars, size distributions, maps and
force-chain statistics. Per-case records (time series, fracture events, size snapshots) differ in
length from case to case and stay in the case files; scene summaries reduce them first
(SCENE_SUMMARIES). ``millsim aggregate`` writes the result with millsim.io.write_netcdf.
"""

import json
import os
from collections.abc import Callable, Iterable, Sequence

import pandas as pd
import xarray as xr

from ..io import case_parameters, read_case
from . import ballmill, bed_impact

__all__ = ["aggregate", "stack_cases", "swept_parameters", "SCENE_SUMMARIES"]

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


def _unchanged(ds: xr.Dataset) -> xr.Dataset:
    return ds


# scene -> (summary of each case before stacking, summary of the stacked dataset); a scene not
# named here is stacked as it is
SCENE_SUMMARIES: dict[str, tuple[Callable, Callable]] = {
    "ballmill2d": (ballmill.case_summary, ballmill.summary),
    "bed_impact": (_unchanged, bed_impact.summary),
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
    per_case, summary = SCENE_SUMMARIES.get(scene, (_unchanged, _unchanged))
    stacked = summary(stack_cases([per_case(ds) for ds in cases], over, coord_attrs))
    stacked.attrs["source_cases"] = json.dumps(paths)
    return stacked
