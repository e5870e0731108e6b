"""The outputs of the accuracy study (millsim.analysis.accuracy): its tables in one netCDF file
and back, and their markdown summary. ``millsim.analysis.accuracy`` imports them from here."""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr

# ---- netCDF -------------------------------------------------------------------------------------

CASE_UNITS = {"ladder_value": "1", "seed": "1", "dt": "s", "dt_limit": "s", "steps": "1",
              "wall_time_s": "s", "value": "1"}
CASE_LONG = {
    "name": "scene name of the accuracy config (ballmill, single_particle, ...)",
    "scene": "millsim scene", "series": "ladder (config accuracy.<name>.series)",
    "ladder": "the step parameter swept", "ladder_value": "its value",
    "seed": "random seed", "dt": "time step of the case", "dt_limit": "engine stability limit",
    "steps": "time steps of the case", "wall_time_s": "wall time of the case (case file)",
    "engine_hash": "millsim.provenance_hash() of the code that ran the case",
    "millsim_version": "millsim version", "parameters_json": "every scene parameter (JSON)",
    "path": "case file", "observable": "observable", "value": "its value (units: case_units)",
    "units": "units of the value",
}
POINT_UNITS = {
    "step": ("s", "time step (median over seeds)"),
    "ladder_value": ("1", "value of the ladder parameter (see ladder)"),
    "dt_limit": ("s", "the engine's stability limit of the step"),
    "steps": ("1", "time steps of the case (median over seeds)"),
    "n": ("1", "seeds"),
    "mean": ("", "mean over seeds"),
    "sd": ("", "standard deviation over seeds"),
    "error": ("", "mean - reference (paired over seeds for a finest-step reference)"),
    "error_se": ("", "standard error of the error (paired differences, pooled over the ladder)"),
    "relative_error": ("1", "error / |reference| (the error itself for residuals)"),
    "relative_error_se": ("1", "error_se / |reference|"),
    "tolerance": ("", "max(tolerance x |reference|, 2 error_se): the accepted |error|"),
    "within": ("1", "1 if |error| <= tolerance"),
    "resolved": ("1", "1 if |error| > 2 error_se (the error is statistically resolved)"),
    "wall_time": ("s", "wall time of one case (smallest over seeds)"),
    "reference": ("", "converged value"),
    "reference_se": ("", "standard error of the converged value"),
    "reference_order": ("1", "observed order used for Richardson extrapolation (NaN: none)"),
    "noise": ("", "standard deviation over seeds of one case at the reference step"),
    "headline": ("1", "1 if the observable decides the default step"),
}


def _strings(values):
    return np.array([str(v) for v in values], dtype=object)


def to_dataset(cases, points, choices, attrs):
    """Three tables in one netCDF, each a dimension with its columns as variables: case_* (one
    row per case and observable: parameters, dt, steps, wall time, code version, value), point_*
    (per name, series, observable and step: the error table) and choice_* (cheapest steps)."""
    data = {}
    for col in cases.columns:
        v = cases[col].values
        kind = "i" if col in ("seed", "steps") else ("f" if col in CASE_UNITS else "s")
        data[f"case_{col}"] = ("case", v.astype(float) if kind == "f" else
                               v.astype(np.int64) if kind == "i" else _strings(v),
                               {"units": CASE_UNITS.get(col, "1"),
                                "long_name": CASE_LONG.get(col, col)})
    for col in points.columns:
        v = points[col].values
        if points[col].dtype == bool:
            v = v.astype(np.int8)
        units, long = POINT_UNITS.get(col, ("1", col))
        if units == "":
            units = "see point_units"
        data[f"point_{col}"] = ("point", v.astype(float) if v.dtype.kind == "f" else
                                v if v.dtype.kind in "iu" else _strings(v),
                                {"units": units, "long_name": long})
    for col in choices.columns:
        v = choices[col].values
        if choices[col].dtype == bool:
            v = v.astype(np.int8)
        data[f"choice_{col}"] = ("choice", v.astype(float) if v.dtype.kind == "f" else
                                 v if v.dtype.kind in "iu" else _strings(v),
                                 {"units": {"step": "s", "wall_time": "s"}.get(col, "1")})
    ds = xr.Dataset(data, coords={
        "case": ("case", np.arange(len(cases)), {"units": "1"}),
        "point": ("point", np.arange(len(points)), {"units": "1"}),
        "choice": ("choice", np.arange(len(choices)), {"units": "1"}),
    })
    ds.attrs.update(attrs)
    return ds


def points_frame(ds, prefix="point"):
    """A table of the netCDF back as a DataFrame (prefix point | choice | case)."""
    cols = {k[len(prefix) + 1:]: ds[k].values for k in ds.data_vars if k.startswith(prefix + "_")}
    return pd.DataFrame(cols)


# ---- summary (markdown) -------------------------------------------------------------------------

def _fmt(x, digits=3):
    if x is None or (isinstance(x, float) and not np.isfinite(x)):
        return "-"
    return f"{x:.{digits}g}"


def summary_markdown(points, choices):
    """Per name, series and observable: the ladder with error, noise and wall time."""
    out = []
    for (name, series, obs), t in points.groupby(["name", "series", "observable"], sort=False):
        r0 = t.iloc[0]
        ref = r0["reference"]
        out.append(f"### {name} / {series}: {obs} [{r0['units']}]\n")
        out.append(f"reference {_fmt(ref, 5)} ({r0['reference_method']}"
                   + (f", order {r0['reference_order']:.2f}" if np.isfinite(r0["reference_order"])
                      else "")
                   + (f", of series {r0['reference_series']}" if r0["reference_series"] != series
                      else "")
                   + f"); noise (sd over seeds at the reference step) {_fmt(r0['noise'])}"
                   + (f" = {100 * r0['noise'] / abs(ref):.2g} %" if ref and np.isfinite(r0["noise"])
                      else "") + "\n")
        out.append(f"| {r0['ladder']} | dt [s] | dt/limit | mean | error [%] | +- se [%] "
                   "| within | wall [s] |")
        out.append("|---|---|---|---|---|---|---|---|")
        for _, r in t.iterrows():
            out.append(f"| {_fmt(r['ladder_value'], 4)} | {_fmt(r['step'])} "
                       f"| {_fmt(r['step'] / r['dt_limit'], 2)} | {_fmt(r['mean'], 4)} "
                       f"| {_fmt(100 * r['relative_error'], 2)} "
                       f"| {_fmt(100 * r['relative_error_se'], 2)} "
                       f"| {'yes' if r['within'] else 'no'} | {_fmt(r['wall_time'], 3)} |")
        out.append("")
    out.append("### cheapest step within the tolerance (or the noise)\n")
    out.append("| name | series | observable(s) | kind | ladder value | dt [s] | wall [s] "
               "| error [%] |")
    out.append("|---|---|---|---|---|---|---|---|")
    for _, c in choices.iterrows():
        out.append(f"| {c['name']} | {c['series']} | {c['observable']} | {c['kind']} "
                   f"| {_fmt(c['ladder_value'], 4)} "
                   f"| {_fmt(c['step'])} | {_fmt(c['wall_time'])} "
                   f"| {_fmt(100 * c['relative_error'], 2)} |")
    return "\n".join(out) + "\n"
