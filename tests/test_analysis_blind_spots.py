"""Tests for the survivors of the sampled mutation run over analysis/ (issue 47, item 2):
accuracy, accuracy_output, aggregate, ballmill, bed_impact, evidence and util.stats (the other
modules: test_analysis_blind_spots_2.py).

Each expected number comes from outside the code under test: a closed form (an exact power law,
the standard error of a linear combination of independent means), a hand computation on a few
synthetic rows, or a fact of the definitions (SI units, the limit dt -> 0). Pure Python on
synthetic inputs: no simulation, no workflow.
"""

import json
import math

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from scipy import stats as scipy_stats

from millsim.analysis import accuracy as acc
from millsim.analysis import aggregate, ballmill, bed_impact, evidence
from millsim.util import stats

# ---- accuracy: the observed order's bracket and bisection --------------------------------------


@pytest.mark.parametrize("p", [0.5, 3.7, 20.0])
def test_observed_order_of_exact_power_laws_up_to_the_bracket_end(p):
    """y = C h^p on an uneven ladder: the order comes back whatever p in the bracket, including
    its upper end p = 20, where f(20) is exactly 0 (y0 = 0 makes the data's ratio of differences
    the same floating-point number as the model's)."""
    h = np.array([1.0, 2.0, 3.0])
    assert acc.observed_order(h, 0.5 * h**p) == pytest.approx(p, abs=1e-9)
    assert acc.observed_order(h[::-1], (-2.0 * h**p)[::-1]) == pytest.approx(p, abs=1e-9)


def test_observed_order_at_the_lower_bracket_end():
    """p = 0.05 exactly, the bracket's lower end, where f(lo) is exactly 0: the bisection used to
    walk to the upper end and return 20."""
    h = np.array([1.0, 2.0, 3.0])
    assert acc.observed_order(h, h**0.05) == pytest.approx(0.05, abs=1e-9)


def test_a_repeated_step_has_no_observed_order():
    """Two rungs at one step: no order (NaN), not a math domain error from log(0)."""
    assert math.isnan(acc.observed_order([1.0, 2.0, 2.0], [1.0, 1.5, 1.7]))
    assert math.isnan(acc.observed_order([1.0, 1.0, 2.0], [1.0, 1.5, 1.7]))


# ---- accuracy: the reference and its standard error --------------------------------------------

def test_exact_reference_is_zero_at_zero_step():
    """A residual's exact value is 0, the limit dt -> 0: no standard error, no second step."""
    ref = acc.reference_value([0.1, 0.2, 0.4], [0.03, 0.05, 0.09], method="exact")
    assert (ref["value"], ref["se"], ref["step"]) == (0.0, 0.0, 0.0)
    assert math.isnan(ref["step2"]) and math.isnan(ref["order"])


@pytest.mark.parametrize("h", [(0.5, 1.0), (0.5, 1.0, 2.0)])
def test_richardson_reference_standard_error_of_the_linear_combination(h):
    """The extrapolated value y1 + g (y1 - y2) = (1 + g) y1 - g y2, g = 1 / ((h2/h1)^p - 1), of
    independent means has se = sqrt(((1 + g) se1)^2 + (g se2)^2). Exact y = 1 + 0.3 h^2: p = 2,
    h2/h1 = 2, g = 1/3. Without diff_se the smoothness test uses the two se's combined, which
    here resolve every difference."""
    h = np.asarray(h)
    se = np.array([0.001, 0.002, 0.003])[:h.size]
    ref = acc.reference_value(h, 1.0 + 0.3 * h**2, se=se,
                              method="richardson" if h.size == 2 else "auto")
    assert ref["method"] == "richardson"
    assert ref["value"] == pytest.approx(1.0, abs=1e-12)
    assert ref["order"] == pytest.approx(2.0, abs=1e-9)
    g = 1.0 / 3.0
    assert ref["se"] == pytest.approx(math.hypot((1 + g) * 0.001, g * 0.002), rel=1e-9)
    assert (ref["step"], ref["step2"]) == (0.5, 1.0)


def test_unpaired_error_is_the_mean_minus_the_borrowed_reference():
    """A series compared with another's reference and no seed in common: the error is the plain
    difference of the means, its se the two standard errors combined."""
    values = pd.DataFrame(dict(step=[0.2, 0.2, 0.4, 0.4], seed=[1, 2, 1, 2],
                               value=[2.1, 2.3, 2.5, 2.7]))
    lender = pd.DataFrame(dict(step=[0.1, 0.1], seed=[7, 8], value=[1.9, 2.1]))
    reference = dict(value=2.0, se=0.1, method="finest", order=math.nan, step=0.1,
                     step2=math.nan)
    table, ref = acc.error_table(values, tolerance=0.01, reference=reference,
                                 reference_values=lender)
    assert table["error"].to_numpy() == pytest.approx([0.2, 0.6], abs=1e-12)
    # sd over the two seeds sqrt(0.02) = 0.1414, se = 0.1 per step; with the reference's 0.1
    assert table["error_se"].to_numpy() == pytest.approx([math.hypot(0.1, 0.1)] * 2, rel=1e-9)
    assert ref["noise"] == pytest.approx(math.sqrt(0.02), rel=1e-9)


def _cases(series, values_by_step, seeds):
    """Long case table of ballmill2d drive power: one row per (step, seed), value given."""
    rows = []
    for dt, values in values_by_step.items():
        for seed, value in zip(seeds, values):
            rows.append(dict(name="mill", scene="ballmill2d", series=series,
                             ladder="steps_per_contact", ladder_value=1e-3 / dt, seed=seed,
                             dt=dt, dt_limit=1.0, steps=int(round(1.0 / dt)), wall_time_s=1.0,
                             engine_hash="x", millsim_version="0", parameters_json="{}",
                             path=f"{series}/{dt}/{seed}", observable="drive_power", units="W",
                             value=value))
    return pd.DataFrame(rows)


@pytest.mark.parametrize("borrower_steps", [{1e-4: [10.4, 10.6], 2e-4: [11.0, 11.2]},
                                            {2e-4: [11.0]}])
def test_a_borrowing_series_listed_first_still_borrows(borrower_steps):
    """The series that borrows its reference comes first in the table, as a ladder or as one
    single case: the lender's reference (its finest-step mean, 10.0 W) is the one used, and the
    borrower's error is its value minus the lender's value of the same seed (9.9 W for seed 1,
    10.1 W for seed 2)."""
    borrower = _cases("verlet", borrower_steps, [1, 2])
    lender = _cases("gear", {1e-4: [9.9, 10.1], 2e-4: [10.2, 10.4]}, [1, 2])
    points, _ = acc.analyse(pd.concat([borrower, lender], ignore_index=True),
                            links={("mill", "verlet"): "gear"}, methods={"mill": "finest"})
    verlet = points[points["series"] == "verlet"].sort_values("step")
    assert set(verlet["reference_series"]) == {"gear"}
    assert set(verlet["scene"]) == {"ballmill2d"}
    assert verlet["reference"].to_numpy() == pytest.approx(10.0, abs=1e-12)
    expected = {1e-4: 0.5, 2e-4: 1.1}
    assert verlet["error"].to_numpy() == pytest.approx([expected[s] for s in borrower_steps],
                                                       abs=1e-12)


# ---- accuracy_output: the netCDF's units and its tables read back ------------------------------

def _study_tables():
    cases = _cases("gear", {1e-4: [9.9, 10.1], 2e-4: [10.2, 10.4]}, [1, 2])
    points, choices = acc.analyse(cases, methods={"mill": "finest"})
    return cases, points, choices


def test_point_variables_carry_their_units():
    """Steps and wall times are in seconds (SI), relative errors are dimensionless; a column in
    the observable's units (mean, error) names no unit of its own but must not be left blank."""
    cases, points, choices = _study_tables()
    ds = acc.to_dataset(cases, points, choices, {})
    assert ds["point_step"].attrs["units"] == "s"
    assert ds["point_wall_time"].attrs["units"] == "s"
    assert ds["point_relative_error"].attrs["units"] == "1"
    for col in ("mean", "error", "reference"):
        assert ds[f"point_{col}"].attrs["units"].strip(), col


def test_points_frame_reads_back_only_its_own_table():
    """Each table comes back with exactly its columns, even when the file holds another
    variable whose name merely begins with the table's name."""
    cases, points, choices = _study_tables()
    ds = acc.to_dataset(cases, points, choices, {})
    ds["pointer"] = 1.0
    ds["choices_note"] = 2.0
    again = acc.points_frame(ds, "point")
    assert list(again.columns) == list(points.columns)
    assert list(acc.points_frame(ds, "choice").columns) == list(choices.columns)
    assert np.array_equal(again["error"].to_numpy(float), points["error"].to_numpy(float))


def test_summary_rows_by_hand():
    """The markdown summary of one point and two choices, every cell rounded by hand: dt, noise
    and wall time to 3 significant digits, the ladder value to 4, percentages to 2, a number
    that is not there (NaN) as a dash."""
    point = dict(name="mill", series="verlet", observable="drive_power", units="W",
                 reference=10.0, reference_method="richardson", reference_order=2.0,
                 reference_series="gear", noise=0.123456, ladder="steps_per_contact",
                 ladder_value=16.0, step=1.23456e-4, dt_limit=1e-3, mean=10.0123456,
                 relative_error=0.00123456, relative_error_se=0.0005, within=True,
                 wall_time=1.23456)
    choice = dict(name="mill", series="verlet", observable="drive_power", kind="observable",
                  ladder_value=16.0, step=1.23456e-4, wall_time=1.23456,
                  relative_error=0.00123456)
    nothing = dict(choice, kind="default", ladder_value=math.nan, step=math.nan,
                   wall_time=math.nan, relative_error=math.nan)
    text = acc.summary_markdown(pd.DataFrame([point]), pd.DataFrame([choice, nothing]))
    assert text.endswith("|\n")  # a text file: its last line ends with a newline
    lines = text.splitlines()
    assert "### mill / verlet: drive_power [W]" in lines
    assert ("reference 10 (richardson, order 2.00, of series gear); noise (sd over seeds at the "
            "reference step) 0.123 = 1.2 %") in lines
    assert "| 16 | 0.000123 | 0.12 | 10.01 | 0.12 | 0.05 | yes | 1.23 |" in lines
    assert "| mill | verlet | drive_power | observable | 16 | 0.000123 | 1.23 | 0.12 |" in lines
    # no step found: a dash, not "nan"
    assert lines[-1] == "| mill | verlet | drive_power | default | - | - | - | - |"


# ---- aggregate: stacking cases, and refusing cases that do not stack ---------------------------

def _case(source, code=("h1", "0.1"), **params):
    """An in-memory case: one scalar, a time series (per-case, dropped) and its parameters."""
    ds = xr.Dataset({"power": ((), 2.0 * params.get("speed", 1.0)),
                     "trace": (("time",), np.arange(3.0))},
                    attrs=dict(parameters_json=json.dumps(params), engine_hash=code[0],
                               millsim_version=code[1], wall_time_s=1.5))
    ds.encoding["source"] = source
    return ds


@pytest.mark.parametrize("odd", [0, 1, 2])
def test_stack_refuses_an_unstacked_parameter_that_differs_in_any_case(odd):
    """Three cases over speed; the seed of one of them (the first, the second or the last)
    differs: refused, naming the seed and that case's file."""
    cases = [_case(f"c{i}.nc", speed=float(i + 1), seed=9 if i == odd else 1) for i in range(3)]
    with pytest.raises(ValueError, match=rf"seed: .*c{odd}\.nc"):
        aggregate.stack_cases(cases, ["speed"])


@pytest.mark.parametrize("odd", [0, 1, 2])
def test_same_code_refuses_a_case_of_other_code_whatever_its_place(odd):
    cases = [_case(f"c{i}.nc", code=("h2" if i == odd else "h1", "0.1"), speed=float(i))
             for i in range(3)]
    with pytest.raises(ValueError, match=rf"engine_hash: .*c{odd}\.nc"):
        aggregate.same_code(cases, [f"c{i}.nc" for i in range(3)])


def test_one_case_has_its_own_code_and_sweeps_nothing():
    one = [_case("only.nc", speed=1.0, seed=1)]
    assert aggregate.same_code(one, ["only.nc"]) == {"engine_hash": "h1", "millsim_version": "0.1"}
    assert aggregate.swept_parameters(one) == []


def test_stack_over_a_parameter_keeps_scalars_and_coordinate_units():
    """Cases given out of order come back sorted by speed, the scalar along it (2 speed here),
    the per-case time series dropped, and the coordinate with the units asked for (default 1)."""
    cases = [_case(f"c{s}.nc", speed=s, seed=1) for s in (3.0, 1.0, 2.0)]
    assert aggregate.swept_parameters(cases) == ["speed"]
    ds = aggregate.stack_cases(cases, ["speed"], {"speed": {"units": "rad s-1"}})
    assert ds["speed"].values.tolist() == [1.0, 2.0, 3.0]
    assert ds["power"].values.tolist() == [2.0, 4.0, 6.0]
    assert "trace" not in ds and ds["speed"].attrs["units"] == "rad s-1"
    assert aggregate.stack_cases(cases, ["speed"])["speed"].attrs["units"] == "1"


# ---- ballmill and bed_impact summaries ---------------------------------------------------------

def test_ballmill_case_summary_mass_fractions_by_hand():
    """Two snapshots of three size classes, 1+1+2 kg and 3+1+0 kg: fractions (1/4, 1/4, 1/2)
    and (3/4, 1/4, 0), mean (1/2, 1/4, 1/4), population sd (1/4, 0, 1/4) (xarray's std, ddof 0)."""
    mass = xr.DataArray([[1.0, 1.0, 2.0], [3.0, 1.0, 0.0]], dims=("snapshot", "size_class"),
                        attrs={"units": "kg"})
    out = ballmill.case_summary(xr.Dataset({"size_distribution": mass}))
    np.testing.assert_allclose(out["mass_fraction"], [0.5, 0.25, 0.25], rtol=1e-15)
    np.testing.assert_allclose(out["mass_fraction_std"], [0.25, 0.0, 0.25], rtol=1e-15)
    np.testing.assert_allclose(out["size_distribution_mean"], [2.0, 1.0, 1.0], rtol=1e-15)
    assert out["size_distribution_mean"].attrs["units"] == "kg"


def test_ballmill_chain_length_absent_from_a_case_counts_zero():
    """Stacking leaves NaN where a chain length never occurred in a case: it occurred 0 times."""
    counts = xr.DataArray([[3.0, np.nan], [1.0, 2.0]], dims=("n_over_nc", "chain_length"))
    out = ballmill.summary(xr.Dataset({"chain_count": counts}))
    np.testing.assert_array_equal(out["chain_count"], [[3.0, 0.0], [1.0, 2.0]])


def test_bed_impact_replicates_count_the_seeds_of_each_condition():
    """A sparse grid: energy 1 J has three seeds, 2 J one (two NaN). Only the broken fraction
    given: replicates 3 and 1; mean (0.2+0.4+0.6)/3 = 0.4 and 0.8; sd 0.2, and none from one."""
    frac = xr.DataArray([[0.2, 0.4, 0.6], [0.8, np.nan, np.nan]],
                        dims=("impact_energy", "seed"),
                        coords={"impact_energy": [1.0, 2.0], "seed": [1, 2, 3]})
    out = bed_impact.summary(xr.Dataset({"broken_fraction": frac}))
    assert out["replicates"].values.tolist() == [3, 1]
    np.testing.assert_allclose(out["broken_fraction_mean"], [0.4, 0.8], rtol=1e-12)
    assert out["broken_fraction_std"].values[0] == pytest.approx(0.2, rel=1e-12)
    assert np.isnan(out["broken_fraction_std"].values[1])


# ---- util.stats: MSER-5 truncates at most half; Wilson's interval ------------------------------

def _mser_statistic(b, d):
    """White (1997): sum of squared deviations of the kept batch means over (kept count)^2."""
    kept = np.asarray(b[d:], float)
    return ((kept - kept.mean()) ** 2).sum() / kept.size**2


def test_mser5_truncates_up_to_half_and_no_further():
    """Batch means 10, 9, 8, 7, 5, 1, 1, 1: dropping five batches would leave no scatter at all,
    but at most half (4 of 8) may go, and among d = 0..4 the statistic (computed here) is least
    at d = 4: index 20. Constant batches keep everything."""
    b = [10.0, 9.0, 8.0, 7.0, 5.0, 1.0, 1.0, 1.0]
    stat = [_mser_statistic(b, d) for d in range(6)]
    assert stat[5] == 0.0 and int(np.argmin(stat[:5])) == 4
    series = np.repeat(b, 5)
    assert stats.mser5(series) == 20
    assert stats.mser5(np.ones(40)) == 0
    # four batches are enough to truncate (9, 1, 1, 1: d = 1 leaves no scatter), three are not
    assert stats.mser5(np.repeat([9.0, 1.0, 1.0, 1.0], 5)) == 5
    assert stats.mser5(np.repeat([9.0, 1.0, 1.0], 5)) == 0
    # no finite statistic (a NaN in every kept part): nothing to minimise, nothing truncated
    assert stats.mser5(np.r_[np.repeat(b, 5)[:-1], np.nan]) == 0


# ---- evidence: the first line has no line before it --------------------------------------------

def test_the_first_line_is_not_joined_to_the_last():
    """Only the line before reaches back: a page ending with the word "engine" does not make a
    hexadecimal word that opens the page an engine hash (the page has no line before its first)."""
    text = "0123456789ab is a commit, not an engine hash\n\nmeasured with the engine"
    assert evidence.engine_hashes(text) == []
    text = "and 0123456789ab\nengine aaaaaaaaaaaa"
    assert evidence.engine_hashes(text) == [(2, "", "aaaaaaaaaaaa")]


@pytest.mark.parametrize("k, n", [(2, 10), (0, 7), (9, 9)])
def test_wilson_interval_is_both_roots_of_its_quadratic(k, n):
    """Wilson's bounds are the two roots p of (k/n - p)^2 = z^2 p (1 - p) / n, i.e. of
    (1 + z^2/n) p^2 - (2 k/n + z^2/n) p + (k/n)^2 = 0 (solved here by numpy.roots), lower first."""
    z = scipy_stats.norm.ppf(0.975)
    roots = np.sort(np.roots([1 + z * z / n, -(2 * k / n + z * z / n), (k / n) ** 2]).real)
    lo, hi = stats.binomial_interval(k, n, method="wilson")
    assert (float(lo), float(hi)) == pytest.approx(tuple(roots), abs=1e-12)
