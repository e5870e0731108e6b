"""The summary behind the report's landing page: headline numbers per study, verification
verdicts with the rule that decides each, calibrated values with their 95 % intervals, and
whether the stirred-mill reference is a synthetic twin.

``millsim report`` reads the pipeline's aggregates and calibration files and writes the summary
as JSON and as reStructuredText (``results/report/landing.rst``, included by
workflow/report/workflow.rst into ``snakemake --report``); ``millsim verdicts SUMMARY`` prints the
verdicts, failed ones first (the last step of ``make run``). Every number on the page is computed
here from those files, so the page and the files cannot disagree.

A verdict is a dict: study, check, rule (the rule that decides it, in words, with where it is
implemented), value (what was found), passed (True, False, or None where the rule cannot be
applied, e.g. no points).
"""

import json
import math

import numpy as np

from ..io import read_case
from . import stirred_mill as sm

FAILED, UNDECIDED, PASSED = "FAIL", "n/a", "PASS"
PER_S, PER_MIN, ETA, MU, NNC = "s\u207b\u00b9", "min\u207b\u00b9", "\u03b7", "\u03bc", "n/n_c"


def _f(x, digits=3):
    """A number as the page writes it: ``digits`` significant digits, NaN as an en dash."""
    if x is None or not np.isfinite(x):
        return "\u2013"
    if x != 0 and not 1e-4 <= abs(x) < 1e6:
        return f"{float(x):.{digits}g}"
    # 3500, not 3.5e+03
    return np.format_float_positional(float(x), precision=digits, unique=True, fractional=False,
                                      trim="-")


def _pm(x, ci, unit=""):
    return f"{_f(x)} \u00b1 {_f(ci, 2)}{(' ' + unit) if unit else ''}"


def _interval_text(iv, digits=3):
    """[lo, hi] of ``interval``; an end the simulated grid does not bracket as <= / >=."""
    lo = ("\u2264 " if iv["lo_open"] else "") + _f(iv["lo"], digits)
    hi = ("\u2265 " if iv["hi_open"] else "") + _f(iv["hi"], digits)
    return f"[{lo}, {hi}]"


def _status(passed):
    return UNDECIDED if passed is None else PASSED if passed else FAILED


# ---- studies ---------------------------------------------------------------------------------

def ballmill(path):
    """Ball mill 2D comminution study: peak rate and drive power against n/n_c."""
    ds = read_case(path)
    speed = ds["n_over_nc"].values
    rate, ci = ds["comminution_rate"].values, ds["comminution_rate_ci"].values
    k = int(np.nanargmax(rate))
    j = int(np.nanargmax(ds["mean_drive_power"].values))
    return dict(
        title="Ball mill 2D (Buchholtz, Freund and P\u00f6schel 2000)", key="ballmill",
        headline=[
            ("cases", f"{speed.size}: {NNC} = {', '.join(_f(s) for s in speed)}"),
            ("highest comminution rate", f"{_pm(rate[k], ci[k], PER_S)} at {NNC} = {_f(speed[k])}"),
            ("highest drive power", f"{_f(ds['mean_drive_power'].values[j])} W at {NNC} = "
                                    f"{_f(speed[j])}"),
        ],
        numbers=dict(speeds=speed.tolist(), peak_rate_speed=float(speed[k]),
                     peak_rate=float(rate[k]), peak_rate_ci=float(ci[k]),
                     peak_power_speed=float(speed[j]),
                     peak_power=float(ds["mean_drive_power"].values[j])),
        verdicts=[])


def forcechain(path):
    """Ball mill 2D force-chain study: chains counted per speed."""
    ds = read_case(path)
    speed = ds["n_over_nc"].values
    chains = ds["chain_count"].fillna(0).sum("chain_length").values
    return dict(
        title="Ball mill 2D, force chains (no fragmentation)", key="forcechain",
        headline=[("cases", f"{speed.size}: {NNC} = {', '.join(_f(s) for s in speed)}"),
                  ("force chains counted", ", ".join(f"{_f(c)} at {NNC} = {_f(s)}"
                                                     for s, c in zip(speed, chains)))],
        numbers=dict(speeds=speed.tolist(), chains=chains.tolist()), verdicts=[])


def bed(path):
    """Bed impact: broken mass and capture radius per bed and energy (mean over seeds)."""
    ds = read_case(path)
    rows = []
    for mat in ds["material"].values:
        for rings in ds["rings"].values:
            for layers in ds["layers"].values:
                for e in ds["impact_energy"].values:
                    sub = ds.sel(material=mat, rings=rings, layers=layers, impact_energy=e)
                    if not bool(sub["broken_fraction_mean"].notnull()):
                        continue
                    rows.append(dict(material=str(mat), rings=int(rings), layers=int(layers),
                                     impact_energy=float(e),
                                     broken_mass_percent=100 * float(sub["broken_fraction_mean"]),
                                     capture_radius_mm=1e3 * float(sub["capture_radius_mean"]),
                                     seeds=int(sub["replicates"])))
    table = [["material", "rings x layers", "energy [J]", "broken mass [%]",
              "capture radius [mm]", "seeds"]]
    table += [[r["material"], f"{r['rings']} x {r['layers']}", _f(r["impact_energy"]),
               _f(r["broken_mass_percent"]), _f(r["capture_radius_mm"]), str(r["seeds"])]
              for r in rows]
    return dict(title="Particle-bed impact (Tavares et al. 2021)", key="bed",
                headline=[("cases", f"{int(ds['replicates'].sum())} in {len(rows)} conditions")],
                table=table, numbers=dict(rows=rows), verdicts=[])


_TAVARES_RULES = {
    "probability": "eq 1 inside the 95 % Clopper-Pearson interval of the simulated fraction "
                   "broken at >= 90 % of the energies",
    "repeated": "eqs 1-6 inside the 95 % Clopper-Pearson interval of the fraction broken after "
                ">= 90 % of the impacts",
    "t10": "eq 7 (E50b of the broken) inside the 95 % bootstrap interval of t10 at >= 90 % of "
           "the energies",
}
_WHERE = "millsim.analysis.tavares_verification.pass_rule"


def tavares(path):
    """Tavares single-particle verification: the pass rules of the aggregate as verdicts, and
    simulated vs model values."""
    ds = read_case(path)
    verdicts = []
    for group in ("probability", "repeated", "t10"):
        for name, r in json.loads(ds.attrs.get(f"pass_rule_{group}", "{}")).items():
            points = r.get("points")
            inside = r["inside"]
            value = (f"{round(inside * points)} of {points} inside ({100 * inside:.0f} %)"
                     if points else f"{100 * inside:.0f} % inside" if np.isfinite(inside)
                     else "no points")
            verdicts.append(dict(study="tavares", check=f"{group}: {name}",
                                 rule=f"{_TAVARES_RULES[group]} ({_WHERE})", value=value,
                                 passed=bool(r["pass"]) if np.isfinite(inside) else None))
    headline = []
    if "rep_fraction" in ds:
        last = ds.isel(impact=-1)
        for g in ds["gamma"].values:
            sub = last.sel(gamma=g)
            headline.append((f"fraction broken after {int(ds['impact'][-1])} impacts, "
                             f"\u03b3 = {_f(g)}",
                             f"{_f(float(sub['rep_fraction']))} [{_f(float(sub['rep_ci_lo']))}, "
                             f"{_f(float(sub['rep_ci_hi']))}] vs model "
                             f"{_f(float(sub['rep_analytic']))}"))
    table = None
    if "t10" in ds:
        table = [["case", "Ek/m [J kg\u207b\u00b9]", "t10 [%] (95 % interval)", "eq 7 [%]",
                  "broken"]]
        for i, case in enumerate(ds["frag_case"].values):
            for r in range(ds.sizes["frag_ratio"]):
                sub = ds.isel(frag_case=i, frag_ratio=r)
                if not np.isfinite(float(sub["t10_specific_energy"])):
                    continue
                table.append([str(case), _f(float(sub["t10_specific_energy"])),
                              f"{_f(float(sub['t10']))} [{_f(float(sub['t10_lo']))}, "
                              f"{_f(float(sub['t10_hi']))}]", _f(float(sub["t10_model"])),
                              _f(float(sub["t10_broken"]))])
    if "table2_families" in ds:
        gap = float(np.max(np.abs(ds["table2_families"] - ds["table2_paper"])))
        headline.append(("progeny families at t10' = 3 % vs Table 2 of Tavares et al. 2021",
                         f"largest difference {_f(gap, 2)} percentage points"))
    return dict(title="Tavares single-particle verification (Tavares et al. 2021, section 4.1)",
                key="tavares", headline=headline, table=table, verdicts=verdicts,
                numbers={})


def stirred(path):
    """Stirred media mill power study: net power per case, typology, energy balance verdict."""
    ds = read_case(path)
    rows, worst = [], (0.0, "")
    for eta in ds["eta"].values:
        for rpm in ds["rpm"].values:
            sub = ds.sel(eta=eta, rpm=rpm)
            err = float(sub["energy_balance_error"])
            where = f"{ETA} = {_f(eta)} Pa s, {_f(rpm)} {PER_MIN}"
            if not abs(err) <= abs(worst[0]):
                worst = (err, where)
            shares = dict(zip(map(str, ds["typology"].values),
                              100 * sub["typology_fraction"].values))
            rows.append(dict(eta=float(eta), rpm=float(rpm), net_power=float(sub["net_power"]),
                             net_power_ci=float(sub["net_power_ci"]), energy_balance_error=err,
                             shares=shares))
    table = [[f"{ETA} [Pa s]", f"speed [{PER_MIN}]", "net power [W] (95 %)",
              "impact / shearing / rolling [% of dissipation]", "energy-balance residual [%]"]]
    table += [[_f(r["eta"]), _f(r["rpm"]), _pm(r["net_power"], r["net_power_ci"]),
               " / ".join(_f(r["shares"].get(k, math.nan), 2)
                          for k in ("impact", "shearing", "rolling")),
               _f(100 * r["energy_balance_error"], 2)] for r in rows]
    tol = sm.ENERGY_BALANCE_TOLERANCE
    verdict = dict(study="stirred_mill", check="energy balance of every power-study case",
                   rule=f"|agitator work - energy changes - dissipation| <= {100 * tol:g} % of the "
                        "work, steady window (millsim.analysis.stirred_mill."
                        "ENERGY_BALANCE_TOLERANCE)",
                   value=f"largest {_f(100 * worst[0], 2)} % ({worst[1]})",
                   passed=bool(abs(worst[0]) <= tol))
    return dict(title="Stirred media mill, power study (the LabStar LS1 paper)",
                key="stirred", headline=[("cases", f"{len(rows)} ({ETA} x speed)")], table=table,
                numbers=dict(rows=rows), verdicts=[verdict])


def calibration(friction, viscosity, prediction, reference):
    """Stirred-mill power-draw calibration: calibrated friction and eta_sim with their 95 %
    intervals; for a synthetic twin, whether they recover its generating parameters."""
    import pandas as pd

    fr = _read_json(friction)
    vi = _read_json(viscosity)
    ref = sm.read_reference(reference)
    synthetic, true_friction = sm.synthetic_reference(ref)
    values = [dict(parameter=f"friction {MU}", grid=fr["friction"], refined=fr["friction_refined"],
                   interval=fr.get("friction_interval"), truth=true_friction)]
    for fluid, c in sorted(vi["fluids"].items()):
        values.append(dict(parameter=f"{ETA}_sim of {fluid} [Pa s]", grid=c["eta_sim"],
                           refined=c["eta_sim_refined"], interval=c.get("eta_sim_interval"),
                           truth=c["eta_exp"] if synthetic else None))
    table = [["parameter", "calibrated (grid)", "refined", "95 % interval"]
             + (["twin's generating value"] if synthetic else [])]
    verdicts = []
    for v in values:
        iv = v["interval"]
        table.append([v["parameter"], _f(v["grid"]), _f(v["refined"]),
                      _interval_text(iv) if iv else "\u2013"]
                     + ([_f(v["truth"]) if v["truth"] is not None else "not stated"]
                        if synthetic else []))
        if synthetic:
            inside = (None if iv is None or v["truth"] is None
                      else bool(iv["lo"] * (1 - 1e-9) <= v["truth"] <= iv["hi"] * (1 + 1e-9)))
            verdicts.append(dict(
                study="stirred_mill", check=f"calibration recovers the twin's {v['parameter']}",
                rule="the synthetic twin's generating value inside the 95 % interval of the "
                     "calibrated one (millsim.analysis.stirred_mill.interval)",
                value=(f"{_f(v['truth'])} vs {_interval_text(iv)}" if iv and v["truth"] is not None
                       else "no interval or no generating value"),
                passed=inside))
    notes = []
    if any(v["interval"] and (v["interval"]["lo_open"] or v["interval"]["hi_open"])
           for v in values):
        notes.append(("\u2264 / \u2265 in an interval", "it reaches the end of the simulated "
                      "grid, which does not bracket it"))
    for v in values:
        if v["interval"] and v["interval"]["scale"] > 1:
            notes.append((f"{v['parameter']} interval", "widened by a factor "
                          f"{_f(math.sqrt(v['interval']['scale']), 2)}: the speeds disagree more "
                          "than their intervals allow (Particle Data Group scale factor)"))
    pred = pd.read_csv(prediction)
    rel = (pred["residual"] / pred["reference"]).abs()
    headline = [("reference", "SYNTHETIC twin (engine output), not a measurement"
                 if synthetic else "as given in " + str(reference)),
                ("calibration speeds", f"{', '.join(_f(r) for r in fr['speeds'])} {PER_MIN}; "
                                       f"viscosity stage at {_f(vi['rpm'])} {PER_MIN}"),
                ("prediction (stage 3)", f"largest |simulated - reference| / reference "
                                         f"{_f(100 * rel.max(), 2)} % over {len(pred)} points"),
                *notes]
    return dict(title="Stirred media mill, power-draw calibration", key="calibration",
                headline=headline, table=table, verdicts=verdicts,
                numbers=dict(values=values, synthetic=synthetic,
                             prediction_max_relative_residual=float(rel.max())))


def _read_json(path):
    try:
        with open(path) as fh:
            return json.load(fh)
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: not a readable JSON file ({exc})") from None


# ---- the summary -----------------------------------------------------------------------------

def summarise(ballmill_path=None, forcechain_path=None, bed_path=None, tavares_path=None,
              stirred_path=None, calibration_paths=None, command=""):
    """The summary of whichever studies are given (a dict, JSON-serialisable)."""
    studies = [_read(study, path) for study, path in (
        (ballmill, ballmill_path), (forcechain, forcechain_path), (bed, bed_path),
        (tavares, tavares_path), (stirred, stirred_path)) if path]
    synthetic = False
    if calibration_paths:
        cal = _read(calibration, *calibration_paths)
        synthetic = cal["numbers"]["synthetic"]
        studies.append(cal)
    verdicts = ordered([v for s in studies for v in s.pop("verdicts")])
    return dict(command=command, synthetic_reference=synthetic, verdicts=verdicts,
                studies=studies)


def _read(study, path, *more):
    """``study(path, *more)``; a readable file of another kind is named in one line."""
    try:
        return study(path, *more)
    except KeyError as exc:
        raise ValueError(f"{path}: no {exc.args[0]!r}; not the {study.__name__} input of "
                         "`millsim report` (see --help)") from None


def ordered(verdicts):
    """Failed first, then undecided, then passed; the given order within each."""
    rank = {False: 0, None: 1, True: 2}
    return sorted(verdicts, key=lambda v: rank[v["passed"]])


def verdict_lines(summary):
    """One line per verdict, failed first: STATUS  check: value  [rule]."""
    verdicts = ordered(summary["verdicts"])
    failed = sum(v["passed"] is False for v in verdicts)
    lines = [f"{_status(v['passed']):4s}  {v['study']}: {v['check']}: {v['value']}  "
             f"[rule: {v['rule']}]" for v in verdicts]
    head = (f"millsim verdicts: {failed} of {len(verdicts)} FAILED" if failed
            else f"millsim verdicts: all {len(verdicts)} passed")
    if summary.get("synthetic_reference"):
        lines.append("NOTE  the stirred-mill reference power is a SYNTHETIC twin, not a "
                     "measurement (config/reference/SOURCES.md)")
    return [head, *lines]


def _list_table(rows):
    out = [".. list-table::", "   :header-rows: 1", ""]
    for row in rows:
        out.append(f"   * - {_rst(row[0])}")
        out.extend(f"     - {_rst(cell)}" for cell in row[1:])
    return out


def _rst(text):
    """Text shown as written in RST: markup characters escaped."""
    for char in "\\*`_|":
        text = str(text).replace(char, "\\" + char)
    return text


def landing_rst(summary):
    """The landing page (reStructuredText) of a summary."""
    out = []
    if summary["synthetic_reference"]:
        out += [".. warning::", "",
                "   **SYNTHETIC REFERENCE.** The stirred-mill \"measured\" power "
                "(config/reference/stirred_mill_power.csv) is a synthetic twin computed by this "
                "engine, not a measurement. The calibration below shows that the pipeline "
                "recovers known parameters; it says nothing about a real mill. "
                "config/reference/SOURCES.md says how to use measured data.", ""]
    verdicts = ordered(summary["verdicts"])
    failed = sum(v["passed"] is False for v in verdicts)
    out += ["Verification verdicts", "---------------------", "",
            (f"**{failed} of {len(verdicts)} checks FAILED** (listed first)." if failed
             else f"All {len(verdicts)} checks passed.") + " Each is decided by the rule given.",
            ""]
    if verdicts:
        rows = [["verdict", "check", "found", "rule"]]
        rows += [[_status(v["passed"]), f"{v['study']}: {v['check']}", v["value"], v["rule"]]
                 for v in verdicts]
        out += _list_table(rows) + [""]
        # the status column in bold where it failed: list-table cells are plain, so mark them
        out = [line.replace("   * - FAIL", "   * - **FAIL**") for line in out]
    for study in summary["studies"]:
        title = study["title"]
        out += [title, "-" * len(title), ""]
        for name, value in study["headline"]:
            out.append(f"- {_rst(name)}: {_rst(value)}")
        out.append("")
        if study.get("table"):
            out += _list_table(study["table"]) + [""]
    out += ["How this page was made", "----------------------", "",
            "Written by ``millsim report`` from the aggregates and calibration files of this run "
            "(results/logs/report_summary.log); every number above is computed there. "
            "Regenerate the study, this page and the report with::", "",
            "    snakemake --cores 2 && snakemake --report results/report.html", "",
            "and print the verdicts with ``millsim verdicts results/report/summary.json``.", ""]
    if summary.get("command"):
        out += ["This page's command::", "", f"    {summary['command']}", ""]
    return "\n".join(out)
