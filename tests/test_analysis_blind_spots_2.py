"""Tests for the survivors of the sampled mutation run over analysis/ (issue 47, item 2), part 2:
stirred_mill, tavares_verification (its p-values and the t10 aggregate), ballmill3d, report and
results_page.

Each expected number comes from outside the code under test: a closed form (the interval where
a quadratic q stays within its minimum plus one, a parabola's vertex), scipy's own binomial test
and normal tail, a number the docs state (the 2 % energy balance), or a table row written by
hand from made-up aggregates. Pure Python on synthetic inputs: no simulation, no workflow.
"""

import json
import math

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from scipy import stats as scipy_stats
from scipy.optimize import minimize_scalar

from millsim.analysis import ballmill3d, report
from millsim.analysis import results_page as rp
from millsim.analysis import stirred_mill as sm
from millsim.analysis import tavares_verification as tv
from millsim.io import write_case, write_netcdf

from helpers import calibration_files

# ---- stirred_mill: the 95 % interval, the refined minimum, the stage tables ----------------------

STEP = 1.0 / 4000  # interval's default grid: 4001 points over [0, 1]


def test_interval_of_one_condition_is_q_within_one_of_its_minimum_ends_included():
    """P = x on [0, 1], reference 0.5, half-width 0.25: q = ((x - 0.5) / 0.25)^2 <= 1 on
    [0.25, 0.75], whose ends are grid points where q is exactly 1 (powers of two): included."""
    out = sm.interval([0.0, 1.0], [0.0, 1.0], [0.25, 0.25], 0.5)
    assert (out["best"], out["lo"], out["hi"], out["scale"]) == (0.5, 0.25, 0.75, 1.0)
    assert not out["lo_open"] and not out["hi_open"]


def test_interval_ends_are_the_grid_points_just_inside():
    """Two conditions that agree (both references 0.5, half-widths 0.1): q = 200 (x - 0.5)^2,
    minimum 0, scale 1 (no excess), interval |x - 0.5| <= sqrt(1/200) = 0.0707, which no grid
    point hits: the ends are the first and last grid points inside it."""
    x = [0.0, 1.0]
    out = sm.interval(x, [[0.0, 0.0], [1.0, 1.0]], [[0.1, 0.1], [0.1, 0.1]], [0.5, 0.5])
    half = math.sqrt(1 / 200)
    assert 0.5 - half <= out["lo"] < 0.5 - half + STEP
    assert 0.5 + half - STEP < out["hi"] <= 0.5 + half
    assert out["scale"] == 1.0 and out["best"] == pytest.approx(0.5, abs=1e-12)


def test_interval_widens_by_the_excess_of_disagreeing_conditions():
    """References 0.4 and 0.62 for the same P = x, half-widths 0.1: q = 200 (x - 0.51)^2 + 2.42,
    q_min = 2.42 over one degree of freedom: scale 1.96^2 x 2.42 (Workman et al. 2022, section
    5.2), interval |x - 0.51| <= sqrt(scale / 200) = 1.96 x 0.11."""
    out = sm.interval([0.0, 1.0], [[0.0, 0.0], [1.0, 1.0]], [[0.1, 0.1], [0.1, 0.1]], [0.4, 0.62])
    assert out["scale"] == pytest.approx(1.96**2 * 2.42, rel=1e-9)
    half = 1.96 * 0.11
    assert 0.51 - half <= out["lo"] < 0.51 - half + STEP
    assert 0.51 + half - STEP < out["hi"] <= 0.51 + half


def test_interval_reaching_the_grid_end_is_open_there():
    """Reference 1.05 beyond P = x on [0, 1], half-width 0.1: q_min = 0.25 at x = 1, the
    interval |x - 1.05| <= sqrt(1.25) x 0.1 = 0.1118 is cut at 1: open above only."""
    out = sm.interval([0.0, 1.0], [0.0, 1.0], [0.1, 0.1], 1.05)
    assert out["best"] == 1.0 and out["hi"] == 1.0 and out["hi_open"] and not out["lo_open"]
    assert 1.05 - 0.1 * math.sqrt(1.25) <= out["lo"] < 1.05 - 0.1 * math.sqrt(1.25) + STEP


def _dry(ssr_by_friction, rpm=1000.0, reference=10.0):
    """Dry cases at one speed whose squared residual against ``reference`` is the given ssr."""
    cases = pd.DataFrame([dict(friction=mu, eta=0.0, rpm=rpm, net_power=reference + math.sqrt(s),
                               net_power_ci=0.5) for mu, s in ssr_by_friction.items()])
    ref = pd.DataFrame(dict(rpm=[rpm], fluid=[sm.DRY], eta_exp=[0.0], net_power=[reference],
                            net_power_ci=[0.5], source=["measured"]))
    return cases, ref


def test_friction_refined_is_the_vertex_of_the_parabola_through_the_minimum():
    """ssr 5, 2, 1, 3, 8 at mu = 0.1 .. 0.5: the parabola through (0.2, 2), (0.3, 1), (0.4, 3)
    is 150 mu^2 - 85 mu + 13 (solved by hand), vertex 85/300; the residuals are P - reference."""
    mus = [0.1, 0.2, 0.3, 0.4, 0.5]
    cases, ref = _dry(dict(zip(mus, [5.0, 2.0, 1.0, 3.0, 8.0])))
    table, summary, choice = sm.calibrate_friction(cases, ref)
    assert choice["friction"] == 0.3 and choice["ssr_min"] == pytest.approx(1.0, rel=1e-12)
    assert choice["friction_refined"] == pytest.approx(85 / 300, rel=1e-9)
    np.testing.assert_allclose(table["residual"] ** 2, [5.0, 2.0, 1.0, 3.0, 8.0], rtol=1e-12)
    # two frictions are enough for an interval
    _, _, two = sm.calibrate_friction(*_dry({0.2: 1.0, 0.3: 4.0}))
    assert "friction_interval" in two


def _wet(powers, etas=(0.01, 0.1, 1.0), reference=20.0):
    cases = pd.DataFrame([dict(friction=0.3, eta=e, rpm=2000.0, net_power=p, net_power_ci=0.5)
                          for e, p in zip(etas, powers)])
    ref = pd.DataFrame(dict(rpm=[2000.0, 2000.0], fluid=[sm.DRY, "A"], eta_exp=[0.0, 0.05],
                            net_power=[5.0, reference], net_power_ci=[0.5, 0.5],
                            source=["measured", "measured"]))
    return cases, ref


def test_viscosity_on_a_grid_point_that_hits_the_reference_is_bracketed():
    """Power 10, 20, 30 W at eta 0.01, 0.1, 1 against 20 W: eta = 0.1 hits it exactly, a
    crossing (not an extrapolation), refined to 0.1 itself. Two wet cases are enough; cases not
    pooled count one replicate each."""
    table, choice = sm.calibrate_viscosity(*_wet([10.0, 20.0, 30.0]), 0.3, 2000.0)
    a = choice["A"]
    assert a["eta_sim"] == 0.1 and a["eta_sim_refined"] == pytest.approx(0.1, rel=1e-12)
    assert not a["refined_extrapolated"]
    assert table["replicates"].tolist() == [1, 1, 1]
    _, two = sm.calibrate_viscosity(*_wet([10.0, 30.0], etas=(0.01, 1.0)), 0.3, 2000.0)
    # 20 W halfway in log eta between 0.01 and 1
    assert two["A"]["eta_sim_refined"] == pytest.approx(0.1, rel=1e-12)


def test_synthetic_reference_names_its_generating_friction():
    ref = pd.DataFrame(dict(source=["synthetic twin of the LS1 curve, friction 0.3, seed 1",
                                    "Synthetic twin (friction 0.3)"]))
    assert sm.synthetic_reference(ref) == (True, 0.3)
    assert sm.synthetic_reference(pd.DataFrame(dict(source=["measured, Fig. 7"]))) == (False, None)


def test_one_simulated_viscosity_brackets_nothing():
    """A fluid with a single simulated eta: the interval is that eta, open at both ends."""
    rows = pd.DataFrame(dict(eta_sim=[0.1], net_power=[20.0], net_power_ci=[0.3],
                             reference_ci=[0.4], reference=[25.0]))
    out = sm.viscosity_interval(rows)
    assert out["lo"] == pytest.approx(0.1) and out["hi"] == pytest.approx(0.1)
    assert out["lo_open"] and out["hi_open"]



def test_pooled_table_keeps_the_half_width_beside_its_power():
    """Two replicates, 9 W +- 0.1 and 11 W +- 0.2: weights 1 / ci^2 give the mean
    (9 / 0.01 + 11 / 0.04) / (1 / 0.01 + 1 / 0.04) = 9.4 W; the columns read as the cases'
    (point, power, its half-width) before the pooling's own."""
    cases = pd.DataFrame([dict(friction=0.3, eta=0.0, rpm=2000.0, seed=s, net_power=p,
                               net_power_ci=c, energy_balance_error=0.001, case=f"c{s}.nc")
                          for s, p, c in ((1, 9.0, 0.1), (2, 11.0, 0.2))])
    pooled = sm.pool_replicates(cases)
    assert list(pooled.columns[:6]) == ["friction", "eta", "rpm", "net_power", "net_power_ci",
                                        "energy_balance_error"]
    assert pooled["net_power"].iloc[0] == pytest.approx(9.4, rel=1e-12)
    assert pooled["replicates"].iloc[0] == 2 and pooled["seeds"].iloc[0] == "1;2"

# ---- tavares_verification: the exact binomial test at its edges, Bonferroni, the pass rule -------

@pytest.mark.parametrize("k, n, p", [(0, 1, 0.3), (1, 1, 0.3), (0, 2, 0.09),
                                     (0, 1, (1 + 1.2e-7) / (2 + 1.2e-7))])
def test_binomial_p_value_at_its_edges_is_scipys(k, n, p):
    """One trial; the most likely count, whose tail sums to 1 + 2e-16 in floating point (a
    p-value is at most 1); a count only 1.2e-7 (relative) less likely than the other, which
    scipy's slack of 1e-7 does not count as as likely."""
    got = float(tv.binomial_p_value(k, n, p))
    assert got == pytest.approx(scipy_stats.binomtest(k, n, p).pvalue, rel=1e-12)
    assert got <= 1.0
    assert math.isnan(float(tv.binomial_p_value(math.nan, 10, 0.5)))


def test_bonferroni_is_at_most_one_and_the_pass_rule_includes_its_threshold():
    assert tv.bonferroni([0.6, 0.7, math.nan]) == 1.0
    frac, passed = tv.pass_rule([1.0] * 9 + [0.0, math.nan])  # 9 of 10 finite: 90 %
    assert frac == pytest.approx(0.9) and passed
    frac, passed = tv.pass_rule([1.0] * 8 + [0.0, 0.0])
    assert frac == pytest.approx(0.8) and not passed
    assert math.isnan(tv.pass_rule([math.nan])[0]) and not tv.pass_rule([])[1]


# ---- ballmill3d: Morrell's maximum; report: the energy-balance verdicts at the documented 2 % ----

D3, L3 = 0.3, 0.15  # drum diameter and length [m]


def _mill3d(residual=0.001):
    """A 3D ball-mill aggregate (4 speeds x 3 fillings) whose n/n_c is Morrell's phi (the
    critical speed sqrt(2 g / D)), bulk density 4500 kg m-3, and a made-up simulated power."""
    speeds, fillings = np.array([0.7, 0.8, 0.9, 1.0]), np.array([0.2, 0.3, 0.4])
    grid = np.ones((speeds.size, fillings.size))
    mass = 4500.0 * fillings * math.pi * D3**2 / 4 * L3
    dims = ("n_over_nc", "filling")
    err = np.full(grid.shape, 0.001)
    err[2, 1] = residual  # the worst case
    return xr.Dataset(
        {"power": (dims, 10 - (speeds[:, None] - 0.85) ** 2 + fillings, {"units": "W"}),
         "omega": (dims, speeds[:, None] * math.sqrt(2 * 9.81 / D3) * grid, {"units": "rad s-1"}),
         "charge_mass": (dims, mass * grid, {"units": "kg"}),
         "energy_balance_error": (dims, err, {"units": "1"})},
        coords={"n_over_nc": ("n_over_nc", speeds, {"units": "1"}),
                "filling": ("filling", fillings, {"units": "1"})},
        attrs={"param_drum_diameter": D3, "param_drum_length": L3, "title": "ballmill3d"})


def test_morrell_power_maximum_is_found_on_a_0_001_grid_of_speed():
    """The model's maximum over n/n_c: Morrell's power (checked against the formula in
    tests/test_ballmill3d_study.py) evaluated here at n/n_c = 0.300, 0.301, ..., 1.200, and
    within half that step of the maximiser found by scipy."""
    out = ballmill3d.summary(_mill3d())
    grid = np.arange(300, 1201) / 1000
    for j in (0.2, 0.3, 0.4):
        power = ballmill3d.morrell_net_power(grid, j, D3, L3, 4500.0)
        got = float(out["power_reference_peak_speed"].sel(filling=j))
        assert got == pytest.approx(grid[np.argmax(power)], abs=1e-9)
        best = minimize_scalar(lambda n, j=j: -ballmill3d.morrell_net_power(n, j, D3, L3, 4500.0),
                               bounds=(0.6, 1.1), method="bounded", options={"xatol": 1e-10}).x
        assert abs(got - best) <= 0.0005


@pytest.mark.parametrize("residual, passed", [(0.02, True), (-0.025, False)])
def test_energy_balance_verdicts_use_the_documented_2_percent(tmp_path, residual, passed):
    """docs/pipeline.md: the energy balance of every case within 2 % (3D ball mill, and the
    stirred mill's power study); the bound itself passes."""
    path = tmp_path / "bm3.nc"
    write_netcdf(path, ballmill3d.summary(_mill3d(residual)))
    verdict = next(v for v in report.ballmill3d(path)["verdicts"]
                   if v["check"].startswith("energy balance"))
    assert verdict["passed"] is passed
    shares = np.array([0.4, 0.1, 0.3, 0.2])
    stirred = xr.Dataset(
        {"net_power": (("eta", "rpm"), [[1.0]], {"units": "W"}),
         "net_power_ci": (("eta", "rpm"), [[0.1]], {"units": "W"}),
         "energy_balance_error": (("eta", "rpm"), [[residual]], {"units": "1"}),
         "typology_fraction": (("eta", "rpm", "typology"), shares[None, None, :], {"units": "1"})},
        coords={"eta": ("eta", [0.0], {"units": "Pa s"}),
                "rpm": ("rpm", [2000.0], {"units": "min-1"}),
                "typology": ("typology", ["impact", "torsion", "shearing", "rolling"],
                             {"units": "1"})}, attrs={"title": "stirred-mill aggregate"})
    write_netcdf(tmp_path / "s.nc", stirred)
    (verdict,) = report.stirred(tmp_path / "s.nc")["verdicts"]
    assert verdict["passed"] is passed


@pytest.mark.parametrize("x, text", [(999000.0, "999000"), (1e6, "1e+06"), (1.23e6, "1.23e+06"),
                                     (-1.5e6, "-1.5e+06")])
def test_report_numbers_of_a_million_and_more_are_in_exponent_form(x, text):
    """The page writes 3 significant digits positionally below a million (3500, not 3.5e+03)
    and in exponent form from a million on."""
    assert report._f(x) == text


# ---- report: the calibration page, the twin's p-value, the repeated-impact headline ------------

def _calibration_files(tmp_path, source, friction_interval, eta_interval):
    """Friction 0.3, one fluid A (eta_exp 0.05, eta_sim 0.04), a two-point prediction with
    relative residuals 2 % and -5 % (tests/helpers.py)."""
    return calibration_files(tmp_path, source, friction_interval, eta_interval)


def _iv(lo, hi, lo_open=False, hi_open=False, scale=1.0):
    return dict(best=0.5 * (lo + hi), lo=lo, hi=hi, lo_open=lo_open, hi_open=hi_open, scale=scale)


def test_calibration_page_of_a_measured_reference(tmp_path):
    """A measured reference is named by its file; an interval widened by the scale factor 1.44
    says so with the factor sqrt(1.44) = 1.2."""
    files = _calibration_files(tmp_path, "measured (Fig. 7)", _iv(0.28, 0.33, scale=1.44), None)
    out = report.calibration(*files)
    head = dict(out["headline"])
    assert head["reference"] == f"as given in {files[3]}"
    assert "widened by a factor 1.2" in head["friction \u03bc interval"]
    assert "largest |simulated - reference| / reference 5 % over 2 points" in \
        head["prediction (stage 3)"]
    assert out["verdicts"] == [] and not out["numbers"]["synthetic"]


def test_twin_p_values_open_ends_missing_values_and_the_normal_side():
    """A synthetic twin (friction 0.3 generating): the friction's interval [0.2, 0.28] is open
    above, so 0.3 beyond it is not rejected (p = 1); A's generating eta 0.058 below its closed
    interval [0.06, 0.07] around 0.065: the lower half-width 0.005 is 1.96 standard errors,
    z = 0.007 / se, two-sided normal; a value without an interval gives no p-value."""
    p = report._twin_p_value(0.24, _iv(0.2, 0.28, hi_open=True), 0.3)
    assert p == 1.0
    se = 0.005 / scipy_stats.norm.ppf(0.975)
    p = report._twin_p_value(0.065, _iv(0.06, 0.07), 0.058)
    assert p == pytest.approx(2 * scipy_stats.norm.sf(0.007 / se), rel=1e-9)
    assert report._twin_p_value(0.065, None, 0.05) is None
    assert report._twin_p_value(0.065, _iv(0.06, 0.07), None) is None


def test_calibration_of_a_synthetic_twin_tests_what_it_can(tmp_path):
    """The twin's friction beyond the open end: p = 1; eta without an interval: no p-value."""
    files = _calibration_files(tmp_path, "synthetic twin (friction 0.3)",
                               _iv(0.2, 0.28, hi_open=True), None)
    out = report.calibration(*files)
    p_values = {v["check"]: v["p_value"] for v in out["verdicts"]}
    assert p_values == {"calibration recovers the twin's friction \u03bc": 1.0,
                        "calibration recovers the twin's \u03b7_sim of A [Pa s]": None}


def test_tavares_headline_is_the_fraction_after_the_last_impact(tmp_path):
    """Cumulative fractions broken after impacts 1..3 at one gamma: the headline quotes the
    third, with its interval and the model's value there."""
    dims = ("gamma", "impact")
    ds = xr.Dataset({"rep_fraction": (dims, [[0.1, 0.3, 0.6]]),
                     "rep_ci_lo": (dims, [[0.05, 0.2, 0.5]]),
                     "rep_ci_hi": (dims, [[0.2, 0.4, 0.7]]),
                     "rep_analytic": (dims, [[0.12, 0.33, 0.55]])},
                    coords={"gamma": [5.0], "impact": [1, 2, 3]}, attrs={"title": "tavares"})
    for name in ds.variables:
        ds[name].attrs["units"] = "1"
    write_netcdf(tmp_path / "t.nc", ds)
    (headline,) = report.tavares(tmp_path / "t.nc")["headline"]
    assert headline == ("fraction broken after 3 impacts, \u03b3 = 5", "0.6 [0.5, 0.7] vs model 0.55")


# ---- results_page: the tables as written, by hand ------------------------------------------------

def _aggregate_attrs(**more):
    return dict(engine_hash="0123456789ab", millsim_version="1.0", created_utc="2026-11-29",
                source_cases=json.dumps(["a.nc"]), cases_wall_time_s=3600.0, **more)


def test_stirred_page_table_and_figures_by_hand(tmp_path):
    """Powers 1.23456 and 2 W +- 0.0123456 and 0.1 W print with 4 significant digits in a
    markdown table whose every line opens and closes with a bar; of the figures only the study's
    own, and not a template, are named; the page ends with a newline."""
    ds = xr.Dataset(
        {"net_power": (("eta", "rpm"), [[1.23456, 2.0]], {"units": "W"}),
         "net_power_ci": (("eta", "rpm"), [[0.0123456, 0.1]], {"units": "W"})},
        coords={"eta": ("eta", [0.1], {"units": "Pa s"}),
                "rpm": ("rpm", [2000.0, 3000.0], {"units": "min-1"})},
        attrs=_aggregate_attrs(stacked_over=json.dumps(["eta", "rpm"])))
    catalogue = {"stirred_power": ("aggregate:stirred_mill", "power"),
                 "ballmill_rate": ("aggregate:ballmill", "rate"),
                 "stirred_{rpm}": ("aggregate:stirred_mill", "one per speed")}
    text = rp.page("stirred_mill", ds, "agg.nc", figures=tmp_path / "plots",
                   out=tmp_path / "pages" / "page.md", catalogue=catalogue)
    lines = text.splitlines()
    at = lines.index("| eta [Pa s] \\ rpm | 2000 | 3000 |")
    assert lines[at + 1:at + 3] == ["|---|---|---|", "| 0.1 | 1.235 +- 0.01235 | 2 +- 0.1 |"]
    # the folder as the page's links name it: relative to the page
    assert lines[-1] == "Not drawn (absent from ../plots): stirred_power."
    assert text.endswith(".\n")


def test_bed_page_lists_a_condition_of_one_seed_and_skips_one_not_run():
    dims = ("material", "rings", "layers", "impact_energy")
    shape = (1, 1, 1, 2)

    def var(values, units):
        return (dims, np.array(values, float).reshape(shape), {"units": units})

    ds = xr.Dataset({"broken_mass_mean": var([0.05, np.nan], "kg"),
                     "broken_mass_std": var([np.nan, np.nan], "kg"),
                     "capture_radius_mean": var([0.002, np.nan], "m"),
                     "capture_radius_std": var([np.nan, np.nan], "m"),
                     "replicates": (dims, np.array([1, 0]).reshape(shape), {"units": "1"})},
                    coords={"material": ["limestone"], "rings": [2], "layers": [3],
                            "impact_energy": ("impact_energy", [1.0, 2.0], {"units": "J"})},
                    attrs=_aggregate_attrs())
    lines = rp.page("bed_impact", ds, "bed.nc").splitlines()
    rows = [line for line in lines if line.startswith("| limestone")]
    assert rows == ["| limestone | 2 | 3 | 1 | 0.05 | 0.002 | 1 |"]


def test_single_particle_page_gives_the_deviation_ratios_to_3_digits():
    rule = {"copper/drop_weight/10mm/first_reach": dict(
        points=2, inside=0.5, p_value=0.2, threshold=0.01, **{"pass": None},
        deviation="breaks at the fracture energy", t10_over_model=[0.81234, 0.9])}
    ds = xr.Dataset(attrs=_aggregate_attrs(pass_rule_t10=json.dumps(rule)))
    lines = rp.page("single_particle", ds, "sp.nc").splitlines()
    assert ("- copper/drop_weight/10mm/first_reach: breaks at the fracture energy; t10 / eq 7 per "
            "energy: 0.812, 0.9") in lines


def _t10_case(path, material, ratio, t10, lo, hi, model):
    """A single_particle case file with replacement (a t10 case) and made-up outputs."""
    sieve = np.array([0.1, 0.5])
    data = {"energy_ratio": ((), ratio, "1"), "product_t10": ((), t10, "%"),
            "product_t10_ci_lo": ((), lo, "%"), "product_t10_ci_hi": ((), hi, "%"),
            "product_t10_expected": ((), model, "%"), "product_t10_spread": ((), 3.0, "%"),
            "product_t10_p_value": ((), 0.4, "1"),
            "product_t10_model": ((), model, "%"),
            "product_t10_model_all": ((), model, "%"),
            "t10_primary_model": ((), 5.0, "%"), "specific_energy": ((), 100.0 * ratio, "J kg-1"),
            "absorbed_share": ((), 0.8, "1"), "n_broken": ((), 40.0, "1"),
            "product_passing": (("sieve",), [10.0, 60.0], "%"),
            "product_passing_model": (("sieve",), [12.0, 58.0], "%")}
    ds = xr.Dataset({k: xr.Variable(dims, np.asarray(v, float), {"units": u})
                     for k, (dims, v, u) in data.items()},
                    coords={"sieve": ("sieve", sieve, {"units": "1"})})
    params = dict(mode="single", material=material, diameter=0.01, breakage_at="fracture",
                  replacement=True, materials_file="materials.yaml", seed=1)
    write_case(path, ds, {"scene": "single_particle", "parameters": params, "seed": 1,
                          "dt": 1e-6, "steps": 10, "wall_time_s": 1.0})
    return path


@pytest.mark.parametrize("ratios", [(2.0,), (1.0, 2.0)])
def test_t10_aggregate_of_fragmentation_cases_by_hand(tmp_path, ratios):
    """t10 cases of two materials at the energy ratios given (limestone's recomputed ratio off in
    the tenth digit: the same column). eq 7 lies on the interval's lower end for copper and on
    its upper end for limestone: both inside ([lo, hi] is closed; eq 7 = mean of eq 8 here).
    t10 / eq 7 = 12 / 10 and
    9 / 10 at every ratio; each set names its material and the variables' long names are words."""
    paths = []
    for i, r in enumerate(ratios):
        paths.append(_t10_case(tmp_path / f"cu{i}.nc", "copper_ore", r, 12.0, 10.0, 14.0, 10.0))
        paths.append(_t10_case(tmp_path / f"ls{i}.nc", "limestone", r + 3e-10, 9.0, 7.0, 10.0,
                               10.0))
    ds = tv.aggregate(paths)
    assert ds.sizes["frag_ratio"] == len(ratios)
    assert ds["frag_material"].values.tolist() == ["copper_ore", "limestone"]
    assert ds["t10_inside"].values.tolist() == [[1.0] * len(ratios)] * 2
    rules = json.loads(ds.attrs["pass_rule_t10"])
    ratio = {name.split("/")[0]: r["t10_over_model"] for name, r in rules.items()}
    assert ratio == {"copper_ore": pytest.approx([1.2] * len(ratios)),
                     "limestone": pytest.approx([0.9] * len(ratios))}
    np.testing.assert_array_equal(ds["sieve"], [0.1, 0.5])
    for name in ("t10", "t10_lo", "t10_expected", "t10_model", "t10_broken",
                 "t10_specific_energy"):
        assert " " in ds[name].attrs["long_name"], name
