"""Analytic expectations of the Tavares model for single-particle tests, the pass rule, and the
aggregate and figures of the verification study (seed 002 section 4.1, Figs 8, 11, 13-16, Table 2).

Energy bases (docs/tavares.md section 2). The *set* specific energy of a test, ``Ek/m``, is the
**stressing (input)** energy: 1/2 v^2 of a particle thrown at a plate, 1/2 M v^2 / m of a
drop-weight striker of mass M. That is the x-axis of seed 002 Figs 8-11 and 16, and the basis on
which Table 4's E_inf was fitted. The particle absorbs the share ``e = k_s/(k_p + k_s)`` of it
(eq 4, both contacts of a drop-weight test are with steel), and the model compares the
*absorbed* energy ``e Ek/m`` with its fracture energy, whose median is ``e E_inf[1 + (d0/d)^phi]``
(eq 3). So the breakage probability against the input energy is eq 1 with median
``E_inf[1 + (d0/d)^phi]`` -- the two factors cancel.

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

    python -m millsim.analysis.tavares_verification aggregate CASES... --out tavares_verification.nc
    python -m millsim.analysis.tavares_verification plot KIND tavares_verification.nc --out fig.png
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

import numpy as np
from numba import njit
from scipy import stats

from ..breakage import tavares

LEVEL = 0.95
PASS_FRACTION = 0.90

# Seed 002 Table 2 (t10' = 3 %, Table 1 parameters): fragments per relative size (rows) in each
# of the 7 families (columns), dummy spheres, and the family probabilities.
TABLE2_SIZES = np.array([0.841, 0.707, 0.595, 0.500, 0.420, 0.354, 0.297, 0.250, 0.210])
TABLE2_COUNTS = np.array([[1, 1, 0, 0, 1, 1, 1], [0, 0, 2, 1, 0, 0, 0], [1, 0, 0, 2, 1, 1, 0],
                          [0, 2, 1, 0, 0, 0, 2], [1, 0, 1, 1, 1, 1, 1], [1, 1, 0, 1, 1, 0, 0],
                          [0, 1, 1, 2, 1, 2, 0], [1, 2, 0, 0, 0, 1, 2], [1, 1, 2, 0, 1, 1, 1]])
TABLE2_DUMMY = np.array([5, 5, 5, 6, 4, 5, 4])
TABLE2_PROB = np.array([34, 27, 23, 9, 5, 1, 1]) / 100.0


# ---- statistics -------------------------------------------------------------------------------
def binomial_interval(k, n, level=LEVEL, method="clopper_pearson"):
    """Two-sided interval of a binomial proportion k/n: (lo, hi), vectorised.

    ``clopper_pearson`` (exact, coverage >= level) or ``wilson`` (score interval).
    """
    k = np.asarray(k, dtype=float)
    n = np.asarray(n, dtype=float)
    a = 1.0 - level
    if method == "clopper_pearson":
        with np.errstate(invalid="ignore", divide="ignore"):
            lo = np.where(k > 0, stats.beta.ppf(a / 2, k, n - k + 1), 0.0)
            hi = np.where(k < n, stats.beta.ppf(1 - a / 2, k + 1, n - k), 1.0)
        return lo, hi
    if method == "wilson":
        z = stats.norm.ppf(1 - a / 2)
        p = k / n
        centre = (p + z * z / (2 * n)) / (1 + z * z / n)
        half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
        return centre - half, centre + half
    raise ValueError(f"method: {method!r} is not clopper_pearson or wilson")


def bootstrap_interval(values, weights=None, level=LEVEL, resamples=2000, seed=0):
    """Percentile bootstrap interval of the (weighted) mean of ``values``: (lo, hi)."""
    values = np.asarray(values, dtype=float)
    if values.size == 0:
        return math.nan, math.nan
    w = np.ones_like(values) if weights is None else np.asarray(weights, dtype=float)
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, values.size, size=(resamples, values.size))
    means = (values[idx] * w[idx]).sum(1) / w[idx].sum(1)
    a = 1.0 - level
    return float(np.quantile(means, a / 2)), float(np.quantile(means, 1 - a / 2))


def pass_rule(inside, threshold=PASS_FRACTION):
    """(fraction of points inside, passed) over the finite entries of ``inside``."""
    inside = np.asarray(inside, dtype=float).ravel()
    inside = inside[np.isfinite(inside)]
    if inside.size == 0:
        return math.nan, False
    frac = float(inside.mean())
    return frac, bool(frac >= threshold)


# ---- energies -------------------------------------------------------------------------------
def absorbed_share(mat, partner_stiffness=tavares.STEEL_STIFFNESS):
    """e = k_m/(k_p + k_m): the particle's share of an impact on a body of stiffness k_m (eq 4)."""
    return tavares.energy_share(mat.k, partner_stiffness)


def stressing_median(mat, d, share):
    """Median fracture energy on the stressing basis of a test whose absorbed share is ``share``."""
    return float(tavares.median_fracture_energy(mat, d)) / share


def breakage_probability(mat, d, specific_energy, share):
    """Eq 1-2: probability that one impact of input energy Ek/m [J/kg] breaks a fresh particle."""
    return tavares.fracture_energy_cdf(mat, d, share * np.asarray(specific_energy, dtype=float))


@njit(cache=True)
def _impacts_to_break(E, eps, gamma, n):
    """Impact (1..n) at which each fracture energy E breaks under repeated absorbed energy eps,
    n + 1 if it survives all n (eqs 5-6 between impacts)."""
    out = np.full(E.size, n + 1, dtype=np.int64)
    for i in range(E.size):
        e = E[i]
        for k in range(1, n + 1):
            if eps >= e:
                out[i] = k
                break
            e *= 1.0 - tavares.damage_fraction(eps / e, gamma)
    return out


def repeated_impact_broken(mat, d, specific_energy, share, impacts, gamma=None, grid=200_000):
    """Cumulative fraction broken after each of ``impacts`` impacts at the same input energy.

    A particle of fracture energy E breaks at impact k if the absorbed energy e Ek/m reaches its
    current (damaged) E_k; otherwise E_(k+1) = E_k (1 - D) with D from eq 6 at r = e Ek/(m E_k).
    The fraction is integrated over the truncated lognormal of E by the midpoint rule in its
    probability (``grid`` quantiles), so it is exact to ~1/grid.
    """
    gamma = mat.gamma if gamma is None else float(gamma)
    u = (np.arange(grid) + 0.5) / grid
    E = np.asarray(tavares.sample_fracture_energy(mat, d, u), dtype=float)
    k = _impacts_to_break(E, float(share * specific_energy), gamma, int(impacts))
    return np.array([(k <= n).mean() for n in range(1, impacts + 1)])


def median_of_broken(mat, d, absorbed):
    """E50b: median fracture energy of the particles that break at absorbed energy ``absorbed``."""
    E50 = float(tavares.median_fracture_energy(mat, d))
    p = float(tavares.fracture_energy_cdf(mat, d, absorbed))
    if p <= 0:
        return math.nan
    return float(tavares.truncated_lognormal_ppf(0.5 * p, E50, mat.Emax_over_E50 * E50, mat.sigma))


def t10_model(mat, d, specific_energy, share, median="broken"):
    """Eq 7 [%]: t10 = A [1 - exp(-b' Ek/E50b)] of the broken particles at input energy Ek/m.

    ``median`` "broken": E50b is the median fracture energy of the particles broken at that
    energy (Tavares and Carvalho 2009); "all": the median of the whole size class. The ratio is
    formed on the absorbed basis (same as the stressing basis, the share cancels).
    """
    absorbed = share * float(specific_energy)
    if median == "broken":
        E50b = median_of_broken(mat, d, absorbed)
    else:
        E50b = float(tavares.median_fracture_energy(mat, d))
    return float(tavares.t10_population(mat, absorbed, E50b))


def product_passing_model(mat, d, specific_energy, share, x_rel, median="broken"):
    """Modelled % passing x_rel = x/d of the broken particles (eq 10 with eq 7's t10, eqs 11-12
    below d/75)."""
    t10 = t10_model(mat, d, specific_energy, share, median)
    if not np.isfinite(t10):
        return np.full(np.shape(x_rel), np.nan)
    return tavares.cumulative_passing(t10, x_rel, mat)


# ---- Table 2 --------------------------------------------------------------------------------
def table2_passing():
    """Mean % passing each relative size of seed 002 Table 2 (fragment of size x_k retained on
    x_k, dummies pass x_min; each family normalised by its own volume)."""
    vol = TABLE2_COUNTS * TABLE2_SIZES[:, None] ** 3
    dummy = TABLE2_DUMMY * 0.210**3
    frac = np.vstack([vol, dummy]) / (vol.sum(0) + dummy)
    mean = frac @ TABLE2_PROB
    return 100 * np.array([mean[k + 1:].sum() for k in range(9)])


def table2_comparison(t10=3.0):
    """(relative sieves, seed Table 2, our families' mean, eq 10 target) in % passing."""
    sieves = tavares.SIEVE_RATIO ** -np.arange(1.0, 10.0)
    tab = tavares.generate_families(t10, tavares.TABLE1_AVERAGE)
    ours = tab.passing(sieves)
    target = tavares.cumulative_passing(t10, sieves, tavares.TABLE1_AVERAGE)
    return sieves, table2_passing(), np.asarray(ours), np.asarray(target)


# ---- aggregate ------------------------------------------------------------------------------
def _case_key(ds):
    from ..io import case_parameters

    p = case_parameters(ds)
    return p


def aggregate(paths):
    """One dataset of the verification study from single_particle case files.

    Groups (variables prefixed accordingly):
      prob_*:     mode (single, drop_weight) x material x energy_ratio: breakage probability.
      rep_*:      gamma x impact: repeated impacts (fraction broken after each impact).
      t10_*:      material x mode x energy_ratio (cases with replacement): product t10.
      psd_*:      material x mode x energy_ratio x sieve: product size distribution.
    Pass-rule results are global attributes (JSON) and printed by ``summary``.
    """
    import xarray as xr

    from ..io import read_case

    cases = []
    for path in paths:
        ds = read_case(path)
        if ds.attrs.get("scene") != "single_particle":
            raise ValueError(f"{path}: a case of scene {ds.attrs.get('scene')!r}, not single_particle")
        cases.append((os.fspath(path), ds, _case_key(ds)))
    out = {}
    coords = {}
    attrs = {"source_cases": json.dumps([c[0] for c in cases])}

    # -- breakage probability (single impact and drop weight) --
    # probability: the cases without replacement (5.5 mm in the seed); with replacement they are
    # fragmentation cases of another size and go to t10 / size distributions only
    prob = [(p, ds) for _, ds, p in cases
            if p["mode"] in ("single", "drop_weight") and not p.get("replacement", True)]
    if prob:
        modes = sorted({p["mode"] for p, _ in prob})
        mats = sorted({p["material"] for p, _ in prob})
        ratios = sorted({_ratio(ds) for _, ds in prob})
        shape = (len(modes), len(mats), len(ratios))
        names = ("n", "broken", "fraction", "ci_lo", "ci_hi", "analytic", "inside",
                 "specific_energy", "absorbed_share")
        arr = {k: np.full(shape, np.nan) for k in names}
        for p, ds in prob:
            ix = (modes.index(p["mode"]), mats.index(p["material"]),
                  ratios.index(_ratio(ds)))
            arr["n"][ix] = float(ds["n_particles"])
            arr["broken"][ix] = float(ds["n_broken"])
            arr["fraction"][ix] = float(ds["broken_fraction"])
            arr["ci_lo"][ix] = float(ds["broken_fraction_ci_lo"])
            arr["ci_hi"][ix] = float(ds["broken_fraction_ci_hi"])
            arr["analytic"][ix] = float(ds["broken_fraction_analytic"])
            arr["specific_energy"][ix] = float(ds["specific_energy"])
            arr["absorbed_share"][ix] = float(ds["absorbed_share"])
            attrs["prob_diameter_m"] = float(p["diameter"])
        arr["inside"] = np.where(np.isfinite(arr["fraction"]),
                                 (arr["analytic"] >= arr["ci_lo"]) & (arr["analytic"] <= arr["ci_hi"]),
                                 np.nan)
        coords.update(prob_mode=("prob_mode", modes), prob_material=("prob_material", mats),
                      energy_ratio=("energy_ratio", np.array(ratios), {"units": "1",
                                    "long_name": "input specific energy / median E50 (stressing basis)"}))
        dims = ("prob_mode", "prob_material", "energy_ratio")
        meta = {"n": ("1", "particles"), "broken": ("1", "particles broken"),
                "fraction": ("1", "fraction broken (simulation)"),
                "ci_lo": ("1", "95% Clopper-Pearson lower bound"),
                "ci_hi": ("1", "95% Clopper-Pearson upper bound"),
                "analytic": ("1", "breakage probability, eqs 1-3 at the absorbed energy"),
                "inside": ("1", "analytic value inside the 95% interval (1/0)"),
                "specific_energy": ("J kg-1", "input (stressing) specific energy Ek/m"),
                "absorbed_share": ("1", "absorbed share of the input energy (eq 4)")}
        for k, v in arr.items():
            out[f"prob_{k}"] = (dims, v, {"units": meta[k][0], "long_name": meta[k][1]})
        rule = {}
        for m, mode in enumerate(modes):
            for j, mat in enumerate(mats):
                frac, ok = pass_rule(arr["inside"][m, j])
                rule[f"{mode}/{mat}"] = {"inside": frac, "points": int(np.isfinite(arr["inside"][m, j]).sum()),
                                         "pass": ok}
        attrs["pass_rule_probability"] = json.dumps(rule)

    # -- repeated impacts --
    rep = [(p, ds) for _, ds, p in cases if p["mode"] == "repeated"]
    if rep:
        gammas = sorted({float(ds["gamma_used"]) for _, ds in rep})
        n_imp = max(int(ds.sizes["impact"]) for _, ds in rep)
        shape = (len(gammas), n_imp)
        arr = {k: np.full(shape, np.nan) for k in ("fraction", "ci_lo", "ci_hi", "analytic")}
        ns = np.full(len(gammas), np.nan)
        for p, ds in rep:
            g = gammas.index(float(ds["gamma_used"]))
            k = int(ds.sizes["impact"])
            arr["fraction"][g, :k] = ds["impact_broken_fraction"].values
            arr["ci_lo"][g, :k] = ds["impact_broken_fraction_ci_lo"].values
            arr["ci_hi"][g, :k] = ds["impact_broken_fraction_ci_hi"].values
            arr["analytic"][g, :k] = ds["impact_broken_fraction_analytic"].values
            ns[g] = float(ds["n_particles"])
            attrs["rep_material"] = p["material"]
            attrs["rep_diameter_m"] = float(p["diameter"])
            attrs["rep_specific_energy_J_per_kg"] = float(ds["specific_energy"])
        inside = np.where(np.isfinite(arr["fraction"]),
                          (arr["analytic"] >= arr["ci_lo"]) & (arr["analytic"] <= arr["ci_hi"]), np.nan)
        coords.update(gamma=("gamma", np.array(gammas), {"units": "1", "long_name": "damage coefficient (eq 6)"}),
                      impact=("impact", np.arange(1, n_imp + 1), {"units": "1", "long_name": "impact number"}))
        for k, v in arr.items():
            out[f"rep_{k}"] = (("gamma", "impact"), v, {"units": "1", "long_name": {
                "fraction": "cumulative fraction broken (simulation)", "ci_lo": "95% Clopper-Pearson lower",
                "ci_hi": "95% Clopper-Pearson upper", "analytic": "damage model (eqs 1-6), integrated"}[k]})
        out["rep_inside"] = (("gamma", "impact"), inside, {"units": "1", "long_name": "analytic inside 95% interval"})
        out["rep_n"] = (("gamma",), ns, {"units": "1", "long_name": "particles"})
        rule = {f"gamma={g:g}": dict(zip(("inside", "pass"), pass_rule(inside[i])))
                for i, g in enumerate(gammas)}
        rule["all"] = dict(zip(("inside", "pass"), pass_rule(inside)))
        attrs["pass_rule_repeated"] = json.dumps(rule)

    # -- t10 and size distributions (cases with replacement) --
    frag = [(p, ds) for _, ds, p in cases
            if p["mode"] in ("single", "drop_weight") and "product_passing" in ds]
    if frag:
        keys = sorted({_frag_key(p) for p, _ in frag})
        fr = sorted({_ratio(ds) for _, ds in frag})
        sieves = frag[0][1]["sieve"].values
        shape = (len(keys), len(fr))
        names = ("t10", "t10_lo", "t10_hi", "t10_model", "t10_model_all", "t10_primary",
                 "specific_energy", "broken")
        arr = {k: np.full(shape, np.nan) for k in names}
        psd = np.full(shape + (len(sieves),), np.nan)
        psd_model = np.full(shape + (len(sieves),), np.nan)
        for p, ds in frag:
            ix = (keys.index(_frag_key(p)),
                  fr.index(_ratio(ds)))
            arr["t10"][ix] = float(ds["product_t10"])
            arr["t10_lo"][ix] = float(ds["product_t10_ci_lo"])
            arr["t10_hi"][ix] = float(ds["product_t10_ci_hi"])
            arr["t10_model"][ix] = float(ds["product_t10_model"])
            arr["t10_model_all"][ix] = float(ds["product_t10_model_all"])
            arr["t10_primary"][ix] = float(ds["t10_primary_model"])
            arr["specific_energy"][ix] = float(ds["specific_energy"])
            arr["broken"][ix] = float(ds["n_broken"])
            psd[ix] = ds["product_passing"].values
            psd_model[ix] = ds["product_passing_model"].values
        coords.update(frag_case=("frag_case", [_frag_label(k) for k in keys]),
                      frag_ratio=("frag_ratio", np.array(fr), {"units": "1",
                                  "long_name": "input specific energy / median E50 (stressing basis)"}),
                      sieve=("sieve", sieves, {"units": "1", "long_name": "sieve size / initial diameter"}))
        meta = {"t10": ("%", "t10 of the broken particles' product (simulation)"),
                "t10_lo": ("%", "95% bootstrap lower"), "t10_hi": ("%", "95% bootstrap upper"),
                "t10_model": ("%", "eq 7, E50b = median of the broken"),
                "t10_model_all": ("%", "eq 7, E50b = median of all particles"),
                "t10_primary": ("%", "eq 9, primary breakage at the fracture energy"),
                "specific_energy": ("J kg-1", "input (stressing) specific energy"),
                "broken": ("1", "particles broken")}
        for k, v in arr.items():
            out[f"t10_{k}" if not k.startswith("t10") else k] = (("frag_case", "frag_ratio"), v,
                                                                  {"units": meta[k][0], "long_name": meta[k][1]})
        out["psd_sim"] = (("frag_case", "frag_ratio", "sieve"), psd,
                          {"units": "%", "long_name": "cumulative % passing, broken particles' product"})
        out["psd_model"] = (("frag_case", "frag_ratio", "sieve"), psd_model,
                            {"units": "%", "long_name": "eq 10 + eqs 11-12 at the eq 7 t10"})
        inside = np.where(np.isfinite(arr["t10"]),
                          (arr["t10_model"] >= arr["t10_lo"]) & (arr["t10_model"] <= arr["t10_hi"]), np.nan)
        out["t10_inside"] = (("frag_case", "frag_ratio"), inside,
                             {"units": "1", "long_name": "eq 7 inside the 95% bootstrap interval"})
        rule = {_frag_label(k): dict(zip(("inside", "pass"), pass_rule(inside[i])))
                for i, k in enumerate(keys)}
        attrs["pass_rule_t10"] = json.dumps(rule)

    sieves, seed, ours, target = table2_comparison()
    coords["table2_sieve"] = ("table2_sieve", sieves, {"units": "1", "long_name": "relative size x/d"})
    out["table2_seed"] = (("table2_sieve",), seed, {"units": "%", "long_name": "seed 002 Table 2 mean % passing"})
    out["table2_families"] = (("table2_sieve",), ours, {"units": "%", "long_name": "our families, mean % passing"})
    out["table2_target"] = (("table2_sieve",), target, {"units": "%", "long_name": "eq 10 target (Table 1 parameters)"})
    for name, c in coords.items():
        if len(c) == 2:
            coords[name] = (c[0], c[1], {"units": "1"})
    return xr.Dataset(out, coords=coords, attrs=attrs)


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


# ---- figures --------------------------------------------------------------------------------
def _figure(figsize):
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained")


def plot_probability(ds, out):
    """Seed 002 Fig. 8: breakage probability vs input specific energy, 3 materials, single impact
    and drop weight; analytic eq 1 curves and 95 % intervals."""
    import matplotlib

    fig = _figure((7.5, 5))
    ax = fig.subplots()
    colours = matplotlib.colormaps["tab10"]
    markers = {"single": "o", "drop_weight": "s"}
    for j, mat_name in enumerate(ds["prob_material"].values):
        mat = _material(str(mat_name))
        share = float(np.nanmean(ds["prob_absorbed_share"].isel(prob_material=j)))
        d = float(ds.attrs.get("prob_diameter_m", 5.5e-3))
        E = ds["prob_specific_energy"].isel(prob_material=j)
        emax = float(np.nanmax(E)) * 1.2
        x = np.geomspace(emax / 100, emax, 300)
        ax.plot(x, breakage_probability(mat, d, x, share), "-", color=colours(j), lw=1.2,
                label=f"{mat_name}: model (eq 1)")
        for m, mode in enumerate(ds["prob_mode"].values):
            sub = {k: ds[f"prob_{k}"].isel(prob_mode=m, prob_material=j).values
                   for k in ("specific_energy", "fraction", "ci_lo", "ci_hi")}
            ok = np.isfinite(sub["fraction"])
            if not ok.any():
                continue
            ax.errorbar(sub["specific_energy"][ok], sub["fraction"][ok],
                        yerr=[sub["fraction"][ok] - sub["ci_lo"][ok], sub["ci_hi"][ok] - sub["fraction"][ok]],
                        fmt=markers.get(str(mode), "^"), color=colours(j), mfc="none" if mode == "drop_weight" else None,
                        capsize=2, ls="none", label=f"{mat_name}: {mode} (sim., 95% CI)")
    ax.set(xscale="log", xlabel="input specific energy Ek/m [J/kg]", ylabel="fraction broken [1]",
           ylim=(-0.02, 1.02), title="Breakage probability: simulation vs model (seed 002 Fig. 8)")
    ax.legend(fontsize="x-small")
    fig.savefig(out, dpi=120)


def plot_repeated(ds, out):
    """Seed 002 Fig. 11: cumulative fraction broken after each repeated impact, several gamma."""
    import matplotlib

    fig = _figure((7, 5))
    ax = fig.subplots()
    colours = matplotlib.colormaps["viridis"]
    ng = ds.sizes["gamma"]
    for g in range(ng):
        c = colours(g / max(ng - 1, 1))
        sub = ds.isel(gamma=g)
        k = ds["impact"].values
        ax.plot(k, sub["rep_analytic"], "-", color=c, label=f"model, gamma = {float(ds['gamma'][g]):g}")
        f = sub["rep_fraction"].values
        ax.errorbar(k, f, yerr=[f - sub["rep_ci_lo"].values, sub["rep_ci_hi"].values - f], fmt="o",
                    color=c, ms=3, capsize=2, ls="none")
    ax.set(xlabel="impact number", ylabel="cumulative fraction broken [1]", ylim=(0, 1),
           title=f"Repeated impacts: {ds.attrs.get('rep_material', '')} "
                 f"{1e3 * float(ds.attrs.get('rep_diameter_m', math.nan)):g} mm at "
                 f"{float(ds.attrs.get('rep_specific_energy_J_per_kg', math.nan)):g} J/kg "
                 "(seed 002 Fig. 11; symbols: simulation, 95% CI)")
    ax.title.set_fontsize("small")
    ax.legend(fontsize="small")
    fig.savefig(out, dpi=120)


def plot_t10(ds, out):
    """Seed 002 Fig. 16: t10 of the product vs input specific energy, simulation vs eq 7.
    Colour: material/mode/size; marker: when particles break (breakage_at)."""
    import matplotlib

    fig = _figure((8.5, 5.5))
    ax = fig.subplots()
    colours = matplotlib.colormaps["tab10"]
    markers = {"first_reach": "o", "end_of_loading": "s"}
    groups = []
    for i, name in enumerate(ds["frag_case"].values):
        group, _, at = str(name).rpartition("/")
        first = group not in groups
        if first:
            groups.append(group)
        c = colours(groups.index(group))
        sub = ds.isel(frag_case=i)
        E = sub["t10_specific_energy"].values
        ok = np.isfinite(sub["t10"].values)
        order = np.argsort(E[ok])
        if first:  # the model does not depend on breakage_at
            for key, style, lw in (("t10_model", "-", 1.4), ("t10_model_all", ":", 1.0),
                                   ("t10_primary", "--", 0.8)):
                ax.plot(E[ok][order], sub[key].values[ok][order], style, color=c, lw=lw,
                        label=f"{group}: eq 7" if key == "t10_model" else None)
        t = sub["t10"].values
        ax.errorbar(E[ok], t[ok], yerr=[t[ok] - sub["t10_lo"].values[ok], sub["t10_hi"].values[ok] - t[ok]],
                    fmt=markers.get(at, "^"), color=c, mfc="white" if at == "end_of_loading" else c,
                    capsize=2, ls="none", label=f"{group}, {at}")
    ax.set(xscale="log", xlabel="input specific energy Ek/m [J/kg]", ylabel="t10 [%]",
           title="t10 vs energy (seed 002 Fig. 16), 95% bootstrap intervals\n"
                 "solid: eq 7 (E50b of the broken), dotted: E50 of all, dashed: eq 9")
    ax.title.set_fontsize("small")
    ax.legend(fontsize="x-small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.savefig(out, dpi=120)


def plot_size_distributions(ds, out):
    """Seed 002 Figs. 13-15: cumulative product size distribution of the broken particles, with the
    fines extension (eq 11) below the smallest family size; lines: eq 10 model."""
    import matplotlib

    n = ds.sizes["frag_case"]
    fig = _figure((6 * n, 4.8))
    axes = np.atleast_1d(fig.subplots(1, n, squeeze=False)[0])
    colours = matplotlib.colormaps["plasma"]
    x = ds["sieve"].values
    nr = ds.sizes["frag_ratio"]
    for i, ax in enumerate(axes):
        sub = ds.isel(frag_case=i)
        for r in range(nr):
            c = colours(r / max(nr, 1))
            sim = sub["psd_sim"].isel(frag_ratio=r).values
            if not np.isfinite(sim).any():
                continue
            E = float(sub["t10_specific_energy"].isel(frag_ratio=r))
            ax.plot(x, sub["psd_model"].isel(frag_ratio=r), "-", color=c, lw=1)
            ax.plot(x, sim, "o", color=c, ms=3, label=f"{E:.0f} J/kg")
        ax.axvline(tavares.SIEVE_RATIO ** -tavares.STANDARD_CLASSES, color="k", ls="--", lw=0.8)
        ax.axvline(0.05, color="r", ls="--", lw=0.8)
        ax.set(xscale="log", yscale="log", xlabel="size / initial size [1]", ylabel="cumulative % passing",
               ylim=(0.01, 110), title=f"{sub['frag_case'].item()} (symbols: sim., lines: model)")
        ax.title.set_fontsize("small")
        ax.legend(fontsize="x-small")
    fig.savefig(out, dpi=120)


def plot_table2(ds, out):
    """Seed 002 Table 2: mean % passing of the t10' = 3 % families, ours vs the paper's."""
    fig = _figure((6.5, 4.5))
    ax = fig.subplots()
    x = ds["table2_sieve"].values
    ax.plot(x, ds["table2_target"], "k-", lw=1, label="eq 10 target (Table 1 average parameters)")
    ax.plot(x, ds["table2_seed"], "s", mfc="none", label="seed 002 Table 2 (7 families)")
    ax.plot(x, ds["table2_families"], "o", ms=4, label="millsim families")
    ax.set(xscale="log", yscale="log", xlabel="relative size x/d [1]", ylabel="cumulative % passing",
           title="Progeny families at t10' = 3 %")
    ax.legend(fontsize="small")
    fig.savefig(out, dpi=120)


PLOTS = {"probability": plot_probability, "repeated": plot_repeated, "t10": plot_t10,
         "size_distributions": plot_size_distributions, "table2": plot_table2}


def _material(name, truncation="single_particle"):
    return tavares.load_materials(truncation=truncation)[name]


def plot(kind, path, out):
    import xarray as xr

    if kind not in PLOTS:
        raise ValueError(f"kind: {kind!r} is not one of {sorted(PLOTS)}")
    ds = xr.load_dataset(path)
    PLOTS[kind](ds, out)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m millsim.analysis.tavares_verification")
    sub = parser.add_subparsers(dest="command", required=True)
    a = sub.add_parser("aggregate", help="stack single_particle cases into the verification aggregate")
    a.add_argument("cases", nargs="+")
    a.add_argument("--out", required=True)
    p = sub.add_parser("plot", help=f"draw a figure: {', '.join(PLOTS)}")
    p.add_argument("kind")
    p.add_argument("input")
    p.add_argument("--out", required=True)
    s = sub.add_parser("summary", help="print the pass-rule results of an aggregate")
    s.add_argument("input")
    args = parser.parse_args(argv)
    try:
        if args.command == "aggregate":
            ds = aggregate(args.cases)
            encoding = {name: {"_FillValue": None} for name in ds.coords}
            ds.to_netcdf(args.out, engine="netcdf4", format="NETCDF4", encoding=encoding)
            print("\n".join(summary(ds)))
        elif args.command == "plot":
            plot(args.kind, args.input, args.out)
        else:
            import xarray as xr

            print("\n".join(summary(xr.load_dataset(args.input))))
    except (ValueError, FileNotFoundError) as exc:
        print(f"tavares_verification: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
