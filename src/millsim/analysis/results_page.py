"""The results page of a paper-scale study, written from its aggregate alone (issue 48, item 3).

``millsim results-page STUDY AGGREGATE [--figures DIR] --out FILE`` writes a markdown page: what
was run (the swept coordinates and the fixed ``param_*`` attributes), the engine hash as
``engine <12 hex>`` (the form :mod:`.evidence` finds), the date the aggregate was written, the
cost (sum of the cases' wall times, attribute ``cases_wall_time_s``, where the aggregate holds
it), the study's main table(s), and links to its figures of the plot registry found in DIR. Every
number is formatted from the aggregate; nothing is typed in.

The pipeline writes the pages to ``results/pages/<study>.md`` (workflow/rules/paper.smk); how a
page lands in docs/results is in docs/pipeline.md, "Paper-scale studies".
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the command line lists STUDIES without importing xarray
    import xarray as xr

__all__ = ["STUDIES", "page", "write_page"]


def fmt(value, digits=4):
    """A number as the tables print it (``digits`` significant digits; "n/a" for NaN)."""
    value = float(value)
    return "n/a" if not math.isfinite(value) else f"{value:.{digits}g}"


def _pm(mean, spread):
    return fmt(mean) if not math.isfinite(float(spread)) else f"{fmt(mean)} +- {fmt(spread)}"


def _units(ds, name):
    return ds[name].attrs.get("units", "1")


def _need(ds, names, study):
    missing = [n for n in names if n not in ds]
    if missing:
        raise ValueError(f"aggregate: no {', '.join(missing)}; not the aggregate of study {study} "
                         "(`millsim results-page --help` names each study's)")


def _table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return out + ["| " + " | ".join(row) + " |" for row in rows]


# ---- the main tables per study ----------------------------------------------------------------
def _ballmill(ds):
    names = ["comminution_rate", "comminution_rate_ci", "relative_rate", "relative_rate_ci",
             "mean_drive_power"]
    _need(ds, names, "ballmill")
    rows = [[fmt(n),
             _pm(ds["comminution_rate"].sel(n_over_nc=n), ds["comminution_rate_ci"].sel(n_over_nc=n)),
             _pm(ds["relative_rate"].sel(n_over_nc=n), ds["relative_rate_ci"].sel(n_over_nc=n)),
             fmt(ds["mean_drive_power"].sel(n_over_nc=n))]
            for n in ds["n_over_nc"].values]
    header = ["n/n_c", f"comminution rate [{_units(ds, 'comminution_rate')}]",
              "relative rate [1]", f"drive power [{_units(ds, 'mean_drive_power')}]"]
    from .ballmill import paper_claims

    claims = [list(row) for row in paper_claims(ds)]
    return [("Comminution rate and drive power vs n/n_c (95 % half-widths of block averages)",
             _table(header, rows)),
            ("Against Buchholtz, Freund & Poeschel (2000)",
             _table(["the paper's statement", "here", "rule", "verdict"], claims))]


BED_DIMS = ("material", "rings", "layers", "impact_energy")


def _bed_impact(ds):
    _need(ds, ["broken_mass_mean", "broken_mass_std", "capture_radius_mean",
               "capture_radius_std", "replicates"], "bed_impact")
    stacked = ds[["broken_mass_mean", "broken_mass_std", "capture_radius_mean",
                  "capture_radius_std", "replicates"]].stack(point=BED_DIMS)
    rows = []
    for k in range(stacked.sizes["point"]):
        p = stacked.isel(point=k)
        if not p["replicates"].item() > 0:  # a point of the sparse grid no sweep has
            continue
        rows.append([str(p["material"].item()), str(int(p["rings"])), str(int(p["layers"])),
                     fmt(p["impact_energy"]),
                     _pm(p["broken_mass_mean"], p["broken_mass_std"]),
                     _pm(p["capture_radius_mean"], p["capture_radius_std"]),
                     str(int(p["replicates"]))])
    header = ["material", "rings", "layers", f"impact energy [{_units(ds, 'impact_energy')}]",
              f"broken mass [{_units(ds, 'broken_mass_mean')}]",
              f"capture radius [{_units(ds, 'capture_radius_mean')}]", "seeds"]
    from .bed_impact import paper_claims

    claims = [list(row) for row in paper_claims(ds)]
    return [("Broken mass and capture radius per material x bed (mean +- sd over seeds)",
             _table(header, rows)),
            ("Against the trends Tavares et al. (2021) state (section 4.2)",
             _table(["the paper's statement", "here", "rule", "verdict"], claims))]


VERDICT_KEYS = {"pass_rule_probability": "probability", "pass_rule_repeated": "repeated",
                "pass_rule_t10": "t10"}


def _verdict(r):
    if r.get("deviation"):
        return "DEVIATION (documented)"
    return "n/a" if r.get("pass") is None else "PASS" if r["pass"] else "FAIL"


def _single_particle(ds):
    keys = [k for k in VERDICT_KEYS if k in ds.attrs]
    if not keys:
        raise ValueError("aggregate: no pass_rule_* attributes; not the aggregate of study "
                         "single_particle (`millsim analyse tavares aggregate` writes it)")
    rows, deviations, beside_eq7 = [], [], []
    for key in keys:
        for name, r in json.loads(ds.attrs[key]).items():
            rows.append([VERDICT_KEYS[key], name, str(r["points"]), fmt(100 * r["inside"]),
                         fmt(r.get("p_value", math.nan)), fmt(r.get("threshold", math.nan)),
                         _verdict(r)])
            if r.get("deviation"):
                ratios = ", ".join(fmt(x, 3) for x in r.get("t10_over_model", []))
                deviations.append(f"- {name}: {r['deviation']}; t10 / eq 7 per energy: {ratios}")
            elif "t10_over_model" in r:
                ratios = ", ".join(fmt(x, 3) for x in r["t10_over_model"])
                beside_eq7.append(f"- {name}: t10 / eq 7 per energy: {ratios}")
    header = ["test", "set", "points", "model inside 95 % [%]", "p-value", "Holm threshold",
              "verdict"]
    tables = [("Verification verdicts (Holm 1979 over the study's tests, family-wise 5 %)",
               _table(header, rows))]
    if deviations:
        tables.append(("Documented deviations (reported, not tested)", deviations))
    if beside_eq7:
        tables.append(("t10 beside eq 7, the population fit of the paper's Fig. 16 (reported, "
                       "not tested; the verdict tests the mean of eq 8 over the broken)",
                       beside_eq7))
    return tables


def _stirred_mill(ds):
    _need(ds, ["net_power", "net_power_ci"], "stirred_mill")
    rpms = ds["rpm"].values
    rows = [[fmt(eta), *(_pm(ds["net_power"].sel(eta=eta, rpm=r), ds["net_power_ci"].sel(eta=eta, rpm=r))
                         for r in rpms)]
            for eta in ds["eta"].values]
    header = [f"eta [{_units(ds, 'eta')}] \\ rpm", *(fmt(r) for r in rpms)]
    return [(f"Net power [{_units(ds, 'net_power')}] vs speed x viscosity (95 % half-widths of "
             "block means)", _table(header, rows))]


BM3_NEEDS = ["power", "power_half_width", "toe_angle", "shoulder_angle", "toe_angle_morrell",
             "shoulder_angle_morrell", "phi_morrell", "power_reference_scale",
             "energy_balance_error"]


def _deg(value):
    return fmt(math.degrees(float(value)))


def _ballmill3d(ds):
    """Per filling x speed: power, Morrell's (1996b) net power scaled as the study's figure
    scales it (analysis.ballmill3d.reference_power), toe and shoulder beside Morrell's, the two
    energy books, the logged-stress breakage where the cases have it; then the paper's
    statement on where the power peaks (analysis.ballmill3d.peak_claim), one row per filling."""
    from . import ballmill3d as bm3

    _need(ds, BM3_NEEDS, "ballmill3d")
    reference = bm3.reference_power(ds)
    logged = "breakage_events_predicted" in ds and "breakage_events_counted" in ds
    rows, claims, shape = [], [], {"toe": [], "shoulder": []}
    for j in ds[bm3.FILLING].values:
        phi_c = float(bm3.morrell_centrifuge_fraction(j))
        for n in ds[bm3.SPEED].values:
            case = ds.sel({bm3.FILLING: j, bm3.SPEED: n})
            # Morrell's relations put the charge at the top from phi_c on: no toe, no shoulder
            spun = float(case["phi_morrell"]) >= phi_c
            morrell = ["centrifuged"] * 2 if spun else [_deg(case["toe_angle_morrell"]),
                                                        _deg(case["shoulder_angle_morrell"])]
            row = [fmt(j), fmt(n), _pm(case["power"], case["power_half_width"]),
                   fmt(reference.sel({bm3.FILLING: j, bm3.SPEED: n})),
                   _deg(case["toe_angle"]), morrell[0], _deg(case["shoulder_angle"]), morrell[1],
                   fmt(case["energy_balance_error"], 2),
                   fmt(case["spectra_audit_error"], 2) if "spectra_audit_error" in ds else "n/a"]
            if logged:
                predicted = float(case["breakage_events_predicted"].sum(skipna=True))
                counted = float(case["breakage_events_counted"].sum(skipna=True))
                p = (f" (p {fmt(case['breakage_prediction_p_value'], 2)})"
                     if "breakage_prediction_p_value" in ds else "")
                row.append(f"{fmt(predicted)} / {fmt(counted)}{p}")
            rows.append(row)
            for name in shape if not spun else ():
                gap = math.degrees(float(case[f"{name}_angle"] - case[f"{name}_angle_morrell"]))
                shape[name] += [gap] if math.isfinite(gap) else []
        sub = ds.sel({bm3.FILLING: j})
        claim = bm3.peak_claim(sub[bm3.SPEED], sub["power"], sub["power_half_width"])
        model = (f"; Morrell's C-model x {fmt(sub['power_reference_scale'], 3)} peaks at "
                 f"{fmt(sub['power_reference_peak_speed'], 3)}"
                 if "power_reference_peak_speed" in ds else "")
        claims.append([f"power maximum between {bm3.PEAK_RANGE[0]:g} and {bm3.PEAK_RANGE[1]:g} of "
                       f"critical (Hogg & Fuerstenau 1972; Morrell 1996b), J = {fmt(j)}",
                       f"vertex at n/n_c = {fmt(claim['vertex'])} (highest power at "
                       f"{fmt(claim['top'])}){model}; {claim['reason']}",
                       bm3.PEAK_RULE, claim["verdict"]])
    for name in bm3.ENERGY_BOOKS:
        book = bm3.book_check(ds, name)
        if book is not None:
            claims.append([f"{book['check']} (issue 52, item 3)",
                           f"largest {fmt(100 * book['worst'], 2)} %; {book['outside']} of "
                           f"{book['cases']} cases outside", book["rule"],
                           {True: "PASS", False: "FAIL"}.get(book["passed"], "n/a")])
    if shape["toe"] or shape["shoulder"]:
        spans = ", ".join(f"{name} {fmt(min(v), 3)} to {fmt(max(v), 3)} deg"
                          for name, v in shape.items() if v)
        claims.append(["toe and shoulder angles of Morrell (1996b)",
                       f"simulated - Morrell: {spans} (the cases Morrell does not centrifuge; + is "
                       "further in the direction of rotation)",
                       "reported: the statement has no tolerance", bm3.NOT_TESTABLE])
    watts = _units(ds, "power")
    header = ["J", "n/n_c", f"power [{watts}]", f"Morrell x scale [{watts}]", "toe [deg]",
              "Morrell toe [deg]", "shoulder [deg]", "Morrell shoulder [deg]", "energy balance",
              "spectra vs audit"]
    if logged:
        header.append("breakage predicted / counted")
    return [("Drive power (95 % half-widths of block means), charge shape and energy books per "
             "filling x speed; Morrell (1996b) scaled to each filling by least squares",
             _table(header, rows)),
            ("Against Morrell (1996b) and Hogg & Fuerstenau (1972)",
             _table(["the paper's statement", "here", "rule", "verdict"], claims))]


@dataclass(frozen=True)
class PageStudy:
    title: str
    paper: str
    datasets: tuple[str, ...]  # the registry's aggregate:<dataset> whose figures the page links
    tables: Callable[[xr.Dataset], list]
    # the swept coordinates to list (default: the aggregate's stacked_over) and the attribute
    # prefixes of the fixed parameters
    swept: tuple[str, ...] = ()
    fixed_prefixes: tuple[str, ...] = ("param_",)
    # the scenes whose physics the numbers come from (millsim evidence judges the page by them;
    # default: the study's name)
    scenes: tuple[str, ...] = ()


STUDIES = {
    "ballmill": PageStudy("Ball mill 2D at the paper's scale", "Buchholtz, Freund & Poeschel (2000)",
                          ("ballmill", "ballmill_forcechain"), _ballmill, scenes=("ballmill2d",)),
    "ballmill3d": PageStudy("Ball mill 3D at lab scale: power and charge shape vs speed x filling",
                            "Morrell (1996b); Hogg & Fuerstenau (1972)", ("ballmill3d",),
                            _ballmill3d),
    "bed_impact": PageStudy("Particle-bed impact at the paper's scale",
                            "Tavares et al. (2021), section 4.2", ("bed_breakage",), _bed_impact),
    "single_particle": PageStudy("Single-particle verification at the paper's scale",
                                 "Tavares et al. (2021), section 4.1", ("tavares_verification",),
                                 _single_particle,
                                 swept=("prob_mode", "prob_material", "energy_ratio", "gamma",
                                        "frag_case", "frag_ratio"),
                                 fixed_prefixes=("prob_", "rep_", "frag_")),
    "stirred_mill": PageStudy("Stirred media mill, full LS1 chamber: power vs speed x viscosity",
                              "the LabStar LS1 paper", ("stirred_mill",), _stirred_mill),
}


# ---- the page ---------------------------------------------------------------------------------
def _value(v):
    import numpy as np

    return fmt(v) if np.issubdtype(np.asarray(v).dtype, np.number) else str(v)


def _what_was_run(spec, ds):
    """The swept coordinates with their values, then the fixed parameters (attributes)."""
    swept = spec.swept or json.loads(ds.attrs.get("stacked_over", "[]"))
    lines = [f"- swept {dim}: {', '.join(_value(v) for v in ds[dim].values)}"
             for dim in swept if dim in ds.coords]
    fixed = sorted((k.removeprefix("param_"), v) for k, v in ds.attrs.items()
                   if k.startswith(spec.fixed_prefixes))
    if fixed:
        lines.append("- fixed: " + ", ".join(f"{k} = {_value(v)}" for k, v in fixed))
    return lines


def _cost(ds):
    cases = len(json.loads(ds.attrs.get("source_cases", "[]")))
    if "cases_wall_time_s" not in ds.attrs:
        return f"{cases} cases; their compute time is not recorded in this aggregate."
    seconds = float(ds.attrs["cases_wall_time_s"])
    return (f"{cases} cases, {fmt(seconds)} s = {fmt(seconds / 3600, 3)} core-hours (sum of the "
            "cases' wall times, one thread per case)")


def _figures(study, figures, out, catalogue):
    """Links to the study's figures found in ``figures``; ``catalogue``: {name: (input, caption)}
    of every figure (the plots registry, handed in by the caller: analysis sits below plots)."""
    names = [name for name, (source, _) in catalogue.items()
             if source.partition(":")[2] in STUDIES[study].datasets and "{" not in name]
    if figures is None:
        return ["No figures given (`--figures`)."]
    lines, absent = [], []
    for name in names:
        path = Path(figures) / f"{name}.png"
        if not path.is_file():
            absent.append(name)
            continue
        link = Path(os.path.relpath(path, Path(out).parent)).as_posix()
        lines.append(f"![{name}]({link})")
        lines.append(f"*{name}*: {catalogue[name][1]}")
        lines.append("")
    if absent:
        folder = Path(os.path.relpath(figures, Path(out).parent)).as_posix()  # as the links
        lines.append(f"Not drawn (absent from {folder}): {', '.join(absent)}.")
    return lines


def page(study, ds, source, figures=None, out="page.md", catalogue=None):
    """The markdown text of the page of ``study`` from aggregate ``ds`` (read from ``source``);
    figure links relative to ``out``."""
    if study not in STUDIES:
        raise ValueError(f"study: unknown {study!r}; known: {', '.join(STUDIES)}")
    spec = STUDIES[study]
    engine = ds.attrs.get("engine_hash")
    if not engine:
        raise ValueError(f"{source}: no engine_hash attribute; not an aggregate of millsim")
    text = [f"# {spec.title}: {spec.paper}", "",
            f"Generated by `millsim results-page {study}` from `{Path(source).as_posix()}`; every "
            "number below is read from that aggregate.", "",
            f"- engine {engine} (millsim {ds.attrs.get('millsim_version', '?')}; the aggregate "
            "refuses cases of two engines, so this is every case's)",
            f"- aggregate written {ds.attrs.get('created_utc', 'at an unrecorded date')}",
            f"- cost: {_cost(ds)}", "",
            "Physics: scene " + ", ".join(f"`{s}`" for s in spec.scenes or (study,)), "",
            "## What was run", "", *_what_was_run(spec, ds), ""]
    for caption, table in spec.tables(ds):
        text += [f"## {caption}", "", *table, ""]
    text += ["## Figures", "", *_figures(study, figures, out, catalogue or {})]
    return "\n".join(text).rstrip() + "\n"


def write_page(study, aggregate, out, figures=None, catalogue=None):
    """Read ``aggregate`` and write the page of ``study`` to ``out`` (atomically)."""
    from ..io import atomic_target, read_case

    if figures is not None and not Path(figures).is_dir():
        raise ValueError(f"--figures: {figures} is not a folder")
    text = page(study, read_case(aggregate), aggregate, figures, out, catalogue)
    with atomic_target(out) as tmp:
        Path(tmp).write_text(text)
    return text
