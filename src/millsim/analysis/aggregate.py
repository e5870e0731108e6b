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
from . import ballmill, ballmill3d, bed_impact

__all__ = ["aggregate", "same_code", "case_cost", "stack_cases", "swept_parameters", "SCENE_SUMMARIES"]

PER_CASE_DIMS = ("time", "event", "snapshot")
# the code that computed a case: cases of two versions may differ by the change alone
CODE_ATTRS = ("engine_hash", "millsim_version")


def swept_parameters(cases: Sequence[xr.Dataset]) -> list[str]:
    """Names of the parameters whose values differ between ``cases``, sorted."""
    params = [case_parameters(ds) for ds in cases]
    first, *rest = params
    return [key for key in sorted(first) if any(p.get(key) != first[key] for p in rest)]


def _name(ds: xr.Dataset, index: int) -> str:
    return ds.encoding.get("source", f"case {index}")


def stack_cases(cases: Sequence[xr.Dataset], over: Sequence[str],
                coord_attrs: dict[str, dict] | None = None) -> xr.Dataset:
    """One Dataset with a dimension per parameter in ``over``, sorted by value.

    Every other parameter (the seed included) must be the same in every case, and no two cases
    may be the same point: an aggregate holds one study, and a parameter that differed but was not
    stacked would be lost. Variables along the per-case dimensions are dropped, and so is a scalar
    variable named like a stacking dimension (it becomes that coordinate). Global attributes equal
    in every case are kept (scene, fixed parameters, engine hash); those that differ are dropped.
    ``coord_attrs`` gives the units and long name of each stacking coordinate.
    """
    if not over:
        raise ValueError("over: name at least one parameter to stack the cases along")
    twice = [name for i, name in enumerate(over) if name in over[:i]]
    if twice:
        raise ValueError(f"over: {twice[0]} given twice; give each parameter once")
    params = [case_parameters(ds) for ds in cases]
    for name in over:
        for i, (ds, p) in enumerate(zip(cases, params)):
            if name not in p:
                raise ValueError(f"{name}: not a parameter of scene {ds.attrs.get('scene')!r} "
                                 f"({_name(ds, i)})")
    for key in sorted(set().union(*params) - set(over)):
        first = params[0].get(key)
        for i, p in enumerate(params[1:], 1):
            if p.get(key) != first:
                raise ValueError(
                    f"{key}: {first!r} in {_name(cases[0], 0)} but {p.get(key)!r} in "
                    f"{_name(cases[i], i)}; cases to stack differ only in --over "
                    f"({', '.join(over)}): stack over {key} too, or leave the odd case out")
    keys = [tuple(p[name] for name in over) for p in params]
    seen = {}
    for i, key in enumerate(keys):
        if key in seen:
            point = ", ".join(f"{name}={value!r}" for name, value in zip(over, key))
            raise ValueError(f"over: {_name(cases[seen[key]], seen[key])} and {_name(cases[i], i)} "
                             f"are the same point ({point}); replicates need different seeds, "
                             "stacked over seed")
        seen[key] = i

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


def same_code(cases: Sequence[xr.Dataset], names: Sequence[str]) -> dict[str, str]:
    """The engine hash and version common to ``cases`` (``names``: their files); cases computed
    by different code are refused, naming two of them."""
    common = {}
    for key in CODE_ATTRS:
        values = [ds.attrs.get(key) for ds in cases]
        for i, value in enumerate(values):
            if value is None:
                raise ValueError(f"{names[i]}: has no {key}; not a case written by millsim run")
            if value != values[0]:
                raise ValueError(
                    f"{key}: {values[0]} in {names[0]} but {value} in {names[i]}; cases of "
                    "different code versions do not stack: run the older ones again")
        common[key] = values[0]
    return common


def case_cost(cases: Sequence[xr.Dataset]) -> dict[str, float]:
    """The sum of the cases' wall times (``wall_time_s``, required of every case): the study's
    cost, which a results page states (analysis.results_page)."""
    return {"cases_wall_time_s": float(sum(float(ds.attrs["wall_time_s"]) for ds in cases))}


def _unchanged(ds: xr.Dataset) -> xr.Dataset:
    return ds


# scene -> (summary of each case before stacking, summary of the stacked dataset); a scene not
# named here is stacked as it is
SCENE_SUMMARIES: dict[str, tuple[Callable, Callable]] = {
    "ballmill2d": (ballmill.case_summary, ballmill.summary),
    "ballmill3d": (ballmill3d.case_summary, ballmill3d.summary),
    "bed_impact": (_unchanged, bed_impact.summary),
}


def aggregate(scene: str, paths: Iterable[str | os.PathLike[str]],
              over: Sequence[str] | None = None,
              coord_attrs: dict[str, dict] | None = None) -> xr.Dataset:
    """Read the case files of ``scene`` and stack them along ``over``.

    ``over`` defaults to the parameters that differ between the cases. The cases must come from
    one code version (``same_code``), which the aggregate records.
    """
    paths = [os.fspath(p) for p in paths]
    cases = [read_case(p, scene) for p in paths]
    code = same_code(cases, paths)
    over = list(over or swept_parameters(cases))
    per_case, summary = SCENE_SUMMARIES.get(scene, (_unchanged, _unchanged))
    stacked = summary(stack_cases([per_case(ds) for ds in cases], over, coord_attrs))
    stacked.attrs.update(code, **case_cost(cases))  # set, not left to the stacking: a summary may rebuild the attrs
    stacked.attrs["source_cases"] = json.dumps(paths)
    stacked.attrs["title"] = f"millsim {scene}: {len(paths)} cases stacked over {', '.join(over)}"
    return stacked
