"""The numbers the landing page derives from the aggregates, each against a value worked out by
hand from made-up aggregates: chain counts, bed percentages and millimetres, the stirred table's
residual cell, the Tavares rule texts and the state of a check without a p-value."""

import json

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from test_report import stirred_aggregate

from millsim.analysis import report
from millsim.io import write_netcdf


def _write(path, ds):
    for name in ds.variables:
        ds[name].attrs.setdefault("units", "1")
    write_netcdf(path, ds)
    return path


@pytest.mark.parametrize("x, text", [(0.0, "0"), (1.0, "1"), (3500.0, "3500"), (0.01234, "0.0123"),
                                     (2.5e-5, "2.5e-05"), (2.5e6, "2.5e+06"), (float("nan"), "\u2013")])
def test_numbers_are_written_with_three_significant_digits(x, text):
    assert report._f(x) == text


def test_force_chains_are_summed_over_the_lengths_that_were_counted(tmp_path):
    counts = np.array([[3.0, 2.0, np.nan], [1.0, np.nan, np.nan]])  # NaN: no chain that long
    ds = xr.Dataset({"chain_count": (("n_over_nc", "chain_length"), counts)},
                    coords={"n_over_nc": [0.5, 0.8], "chain_length": [2, 3, 4]},
                    attrs={"title": "force-chain aggregate"})
    out = report.forcechain(_write(tmp_path / "fc.nc", ds))
    assert out["numbers"]["chains"] == [5.0, 1.0]
    assert "5 at n/n_c = 0.5, 1 at n/n_c = 0.8" in out["headline"][1][1]


def test_bed_rows_are_percent_and_millimetres_and_skip_conditions_not_run(tmp_path):
    shape = (1, 1, 1, 2)
    dims = ("material", "rings", "layers", "impact_energy")
    ds = xr.Dataset(
        {"broken_fraction_mean": (dims, np.array([0.123, np.nan]).reshape(shape)),
         "capture_radius_mean": (dims, np.array([0.0234, np.nan]).reshape(shape)),
         "replicates": (dims, np.array([5, 0]).reshape(shape))},
        coords={"material": ["limestone"], "rings": [2], "layers": [3],
                "impact_energy": [1.0, 2.0]}, attrs={"title": "bed aggregate"})
    out = report.bed(_write(tmp_path / "bed.nc", ds))
    (row,) = out["numbers"]["rows"]
    assert row["broken_mass_percent"] == pytest.approx(12.3, rel=1e-12)
    assert row["capture_radius_mm"] == pytest.approx(23.4, rel=1e-12)
    assert out["table"][1] == ["limestone", "2 x 3", "1", "12.3", "23.4", "5"]


def test_the_stirred_residual_cell_is_in_percent(tmp_path):
    out = report.stirred(stirred_aggregate(tmp_path / "s.nc", residual=0.01234))
    assert [r[-1] for r in out["table"][1:]] == ["1.2"] * 4
    out = report.stirred(stirred_aggregate(tmp_path / "t.nc", residual=0.0124))
    assert {r[-1] for r in out["table"][1:]} == {"1.2"}


def _tavares_aggregate(path, rules):
    ds = xr.Dataset(attrs={"title": "tavares aggregate", **{f"pass_rule_{g}": json.dumps(r) for g, r in rules.items()}})
    return _write(path, ds)


def test_every_tavares_rule_text_says_how_the_family_is_decided(tmp_path):
    rule = dict(inside=0.9, points=10, p_value=0.3, **{"pass": True})
    path = _tavares_aggregate(tmp_path / "t.nc", {g: {"any": rule} for g in
                                                  ("probability", "repeated", "t10")})
    verdicts = report.tavares(path)["verdicts"]
    assert len(verdicts) == 3
    for v in verdicts:
        assert "Holm at 5 % family-wise" in v["rule"] and "Bonferroni" in v["rule"]


def test_a_check_without_a_p_value_is_undecided_and_an_old_one_keeps_its_rule(tmp_path):
    rules = {"probability": {"no p": dict(inside=0.9, points=10, p_value=float("nan"),
                                          **{"pass": True}),
                             "old": dict(inside=0.9, points=10, **{"pass": False})}}
    verdicts = report.decide(report.tavares(_tavares_aggregate(tmp_path / "t.nc", rules))
                             ["verdicts"])
    assert [(v["check"], v["status"]) for v in verdicts] == [
        ("probability: no p", report.UNDECIDED), ("probability: old", report.FAILED)]


def test_the_prediction_headline_is_the_largest_relative_residual(tmp_path):
    from test_report import calibration_files

    paths = calibration_files(tmp_path)
    pd.DataFrame(dict(rpm=[2000.0, 3000.0], reference=[100.0, 50.0],
                      residual=[-5.0, 2.0])).to_csv(paths[2], index=False)
    cal = report.calibration(*paths)
    assert cal["numbers"]["prediction_max_relative_residual"] == pytest.approx(0.05, rel=1e-12)
    assert dict(cal["headline"])["prediction (stage 3)"].endswith("5 % over 2 points")
