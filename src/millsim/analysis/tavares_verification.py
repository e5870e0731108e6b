"""The pass rule and the aggregate of the Tavares verification study (Tavares et al. 2021,
section 4.1, Figs 8, 11, 13-16, Table 2). The analytic expectations the cases are compared with are
computed by the scene (millsim.models.breakage.tavares_predictions) and stored in each case;
the figures are millsim.plots.tavares.

Energy bases (docs/tavares.md section 2). The *set* specific energy of a test, ``Ek/m``, is the
**stressing (input)** energy: 1/2 v^2 of a particle thrown at a plate, 1/2 M v^2 / m of a
drop-weight striker of mass M. That is the x-axis of Figs 8-11 and 16 of Tavares et al. 2021, and
the basis on which Table 4's E_inf was fitted. The particle absorbs the share
``e = k_s/(k_p + k_s)`` of it (eq 4, both contacts of a drop-weight test are with steel), and
the model compares the *absorbed* energy ``e Ek/m`` with its fracture energy, whose median is
``e E_inf[1 + (d0/d)^phi]`` (eq 3). So the breakage probability against the input energy is eq 1
with median ``E_inf[1 + (d0/d)^phi]`` -- the two factors cancel.

Analytic values:

- breakage probability of one impact: eq 1-2 at the absorbed energy (``breakage_probability``);
- fraction broken after each of n repeated impacts: numerical integration over the fracture-energy
  distribution of the damage sequence E_(k+1) = E_k (1 - D(e Ek / E_k)) (eqs 5-6), a particle
  breaking at the first impact with e Ek >= E_k (``repeated_impact_broken``);
- t10 of the broken particles: the mean of eq 8 over the fracture energies of the particles
  that break (``t10_expected``), which the verdict tests; eq 7, t10 = A [1 - exp(-b' Ek/E50b)],
  with E50b the median fracture energy of the particles that break at that energy (Tavares and
  Carvalho 2009), on the same basis as Ek (``t10_model``), the population fit the paper's Fig. 16
  draws, reported beside it (it lies up to ~30 % below the mean of eq 8); the primary-event value
  of eq 9 for reference;
- product size distribution of the broken particles: eq 10 through that t10, extended below d/75
  by the eq 11-12 power law (``product_passing_model``).

Verdict rules (issue 48): each test gives one p-value against the model, and the verdicts of a
set are decided together so that a correct simulation fails *any* of them with a chance of at
most ``FAMILY_ALPHA`` = 5 %:

- probability and repeated impacts: at each point (energy, or impact), the exact two-sided
  binomial test of the simulated broken count against the model's probability (eqs 1-3, or eqs
  1-6 integrated; the count of independent particles is binomial exactly), p-value by the
  minimum-likelihood method (Clopper & Pearson's binomial; scipy.stats.binomtest);
- t10: the simulated t10 of the broken particles against the model's own distribution of that
  mean (their fracture energies drawn, eq 8, the family's spread; Monte Carlo,
  ``tavares_predictions.t10_p_value``, computed by the scene); the 95 % bootstrap interval is
  drawn, not tested: read from a skewed sample of ~25 broken particles it rejected a correct
  model in 12-15 % of draws at the nominal 5 %, and a normal z with the model's spread still let
  a correct 36-point set fail 6.5 % of 1500 draws (tools/t10_false_alarm.py);
- the points of a test combined by Bonferroni: p = min(1, k x the smallest of its k p-values), a
  valid p-value of "the model holds at every point" under any dependence between the points (the
  cumulative counts of repeated impacts are strongly dependent);
- the tests of a set decided by Holm's step-down procedure (Holm 1979, Scand. J. Statist. 6,
  65-70): the i-th smallest of m p-values fails when it and every smaller one lie at or below
  FAMILY_ALPHA / (m - i + 1); family-wise error <= FAMILY_ALPHA under any dependence.

``aggregate`` applies Holm over this study's tests (``pass``); the report applies it again over
every verdict of the run (millsim.analysis.report.decide). t10 under ``breakage_at:
first_reach`` is a known limitation of that option (it breaks at the fracture energy and leaves
t10 below eq 7, docs/tavares.md section 5): it is reported as a documented deviation with its
numbers, not tested. The former rule (the model inside the 95 % interval at >= 90 % of the
points, ``pass_rule``) allowed no miss at 4 points and failed a correct 4-point test about once
in ten.

Command line (used by the pipeline)::

    millsim analyse tavares aggregate CASES... --out tavares_verification.nc
    millsim analyse tavares summary tavares_verification.nc
    millsim plot tavares_KIND tavares_verification.nc --out fig.png
"""

from __future__ import annotations

import functools
import json
import math
import os

import numpy as np
import xarray as xr

from ..io import case_parameters, read_case
from ..models.breakage.tavares_predictions import table2_comparison
from .aggregate import case_cost, same_code

PASS_FRACTION = 0.90
ENERGY_RATIO = {"units": "1", "long_name": "input specific energy / median E50 (stressing basis)"}
# the chance that a correct simulation fails any verdict of a set (Holm over the set)
FAMILY_ALPHA = 0.05
Z95 = 1.959963984540054  # the normal quantile of a two-sided 95 % interval
# t10 of this option is below eq 7 by design (docs/tavares.md section 5): reported, not tested
DEVIATIONS = {"first_reach": "breaks at the fracture energy, t10 below eq 7 (docs/tavares.md "
                             "section 5)"}


def binomial_p_value(k, n, p):
    """Exact two-sided binomial p-value of ``k`` successes in ``n`` trials at probability ``p``
    (minimum-likelihood method, as scipy.stats.binomtest): the probability of every count no
    more likely than ``k``. Vectorised over k, n, p; NaN where an input is not finite; a count
    outside 0..n is a ValueError (an index below 0 would read the pmf from its end)."""
    k, n, p = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (k, n, p)))
    out = np.full(k.shape, np.nan)
    for i in np.ndindex(k.shape):
        if not (np.isfinite(k[i]) and np.isfinite(n[i]) and np.isfinite(p[i])) or n[i] < 1:
            continue
        if not 0 <= round(k[i]) <= n[i]:
            raise ValueError(f"binomial_p_value: count {k[i]:g} outside 0..{n[i]:g}")
        pmf = _binomial_pmf(int(n[i]), float(p[i]))
        # relative slack as scipy's binomtest: counts as likely as k up to rounding
        out[i] = min(1.0, float(pmf[pmf <= pmf[int(round(k[i]))] * (1 + 1e-7)].sum()))
    return out


@functools.lru_cache(maxsize=1024)
def _binomial_pmf(n, p):
    from scipy import stats

    return stats.binom.pmf(np.arange(n + 1), n, p)


def interval_p_value(estimate, lo, hi, model, level_z=Z95):
    """Two-sided p-value of ``model`` against ``estimate`` whose interval [lo, hi] is a normal
    +- level_z standard errors (the side towards the model gives the error); NaN where unknown,
    also where the estimate lies outside its own interval on that side (no error to scale by);
    1 where the model is the estimate, whatever is known of the interval."""
    from scipy import stats

    estimate, lo, hi, model = (np.asarray(x, dtype=float) for x in (estimate, lo, hi, model))
    half = np.where(model >= estimate, hi - estimate, estimate - lo)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.abs(model - estimate) / (half / level_z)
    z = np.where(half < 0, np.nan, z)
    z = np.where(model == estimate, 0.0, z)
    return 2.0 * stats.norm.sf(z)


def bonferroni(p_values):
    """One p-value of "the model holds at every point" from the points' p-values (NaN ignored):
    min(1, k x the smallest); NaN without a point."""
    p = np.asarray(p_values, dtype=float).ravel()
    p = p[np.isfinite(p)]
    return float(min(1.0, p.size * p.min())) if p.size else math.nan


def holm(p_values, alpha=FAMILY_ALPHA):
    """Holm's step-down procedure (Holm 1979): (rejected, threshold) per p-value, in the given
    order; threshold is alpha / (m - rank + 1), the level its p-value is compared with. NaN
    p-values take no part (rejected False, threshold NaN)."""
    p = np.asarray(p_values, dtype=float)
    rejected = np.zeros(p.size, dtype=bool)
    threshold = np.full(p.size, np.nan)
    finite = np.flatnonzero(np.isfinite(p))
    m = finite.size
    going = True
    for rank, i in enumerate(finite[np.argsort(p[finite], kind="stable")]):
        threshold[i] = alpha / (m - rank)
        going = going and p[i] <= threshold[i]
        rejected[i] = going
    return rejected.tolist(), threshold.tolist()


def pass_rule(inside, threshold=PASS_FRACTION):
    """(fraction of points inside, passed) over the finite entries of ``inside``."""
    inside = np.asarray(inside, dtype=float).ravel()
    inside = inside[np.isfinite(inside)]
    if inside.size == 0:
        return math.nan, False
    frac = float(inside.mean())
    return frac, bool(frac >= threshold)


def _rule(inside, p_points, test, deviation=""):
    """A verdict as stored: fraction inside the 95 % intervals, points, the points' p-values and
    their Bonferroni combination ``p_value``, the test, and ``deviation`` (a documented one:
    reported, not tested). ``pass`` is set by :func:`decide_rules` over the study."""
    p_points = np.asarray(p_points, dtype=float).ravel()
    frac, _ = pass_rule(inside)
    return {"inside": frac, "points": int(np.isfinite(np.asarray(inside, float)).sum()),
            "p_points": [float(x) for x in p_points], "test": test,
            "p_value": math.nan if deviation else bonferroni(p_points), "deviation": deviation,
            "pass": None}


def decide_rules(rules, alpha=FAMILY_ALPHA):
    """Holm over every tested rule of ``rules`` ({group: {name: rule}}), in place: ``pass``
    (None where there is no p-value or the rule is a deviation) and ``threshold``."""
    flat = [r for group in rules.values() for r in group.values()]
    rejected, threshold = holm([r["p_value"] for r in flat], alpha)
    for r, rej, thr in zip(flat, rejected, threshold):
        tested = np.isfinite(r["p_value"])
        r["pass"] = (not rej) if tested else None
        r["threshold"] = thr
    return rules


# ---- aggregate ------------------------------------------------------------------------------
def aggregate(paths):
    """One dataset of the verification study from single_particle case files.

    Groups (variables prefixed accordingly):
      prob_*:     mode (single, drop_weight) x material x energy_ratio: breakage probability.
      rep_*:      gamma x impact: repeated impacts (fraction broken after each impact).
      t10_*:      material x mode x energy_ratio (cases with replacement): product t10.
      psd_*:      material x mode x energy_ratio x sieve: product size distribution.
    Pass-rule results are global attributes (JSON) and printed by ``summary``.
    """
    cases = []
    for path in paths:
        ds = read_case(path, "single_particle")
        cases.append((case_parameters(ds), ds))
    out, coords = {}, {}
    attrs = {"source_cases": json.dumps([os.fspath(p) for p in paths]),
             "title": "millsim Tavares model verification (Tavares et al. 2021, section 4.1): "
                      "simulated against analytic breakage probabilities, repeated impacts and t10",
             # cases of other code would mix two engines' numbers in one verdict
             **same_code([ds for _, ds in cases], [os.fspath(p) for p in paths]),
             **case_cost([ds for _, ds in cases])}
    for group in (_probability, _repeated, _fragmentation):
        group(cases, out, coords, attrs)
    # the verdicts of this study decided together (Holm), stored per group
    rules = {k: json.loads(v) for k, v in attrs.items() if k.startswith("pass_rule_")}
    for key, group in decide_rules(rules).items():
        attrs[key] = json.dumps(group)

    sieves, paper, ours, target = table2_comparison()
    coords["table2_sieve"] = ("table2_sieve", sieves, {"units": "1", "long_name": "relative size x/d"})
    out["table2_paper"] = (("table2_sieve",), paper, {"units": "%",
                           "long_name": "Tavares et al. 2021, Table 2 mean % passing"})
    out["table2_families"] = (("table2_sieve",), ours, {"units": "%", "long_name": "our families, mean % passing"})
    out["table2_target"] = (("table2_sieve",), target, {"units": "%", "long_name": "eq 10 target (Table 1 parameters)"})
    for name, c in coords.items():
        if len(c) == 2:
            coords[name] = (c[0], c[1], {"units": "1"})
    return xr.Dataset(out, coords=coords, attrs=attrs)


def _inside(value, lo, hi, where):
    """1 where ``value`` lies in [lo, hi], 0 where not, NaN where ``where`` is not finite."""
    return np.where(np.isfinite(where), (value >= lo) & (value <= hi), np.nan)


def _probability(cases, out, coords, attrs):
    """Breakage probability (single impact and drop weight): the cases without replacement (5.5 mm
    in the paper); with replacement they are fragmentation cases of another size and go to t10 and
    size distributions only."""
    prob = [(p, ds) for p, ds in cases
            if p["mode"] in ("single", "drop_weight") and not p.get("replacement", True)]
    if not prob:
        return
    modes = sorted({p["mode"] for p, _ in prob})
    mats = sorted({p["material"] for p, _ in prob})
    ratios = sorted({_ratio(ds) for _, ds in prob})
    shape = (len(modes), len(mats), len(ratios))
    meta = {"n": ("1", "particles", "n_particles"),
            "broken": ("1", "particles broken", "n_broken"),
            "fraction": ("1", "fraction broken (simulation)", "broken_fraction"),
            "ci_lo": ("1", "95% Clopper-Pearson lower bound", "broken_fraction_ci_lo"),
            "ci_hi": ("1", "95% Clopper-Pearson upper bound", "broken_fraction_ci_hi"),
            "analytic": ("1", "breakage probability, eqs 1-3 at the absorbed energy",
                         "broken_fraction_analytic"),
            "inside": ("1", "analytic value inside the 95% interval (1/0)", None),
            "specific_energy": ("J kg-1", "input (stressing) specific energy Ek/m", "specific_energy"),
            "absorbed_share": ("1", "absorbed share of the input energy (eq 4)", "absorbed_share")}
    arr = {k: np.full(shape, np.nan) for k in meta}
    for p, ds in prob:
        ix = (modes.index(p["mode"]), mats.index(p["material"]), ratios.index(_ratio(ds)))
        for k, (_, _, var) in meta.items():
            if var is not None:
                arr[k][ix] = float(ds[var])
        attrs["prob_diameter_m"] = float(p["diameter"])
        attrs["prob_materials_file"] = p["materials_file"]  # the model curves of the figure
    arr["inside"] = _inside(arr["analytic"], arr["ci_lo"], arr["ci_hi"], arr["fraction"])
    coords.update(prob_mode=("prob_mode", modes), prob_material=("prob_material", mats),
                  energy_ratio=("energy_ratio", np.array(ratios), ENERGY_RATIO))
    dims = ("prob_mode", "prob_material", "energy_ratio")
    for k, v in arr.items():
        out[f"prob_{k}"] = (dims, v, {"units": meta[k][0], "long_name": meta[k][1]})
    p_points = binomial_p_value(arr["broken"], arr["n"], arr["analytic"])
    out["prob_p_value"] = (dims, p_points, {"units": "1", "long_name": "exact two-sided binomial "
                           "p-value of the broken count against the analytic probability"})
    rule = {}
    for m, mode in enumerate(modes):
        for j, mat in enumerate(mats):
            rule[f"{mode}/{mat}"] = _rule(arr["inside"][m, j], p_points[m, j], "binomial")
    attrs["pass_rule_probability"] = json.dumps(rule)


def _repeated(cases, out, coords, attrs):
    """Repeated impacts: the fraction broken after each impact, per damage coefficient gamma."""
    rep = [(p, ds) for p, ds in cases if p["mode"] == "repeated"]
    if not rep:
        return
    gammas = sorted({float(ds["gamma_used"]) for _, ds in rep})
    n_imp = max(int(ds.sizes["impact"]) for _, ds in rep)
    shape = (len(gammas), n_imp)
    meta = {"fraction": ("cumulative fraction broken (simulation)", "impact_broken_fraction"),
            "ci_lo": ("95% Clopper-Pearson lower", "impact_broken_fraction_ci_lo"),
            "ci_hi": ("95% Clopper-Pearson upper", "impact_broken_fraction_ci_hi"),
            "analytic": ("damage model (eqs 1-6), integrated", "impact_broken_fraction_analytic")}
    arr = {k: np.full(shape, np.nan) for k in meta}
    ns = np.full(len(gammas), np.nan)
    for p, ds in rep:
        g = gammas.index(float(ds["gamma_used"]))
        k = int(ds.sizes["impact"])
        for name, (_, var) in meta.items():
            arr[name][g, :k] = ds[var].values
        ns[g] = float(ds["n_particles"])
        attrs["rep_material"] = p["material"]
        attrs["rep_diameter_m"] = float(p["diameter"])
        attrs["rep_specific_energy_J_per_kg"] = float(ds["specific_energy"])
    inside = _inside(arr["analytic"], arr["ci_lo"], arr["ci_hi"], arr["fraction"])
    coords.update(gamma=("gamma", np.array(gammas), {"units": "1", "long_name": "damage coefficient (eq 6)"}),
                  impact=("impact", np.arange(1, n_imp + 1), {"units": "1", "long_name": "impact number"}))
    for k, v in arr.items():
        out[f"rep_{k}"] = (("gamma", "impact"), v, {"units": "1", "long_name": meta[k][0]})
    out["rep_inside"] = (("gamma", "impact"), inside, {"units": "1", "long_name": "analytic inside 95% interval"})
    out["rep_n"] = (("gamma",), ns, {"units": "1", "long_name": "particles"})
    # cumulative broken counts after each impact: binomial (independent particles)
    p_points = binomial_p_value(np.round(arr["fraction"] * ns[:, None]), ns[:, None],
                                arr["analytic"])
    out["rep_p_value"] = (("gamma", "impact"), p_points, {"units": "1", "long_name": "exact "
                          "two-sided binomial p-value of the cumulative broken count"})
    # one verdict per gamma (an "all" verdict would test the same points twice)
    rule = {f"gamma={g:g}": _rule(inside[i], p_points[i], "binomial")
            for i, g in enumerate(gammas)}
    attrs["pass_rule_repeated"] = json.dumps(rule)


def _fragmentation(cases, out, coords, attrs):
    """t10 and size distributions of the broken particles' product (cases with replacement)."""
    frag = [(p, ds) for p, ds in cases
            if p["mode"] in ("single", "drop_weight") and "product_passing" in ds]
    if not frag:
        return
    keys = sorted({_frag_key(p) for p, _ in frag})
    fr = sorted({_ratio(ds) for _, ds in frag})
    sieves = frag[0][1]["sieve"].values
    shape = (len(keys), len(fr))
    meta = {"t10": ("%", "t10 of the broken particles' product (simulation)", "product_t10"),
            "t10_lo": ("%", "95% bootstrap lower", "product_t10_ci_lo"),
            "t10_hi": ("%", "95% bootstrap upper", "product_t10_ci_hi"),
            "t10_expected": ("%", "mean of eq 8 over the broken", "product_t10_expected"),
            "t10_spread": ("%", "model standard deviation of one broken particle's t10",
                           "product_t10_spread"),
            "p_value": ("1", "two-sided p-value against the model's distribution of the mean",
                        "product_t10_p_value"),
            "t10_model": ("%", "eq 7, E50b = median of the broken", "product_t10_model"),
            "t10_model_all": ("%", "eq 7, E50b = median of all particles", "product_t10_model_all"),
            "t10_primary": ("%", "eq 9, primary breakage at the fracture energy", "t10_primary_model"),
            "specific_energy": ("J kg-1", "input (stressing) specific energy", "specific_energy"),
            "absorbed_share": ("1", "absorbed share of the input energy (eq 4)", "absorbed_share"),
            "broken": ("1", "particles broken", "n_broken")}
    arr = {k: np.full(shape, np.nan) for k in meta}
    psd = np.full(shape + (len(sieves),), np.nan)
    psd_model = np.full(shape + (len(sieves),), np.nan)
    for p, ds in frag:
        ix = (keys.index(_frag_key(p)), fr.index(_ratio(ds)))
        for k, (_, _, var) in meta.items():
            arr[k][ix] = float(ds[var])
        psd[ix] = ds["product_passing"].values
        psd_model[ix] = ds["product_passing_model"].values
        attrs["frag_materials_file"] = p["materials_file"]  # the model curves of the figures
    coords.update(frag_case=("frag_case", [_frag_label(k) for k in keys]),
                  frag_ratio=("frag_ratio", np.array(fr), ENERGY_RATIO),
                  sieve=("sieve", sieves, {"units": "1", "long_name": "sieve size / initial diameter"}))
    for k, v in arr.items():
        out[k if k.startswith("t10") else f"t10_{k}"] = (
            ("frag_case", "frag_ratio"), v, {"units": meta[k][0], "long_name": meta[k][1]})
    out["frag_material"] = (("frag_case",), [k[0] for k in keys],
                            {"units": "1", "long_name": "material of the materials file"})
    out["frag_diameter"] = (("frag_case",), [k[2] for k in keys],
                            {"units": "m", "long_name": "initial particle diameter"})
    out["psd_sim"] = (("frag_case", "frag_ratio", "sieve"), psd,
                      {"units": "%", "long_name": "cumulative % passing, broken particles' product"})
    out["psd_model"] = (("frag_case", "frag_ratio", "sieve"), psd_model,
                        {"units": "%", "long_name": "eq 10 + eqs 11-12 at the eq 7 t10"})
    inside = _inside(arr["t10_expected"], arr["t10_lo"], arr["t10_hi"], arr["t10"])
    out["t10_inside"] = (("frag_case", "frag_ratio"), inside, {
        "units": "1", "long_name": "mean of eq 8 inside the 95% bootstrap interval"})
    p_points = arr["p_value"]
    rule = {}
    for i, k in enumerate(keys):
        r = _rule(inside[i], p_points[i], "model-monte-carlo", DEVIATIONS.get(k[3], ""))
        r["t10_over_expected"] = [float(x) for x in arr["t10"][i] / arr["t10_expected"][i]]
        r["t10_over_model"] = [float(x) for x in arr["t10"][i] / arr["t10_model"][i]]
        rule[_frag_label(k)] = r
    attrs["pass_rule_t10"] = json.dumps(rule)


def _ratio(ds):
    # the same energy_ratio differs in the last digits between materials (it is recomputed from
    # the specific energy): one grid column per configured ratio
    return round(float(ds["energy_ratio"]), 9)


def _frag_key(p):
    # cases written before `breakage_at` existed broke at first reach
    return (p["material"], p["mode"], float(p["diameter"]), p.get("breakage_at", "first_reach"))


def _frag_label(key):
    m, mo, d, at = key
    return f"{m}/{mo}/{d * 1e3:g}mm/{at}"


def summary(ds):
    """Lines describing the pass-rule results of an aggregate."""
    lines = []
    for key in ("pass_rule_probability", "pass_rule_repeated", "pass_rule_t10"):
        if key in ds.attrs:
            for name, r in json.loads(ds.attrs[key]).items():
                status = ("DEVIATION (documented)" if r.get("deviation") else "n/a"
                          if r["pass"] is None else "PASS" if r["pass"] else "FAIL")
                lines.append(f"{key[10:]:12s} {name:32s} inside {100 * r['inside']:5.1f} %  "
                             f"p {r.get('p_value', math.nan):.3g}  {status}")
    return lines
