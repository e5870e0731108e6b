"""Whole-function sweeps of the functions where the fresh sampled mutants of issue 47 survived
(seed 48), part 1: tavares_verification and util/stats (report: test_analysis_whole_functions_report.py).
Each test sweeps the branches and boundaries of one function, not one mutant: table-driven over
its cases, against scipy's own implementations (binomtest, its exact and Wilson intervals),
closed forms (the Student t quantile at 1 and 2 degrees of freedom, Clopper-Pearson's ends, the
bootstrap distribution of two or three values, least squares in exact fractions) and aggregates
computed by hand from made-up case files. Pure Python on synthetic data: no simulation.
"""

import json
import math
from fractions import Fraction

import numpy as np
import pytest
import xarray as xr
from scipy import stats as scipy_stats

from millsim.analysis import tavares_verification as tv
from millsim.io import write_case
from millsim.util import stats

Z95 = 1.959963984540054  # normal 97.5 % quantile (Abramowitz & Stegun 26.2)
NAN = math.nan


def t_quantile(q, dof):
    """Student t quantile in closed form: Cauchy at 1 degree of freedom, and
    (2q - 1) / sqrt(2 q (1 - q)) at 2 (Hill 1970)."""
    if dof == 1:
        return math.tan(math.pi * (q - 0.5))
    if dof == 2:
        return (2 * q - 1) / math.sqrt(2 * q * (1 - q))
    raise ValueError(dof)


def normal_two_sided(z):
    return math.erfc(z / math.sqrt(2))


# ---- tavares_verification.binomial_p_value: every count, scipy's slack and its exact ties -------

@pytest.mark.parametrize("n", [1, 2, 3, 7, 20])
@pytest.mark.parametrize("p", [0.0, 0.03, 0.3, 0.5, 0.77, 1.0])
def test_binomial_p_value_of_every_count_is_scipys_binomtest(n, p):
    """All counts 0..n at once (vectorised) against scipy.stats.binomtest, including p at 0 and
    1 (a count the model forbids: p-value 0) and the symmetric p = 0.5 (equal-pmf ties)."""
    k = np.arange(n + 1)
    got = tv.binomial_p_value(k, n, p)
    want = [scipy_stats.binomtest(int(j), n, p).pvalue for j in k]
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-300)
    assert (got <= 1.0).all()


@pytest.mark.parametrize("eps, both", [(3e-8, True), (9e-8, True), (1.2e-7, False),
                                       (3e-7, False)])
def test_binomial_p_value_counts_as_likely_within_scipys_relative_slack(eps, both):
    """One trial at p = (1 + eps) / (2 + eps): count 1 is (1 + eps) times as likely as 0. Within
    scipy's slack of 1e-7 both counts are "as likely" (p-value 1), beyond it only count 0."""
    p = (1 + eps) / (2 + eps)
    got = float(tv.binomial_p_value(0, 1, p))
    assert got == pytest.approx(1.0 if both else 1 - p, rel=1e-12)
    assert got == pytest.approx(scipy_stats.binomtest(0, 1, p).pvalue, rel=1e-12)


def _exact_ties(triples, steps=600):
    """(n, k, p) where pmf(j) == pmf(k) x (1 + 1e-7) to the last bit: searched over the floats
    around the analytic crossing C(n,j)/C(n,k) (p/(1-p))^(j-k) = 1 + 1e-7."""
    found = []
    for n, k, j in triples:
        t = ((1 + 1e-7) * math.comb(n, k) / math.comb(n, j)) ** (1 / (j - k))
        p = t / (1 + t) - steps / 2 * np.spacing(t / (1 + t))
        for _ in range(steps):
            pmf = scipy_stats.binom.pmf(np.arange(n + 1), n, p)
            if pmf[j] == pmf[k] * (1 + 1e-7):
                found.append((n, k, float(p)))
                break
            p = np.nextafter(p, 1.0)
    return found


def test_binomial_p_value_includes_a_count_exactly_at_the_slack():
    """scipy's binomtest counts a pmf equal to pmf(k) x (1 + 1e-7) as as likely (its `<=` and its
    explicit equality term); floats where that equality holds exist, so the edge is a behaviour."""
    ties = _exact_ties([(1, 1, 0), (2, 2, 1), (4, 1, 0), (4, 0, 2), (5, 4, 1), (6, 2, 0)])
    assert len(ties) >= 3, ties
    for n, k, p in ties:
        assert float(tv.binomial_p_value(k, n, p)) == pytest.approx(
            scipy_stats.binomtest(k, n, p).pvalue, rel=1e-12), (n, k, p)


def test_binomial_p_value_without_a_number_or_a_trial_is_nan():
    got = tv.binomial_p_value([NAN, 1, 1, 1, 0], [5, NAN, 5, 5, 0], [0.5, 0.5, NAN, math.inf, 0.5])
    assert np.isnan(got).all()
    # broadcasting: one n and p for a column of counts keeps the counts' shape
    assert tv.binomial_p_value([[0], [3]], 3, 0.5).shape == (2, 1)


# ---- tavares_verification.interval_p_value: both sides, ties, degenerate and half-known ----------

ROWS = [  # estimate, lo, hi, model, the standard error's half-width (None: p given)
    (10.0, 8.0, 14.0, 13.0, 4.0),    # model above: the upper half-width 4
    (10.0, 8.0, 14.0, 7.0, 2.0),     # model below: the lower half-width 2
    (10.0, 8.0, 14.0, 14.0, 4.0),    # on the upper end: z = 1.96, p = 0.05
    (10.0, 8.0, 14.0, 10.0, None),   # at the estimate: z = 0, p = 1
    (10.0, NAN, 14.0, 12.0, 4.0),    # the lower end unknown, not needed
    (10.0, 8.0, NAN, 9.0, 2.0),      # the upper end unknown, not needed
]


@pytest.mark.parametrize("estimate, lo, hi, model, half", ROWS)
def test_interval_p_value_reads_the_error_from_the_side_of_the_model(estimate, lo, hi, model,
                                                                     half):
    want = 1.0 if half is None else normal_two_sided(abs(model - estimate) / (half / Z95))
    assert float(tv.interval_p_value(estimate, lo, hi, model)) == pytest.approx(want, rel=1e-12)


@pytest.mark.parametrize("estimate, lo, hi, model, want", [
    (10.0, 10.0, 10.0, 10.0, 1.0),   # a zero-width interval at the model: not rejected
    (10.0, 10.0, 10.0, 11.0, 0.0),   # a zero-width interval off the model: z infinite
    (10.0, 9.0, 10.0, 11.0, 0.0),    # no upper half-width, model above
    (10.0, 10.0, 12.0, 9.0, 0.0),    # no lower half-width, model below
    (10.0, 10.0, 12.0, 10.0, 1.0),   # no lower half-width, model at the estimate
    (10.0, NAN, 14.0, 10.0, 1.0),    # model at the estimate: z = 0 with the upper side's error
    (10.0, NAN, 14.0, 9.0, NAN),     # the side towards the model unknown
    (10.0, 8.0, NAN, 11.0, NAN),
    (NAN, 8.0, 14.0, 11.0, NAN),
])
def test_interval_p_value_at_degenerate_and_half_known_intervals(estimate, lo, hi, model, want):
    got = float(tv.interval_p_value(estimate, lo, hi, model))
    assert (math.isnan(got) and math.isnan(want)) or got == want


def test_interval_p_value_is_vectorised_and_takes_another_level():
    """The 99 % quantile 2.5758 turns a half-width 4 into a standard error 4 / 2.5758."""
    z99 = 2.5758293035489004
    got = tv.interval_p_value([10.0, 10.0], [8.0, 8.0], [14.0, 14.0], [13.0, 7.0], level_z=z99)
    want = [normal_two_sided(3 / (4 / z99)), normal_two_sided(3 / (2 / z99))]
    np.testing.assert_allclose(got, want, rtol=1e-12)


# ---- tavares_verification.aggregate: repeated impacts and fragmentation, whole groups -----------

def _case(path, params, data, coords=None):
    ds = xr.Dataset({k: xr.Variable(dims, np.asarray(v, float), {"units": "1"})
                     for k, (dims, v) in data.items()}, coords=coords or {})
    write_case(path, ds, {"scene": "single_particle", "seed": 1, "dt": 1e-6, "steps": 10,
                          "wall_time_s": 2.0,
                          "parameters": dict(material="limestone", diameter=0.005,
                                             materials_file="materials.yaml", seed=1, **params)})
    return path


def _repeated_case(path, gamma, fraction, lo, hi, analytic, n=50):
    dims = ("impact",)
    return _case(path, dict(mode="repeated"), {
        "gamma_used": ((), gamma), "n_particles": ((), n), "specific_energy": ((), 120.0),
        "impact_broken_fraction": (dims, fraction), "impact_broken_fraction_ci_lo": (dims, lo),
        "impact_broken_fraction_ci_hi": (dims, hi),
        "impact_broken_fraction_analytic": (dims, analytic)},
        {"impact": ("impact", np.arange(1, len(fraction) + 1), {"units": "1"})})


def test_repeated_impacts_aggregate_by_hand(tmp_path):
    """Two damage coefficients, given out of order, with 3 and 2 impacts of 50 particles: the
    grid is gamma ascending x impacts 1..3, the shorter run padded with NaN; the model inside
    [lo, hi] (ends included) per point; each point's p-value scipy's binomtest of the broken
    count; a verdict per gamma: Bonferroni over its points, then Holm over the two verdicts."""
    paths = [_repeated_case(tmp_path / "g5.nc", 5.0, [0.2, 0.4], [0.1, 0.27], [0.33, 0.54],
                            [0.33, 0.4]),
             _repeated_case(tmp_path / "g2.nc", 2.0, [0.1, 0.3, 0.6], [0.03, 0.18, 0.45],
                            [0.22, 0.45, 0.74], [0.12, 0.55, 0.62])]
    ds = tv.aggregate(paths)
    assert ds["gamma"].values.tolist() == [2.0, 5.0]
    assert ds["impact"].values.tolist() == [1, 2, 3]
    assert ds["rep_n"].values.tolist() == [50.0, 50.0]
    np.testing.assert_array_equal(ds["rep_fraction"], [[0.1, 0.3, 0.6], [0.2, 0.4, NAN]])
    np.testing.assert_array_equal(ds["rep_analytic"], [[0.12, 0.55, 0.62], [0.33, 0.4, NAN]])
    # 0.55 above [0.18, 0.45]; 0.33 on the upper end 0.33: inside
    np.testing.assert_array_equal(ds["rep_inside"], [[1.0, 0.0, 1.0], [1.0, 1.0, NAN]])
    counts = {2.0: ([5, 15, 30], [0.12, 0.55, 0.62]), 5.0: ([10, 20], [0.33, 0.4])}
    p = {g: [scipy_stats.binomtest(k, 50, q).pvalue for k, q in zip(*counts[g])] for g in counts}
    np.testing.assert_allclose(ds["rep_p_value"].values[0], p[2.0], rtol=1e-9)
    np.testing.assert_allclose(ds["rep_p_value"].values[1, :2], p[5.0], rtol=1e-9)
    assert math.isnan(float(ds["rep_p_value"][1, 2]))
    rules = json.loads(ds.attrs["pass_rule_repeated"])
    assert list(rules) == ["gamma=2", "gamma=5"]
    combined = {g: min(1.0, len(p[g]) * min(p[g])) for g in p}
    # Holm by hand: gamma=2's 15 of 50 against 0.55 is far off (p ~ 1e-4, x 3 < 0.05 / 2);
    # gamma=5 is then compared with 0.05 / 1
    assert combined[2.0] < 0.025 < 0.05 < combined[5.0]
    for g, name, points, inside, passed, threshold in ((2.0, "gamma=2", 3, 2 / 3, False, 0.025),
                                                       (5.0, "gamma=5", 2, 1.0, True, 0.05)):
        r = rules[name]
        assert (r["points"], r["test"], r["pass"]) == (points, "binomial", passed)
        assert r["inside"] == pytest.approx(inside, rel=1e-12)
        assert r["p_value"] == pytest.approx(combined[g], rel=1e-9)
        assert r["threshold"] == pytest.approx(threshold, rel=1e-12)
    assert ds.attrs["rep_material"] == "limestone" and ds.attrs["rep_diameter_m"] == 0.005
    assert ds.attrs["rep_specific_energy_J_per_kg"] == 120.0


T10_UNITS = {"t10": "%", "t10_lo": "%", "t10_hi": "%", "t10_expected": "%", "t10_spread": "%",
             "t10_p_value": "1", "t10_model": "%", "t10_model_all": "%",
             "t10_primary": "%", "t10_specific_energy": "J kg-1", "t10_absorbed_share": "1",
             "t10_broken": "1"}


def _t10_case(path, breakage_at, t10, lo, hi, expected, model=None, p_value=0.5, ratio=2.0,
              mode="drop_weight"):
    model = expected if model is None else model
    sieve = ("sieve",)
    return _case(path, dict(mode=mode, replacement=True, breakage_at=breakage_at), {
        "energy_ratio": ((), ratio), "product_t10": ((), t10), "product_t10_ci_lo": ((), lo),
        "product_t10_ci_hi": ((), hi), "product_t10_expected": ((), expected),
        "product_t10_spread": ((), 5.0), "product_t10_p_value": ((), p_value),
        "product_t10_model": ((), model),
        "product_t10_model_all": ((), model + 1.0), "t10_primary_model": ((), 5.0),
        "specific_energy": ((), 50.0 * ratio), "absorbed_share": ((), 0.8),
        "n_broken": ((), 30.0), "product_passing": (sieve, [8.0, 40.0, 90.0]),
        "product_passing_model": (sieve, [9.0, 42.0, 88.0])},
        {"sieve": ("sieve", [0.05, 0.25, 0.5], {"units": "1"})})


def _probability_case(path, broken, analytic, n=50, ratio=1.0):
    return _case(path, dict(mode="single", replacement=False), {
        "energy_ratio": ((), ratio), "n_particles": ((), n), "n_broken": ((), broken),
        "broken_fraction": ((), broken / n), "broken_fraction_ci_lo": ((), 0.26),
        "broken_fraction_ci_hi": ((), 0.55), "broken_fraction_analytic": ((), analytic),
        "specific_energy": ((), 80.0), "absorbed_share": ((), 0.7)})


@pytest.mark.parametrize("at", [["fracture"], ["first_reach", "fracture"]])
def test_fragmentation_aggregate_by_hand(tmp_path, at):
    """One t10 case, and that case with a first_reach one (a documented deviation: no
    p-value, no verdict), beside a probability case (no product: not a t10 case). Every
    variable keeps its unit and words; the sieves are the cases'; the p-value is the normal one
    the case's (the scene's Monte Carlo against the mean of eq 8; eq 7 is reported beside it);
    Holm over the two tested verdicts."""
    values = {"fracture": (12.0, 10.0, 15.0, 14.0, 11.0, 0.031),
              "first_reach": (7.0, 6.0, 9.0, 10.0, 10.0, 0.002)}
    paths = [_t10_case(tmp_path / f"{a}.nc", a, *values[a]) for a in at]
    ds = tv.aggregate([_probability_case(tmp_path / "prob.nc", 20, 0.5), *paths])
    # the probability group: its one case only, 20 of 50 against 0.5 (inside [0.26, 0.55])
    assert ds["prob_mode"].values.tolist() == ["single"] and ds.sizes["energy_ratio"] == 1
    assert float(ds["prob_fraction"].squeeze()) == 0.4 and float(ds["prob_inside"].squeeze()) == 1
    p_prob = scipy_stats.binomtest(20, 50, 0.5).pvalue
    assert float(ds["prob_p_value"].squeeze()) == pytest.approx(p_prob, rel=1e-9)
    (prob,) = json.loads(ds.attrs["pass_rule_probability"]).values()
    assert prob["p_value"] == pytest.approx(p_prob, rel=1e-9) and prob["pass"] is True
    # cases sorted by (material, mode, diameter, breakage_at): fracture is the last
    assert ds["frag_case"].values.tolist() == [f"limestone/drop_weight/5mm/{a}" for a in at]
    assert ds["frag_material"].values.tolist() == ["limestone"] * len(at)
    assert ds["frag_diameter"].values.tolist() == [0.005] * len(at)
    np.testing.assert_array_equal(ds["sieve"], [0.05, 0.25, 0.5])
    np.testing.assert_array_equal(ds["psd_sim"].values[-1, 0], [8.0, 40.0, 90.0])
    np.testing.assert_array_equal(ds["psd_model"].values[-1, 0], [9.0, 42.0, 88.0])
    for name, unit in T10_UNITS.items():
        assert ds[name].attrs["units"] == unit, name
        assert " " in ds[name].attrs["long_name"], name
    assert float(ds["t10_specific_energy"][-1, 0]) == 100.0 and float(ds["t10_broken"][-1, 0]) == 30
    assert float(ds["t10_model_all"][-1, 0]) == 12.0 and float(ds["t10_primary"][-1, 0]) == 5.0
    p = 0.031
    assert float(ds["t10_p_value"][-1, 0]) == pytest.approx(p, rel=1e-12)
    assert ds["t10_inside"].values[:, 0].tolist() == [0.0, 1.0][-len(at):]
    rules = json.loads(ds.attrs["pass_rule_t10"])
    first = rules["limestone/drop_weight/5mm/fracture"]
    assert first["p_value"] == pytest.approx(p, rel=1e-12) and first["pass"] is True
    # Holm by hand: two tested verdicts, the smaller p-value against 0.05 / 2
    assert sorted([first["threshold"], prob["threshold"]]) == pytest.approx([0.025, 0.05])
    assert first["threshold"] == pytest.approx(0.025 if p < p_prob else 0.05, rel=1e-12)
    assert first["t10_over_expected"] == pytest.approx([12 / 14], rel=1e-12)
    assert first["t10_over_model"] == pytest.approx([12 / 11], rel=1e-12)
    assert float(ds["t10_expected"][-1, 0]) == 14.0 and float(ds["t10_model"][-1, 0]) == 11.0
    if len(at) == 2:
        dev = rules["limestone/drop_weight/5mm/first_reach"]
        assert math.isnan(dev["p_value"]) and dev["pass"] is None and dev["deviation"]
        assert dev["t10_over_model"] == pytest.approx([0.7], rel=1e-12)
        assert float(ds["t10_p_value"][0, 0]) == 0.002


# ---- util/stats.binomial_interval: every count against scipy and the closed-form ends ----------

@pytest.mark.parametrize("n", [1, 2, 5, 20])
@pytest.mark.parametrize("level", [0.95, 0.99])
def test_clopper_pearson_of_every_count_is_scipys_exact_interval(n, level):
    """All k = 0..n (vectorised) against scipy's binomtest exact interval (root finding on the
    binomial tails, not the beta quantiles); the ends in closed form: k = 0 -> [0, 1 - (a/2)^(1/n)],
    k = n -> [(a/2)^(1/n), 1], k = 1 -> lower 1 - (1 - a/2)^(1/n), k = n - 1 -> upper
    (1 - a/2)^(1/n)."""
    k = np.arange(n + 1)
    lo, hi = stats.binomial_interval(k, n, level)
    for j in k:
        ci = scipy_stats.binomtest(int(j), n).proportion_ci(confidence_level=level,
                                                            method="exact")
        assert (lo[j], hi[j]) == pytest.approx((ci.low, ci.high), rel=1e-8, abs=1e-12), j
    h = (1 - level) / 2
    assert (lo[0], hi[0]) == pytest.approx((0.0, 1 - h ** (1 / n)), rel=1e-12)
    assert (lo[n], hi[n]) == pytest.approx((h ** (1 / n), 1.0), rel=1e-12)
    assert lo[1] == pytest.approx(1 - (1 - h) ** (1 / n), rel=1e-10)
    assert hi[n - 1] == pytest.approx((1 - h) ** (1 / n), rel=1e-10)


@pytest.mark.parametrize("k, n", [(0, 7), (1, 7), (3, 7), (7, 7), (12, 40)])
def test_wilson_interval_is_the_score_interval(k, n):
    """Wilson (1927): centre (p + z^2/2n) / (1 + z^2/n), half-width z sqrt(p(1-p)/n + z^2/4n^2)
    / (1 + z^2/n); and scipy's binomtest Wilson interval."""
    z, p = Z95, k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    lo, hi = stats.binomial_interval(k, n, method="wilson")
    assert (float(lo), float(hi)) == pytest.approx((centre - half, centre + half), rel=1e-12)
    ci = scipy_stats.binomtest(k, n).proportion_ci(method="wilson")
    assert (float(lo), float(hi)) == pytest.approx((ci.low, ci.high), rel=1e-9, abs=1e-15)
    with pytest.raises(ValueError, match="wilson"):
        stats.binomial_interval(k, n, method="jeffreys")


# ---- util/stats: bootstrap, block means and slope at their smallest sizes ----------------------

@pytest.mark.parametrize("values, level, want", [
    ([], 0.95, (NAN, NAN)), ([4.0], 0.95, (NAN, NAN)),
    # two values a < b: the resampled mean is a, (a+b)/2, b with chances 1/4, 1/2, 1/4, so both
    # 2.5 % tails end on a value itself
    ([3.0, -1.0], 0.95, (-1.0, 3.0)), ([3.0, -1.0], 0.90, (-1.0, 3.0)),
    # 0, 3, 30: the mean of three draws is 0 and 30 with chance 1/27 (3.7 %) each, then 1 and 21
    # with 3/27: inside the 2.5 % tails at 95 %, beyond the 5 % tails at 90 %
    ([0.0, 3.0, 30.0], 0.95, (0.0, 30.0)), ([0.0, 3.0, 30.0], 0.90, (1.0, 21.0)),
])
@pytest.mark.parametrize("seed", [0, 7])
def test_bootstrap_interval_of_two_or_three_values_is_their_resampling_distribution(
        values, level, want, seed):
    lo, hi = stats.bootstrap_interval(values, level=level, seed=seed)
    if math.isnan(want[0]):
        assert math.isnan(lo) and math.isnan(hi)
    else:
        assert (lo, hi) == pytest.approx(want, abs=1e-12)


def test_bootstrap_interval_by_default_is_scipys_seeded_percentile_bootstrap():
    """The documented default (scipy.stats.bootstrap, percentile, 9999 resamples from
    default_rng(0), 95 %): stored t10 intervals are reproduced only with these."""
    x = np.random.default_rng(3).lognormal(size=25)
    ci = scipy_stats.bootstrap((x,), np.mean, n_resamples=9999, confidence_level=0.95,
                               method="percentile", rng=np.random.default_rng(0))
    got = stats.bootstrap_interval(x)
    assert got == pytest.approx((ci.confidence_interval.low, ci.confidence_interval.high),
                                rel=1e-14)
    assert got != pytest.approx(stats.bootstrap_interval(x, seed=1), rel=1e-6)


@pytest.mark.parametrize("blocks, confidence", [([1.0, 4.0], 0.95), ([1.0, 4.0], 0.90),
                                                ([1.0, 2.0, 6.0], 0.95), ([1.0, 2.0, 6.0], 0.90)])
def test_block_mean_interval_of_two_and_three_blocks_in_closed_form(blocks, confidence):
    """Mean and t(1/2 + c/2, n - 1) s / sqrt(n), the t quantile in closed form (1 and 2 degrees
    of freedom); s of (1, 4) is 3 / sqrt 2, of (1, 2, 6) sqrt 7."""
    n = len(blocks)
    s = {2: 3 / math.sqrt(2), 3: math.sqrt(7)}[n]
    mean, half = stats.block_mean_interval(blocks, confidence)
    assert mean == pytest.approx(sum(blocks) / n, rel=1e-15)
    assert half == pytest.approx(t_quantile(0.5 + confidence / 2, n - 1) * s / math.sqrt(n),
                                 rel=1e-12)


def test_block_mean_interval_of_no_or_one_block_has_no_width():
    assert all(math.isnan(x) for x in stats.block_mean_interval([]))
    mean, half = stats.block_mean_interval([2.5])
    assert mean == 2.5 and math.isnan(half)


@pytest.mark.parametrize("x, y, level", [([0, 1, 2], [0, 2, 1], 0.95), ([0, 1, 2], [0, 2, 1], 0.8),
                                         ([0, 1, 2, 3], [1, 3, 2, 5], 0.95),
                                         ([0, 1, 2, 3], [1, 3, 2, 5], 0.9)])
def test_slope_interval_is_least_squares_by_hand(x, y, level):
    """Slope Sxy / Sxx, standard error sqrt(SSR / (n - 2) / Sxx) (exact fractions), times the t
    quantile at n - 2 = 1 or 2 degrees of freedom in closed form."""
    n = len(x)
    fx, fy = [Fraction(v) for v in x], [Fraction(v) for v in y]
    mx, my = sum(fx) / n, sum(fy) / n
    sxx = sum((a - mx) ** 2 for a in fx)
    slope = sum((a - mx) * (b - my) for a, b in zip(fx, fy)) / sxx
    ssr = sum((b - my - slope * (a - mx)) ** 2 for a, b in zip(fx, fy))
    se = math.sqrt(ssr / (n - 2) / sxx)
    got_slope, half = stats.slope_interval(np.array(x, float), np.array(y, float), level)
    assert got_slope == pytest.approx(float(slope), rel=1e-12)
    assert half == pytest.approx(t_quantile(0.5 + level / 2, n - 2) * se, rel=1e-10)


def test_slope_interval_of_an_exact_line_has_no_width():
    slope, half = stats.slope_interval([0.0, 1.0, 2.0, 3.0], [1.0, 3.0, 5.0, 7.0])
    assert slope == pytest.approx(2.0, rel=1e-15) and half == pytest.approx(0.0, abs=1e-12)


def test_a_count_outside_its_trials_is_refused_and_an_estimate_outside_its_interval_is_unknown():
    """Found by the seed-49 review (2026-12-01): a negative count read the pmf from its end, an
    estimate outside its own interval gave p > 1, and a model exactly at the estimate gave p = 1
    or NaN depending on which end of the interval was known."""
    for k in (-1, 6):
        with pytest.raises(ValueError, match="outside 0..5"):
            tv.binomial_p_value(k, 5, 0.5)
    # estimate 1.0 above its interval [0.2, 0.8]: no error on the model's side to scale by
    assert np.isnan(tv.interval_p_value(1.0, 0.2, 0.8, 1.5))
    assert np.isnan(tv.interval_p_value(0.1, 0.2, 0.8, 0.0))
    # the model at the estimate: p = 1 whichever end is known
    for lo, hi in ((0.2, np.nan), (np.nan, 0.8), (0.2, 0.8)):
        assert tv.interval_p_value(0.5, lo, hi, 0.5) == 1.0
