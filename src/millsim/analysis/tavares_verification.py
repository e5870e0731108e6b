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
- t10 of the broken particles: eq 7, t10 = A [1 - exp(-b' Ek/E50b)], with E50b the median
  fracture energy of the particles that break at that energy (Tavares and Carvalho 2009), on the
  same basis as Ek (``t10_model``); the primary-event value of eq 9 for reference;
- product size distribution of the broken particles: eq 10 through that t10, extended below d/75
  by the eq 11-12 power law (``product_passing_model``).

Pass rule: the analytic value lies inside the 95 % Clopper-Pearson interval of the simulated
fraction (probabilities) or the 95 % bootstrap interval over particles (t10) at >= 90 % of the
points of each test.

Command line (used by the pipeline)::

    millsim analyse tavares aggregate CASES... --out tavares_verification.nc
    millsim analyse tavares summary tavares_verification.nc
    millsim plot tavares_KIND tavares_verification.nc --out fig.png
"""

from __future__ import annotations

import json
import math
import os

import numpy as np
import xarray as xr

from ..io import case_parameters, read_case
from ..models.breakage.tavares_predictions import table2_comparison

PASS_FRACTION = 0.90
ENERGY_RATIO = {"units": "1", "long_name": "input specific energy / median E50 (stressing basis)"}


def pass_rule(inside, threshold=PASS_FRACTION):
    """(fraction of points inside, passed) over the finite entries of ``inside``."""
    inside = np.asarray(inside, dtype=float).ravel()
    inside = inside[np.isfinite(inside)]
    if inside.size == 0:
        return math.nan, False
    frac = float(inside.mean())
    return frac, bool(frac >= threshold)


def _rule(inside):
    """A pass-rule result as stored: fraction inside, points, passed."""
    frac, ok = pass_rule(inside)
    return {"inside": frac, "points": int(np.isfinite(np.asarray(inside, float)).sum()), "pass": ok}


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
                      "simulated against analytic breakage probabilities, repeated impacts and t10"}
    for group in (_probability, _repeated, _fragmentation):
        group(cases, out, coords, attrs)

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
    rule = {}
    for m, mode in enumerate(modes):
        for j, mat in enumerate(mats):
            frac, ok = pass_rule(arr["inside"][m, j])
            rule[f"{mode}/{mat}"] = _rule(arr["inside"][m, j])
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
    rule = {f"gamma={g:g}": _rule(inside[i]) for i, g in enumerate(gammas)}
    if len(gammas) > 1:
        rule["all"] = _rule(inside)
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
    inside = _inside(arr["t10_model"], arr["t10_lo"], arr["t10_hi"], arr["t10"])
    out["t10_inside"] = (("frag_case", "frag_ratio"), inside,
                         {"units": "1", "long_name": "eq 7 inside the 95% bootstrap interval"})
    rule = {_frag_label(k): _rule(inside[i]) for i, k in enumerate(keys)}
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
                lines.append(f"{key[10:]:12s} {name:32s} inside {100 * r['inside']:5.1f} %  "
                             f"{'PASS' if r['pass'] else 'FAIL'}")
    return lines
