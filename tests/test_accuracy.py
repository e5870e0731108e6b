"""Error against run time (millsim.analysis.accuracy) on synthetic ladders with known answers, its
netCDF and figure, `millsim analyse accuracy`, and the `accuracy` Snakemake target (dry run, no
simulation)."""

import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr
import yaml

from millsim.analysis import accuracy as acc
from millsim.cli import main
from millsim.io import write_case, write_netcdf
from millsim.plots import plot

ROOT = Path(__file__).resolve().parents[1]
PNG = b"\x89PNG\r\n\x1a\n"
H = np.array([0.125, 0.25, 0.5, 1.0])  # a geometric ladder, finest first


def ladder(h, seeds, f, offsets=None):
    """Long table step, seed, value with value = f(h) + offset of the seed."""
    offsets = np.zeros(len(seeds)) if offsets is None else np.asarray(offsets, dtype=float)
    return pd.DataFrame([dict(step=s, seed=k, value=f(s) + o)
                         for s in h for k, o in zip(seeds, offsets)])


# ---- order, extrapolation, reference -----------------------------------------------------------

@pytest.mark.parametrize("p", [1.0, 2.0, 3.0])
def test_observed_order_is_recovered_on_any_spacing(p):
    assert acc.observed_order(H[:3], 1 + 0.3 * H[:3] ** p) == pytest.approx(p, abs=1e-9)
    h = np.array([0.1, 0.17, 0.4])  # not geometric, unsorted order does not matter
    assert acc.observed_order(h[::-1], (2 - 5 * h**p)[::-1]) == pytest.approx(p, abs=1e-9)


def test_observed_order_is_nan_when_not_monotone():
    assert math.isnan(acc.observed_order([0.1, 0.2, 0.4], [1.0, 1.1, 1.05]))
    assert math.isnan(acc.observed_order([0.1, 0.2, 0.4], [1.0, 1.0, 1.2]))


def test_richardson_removes_a_known_second_order_error():
    y = 1.0 + 0.3 * H**2
    assert acc.richardson(H, y, 2) == pytest.approx(1.0, abs=1e-14)
    # with the wrong order the extrapolation is off
    assert abs(acc.richardson(H, y, 1) - 1.0) > 1e-3


def test_reference_auto_extrapolates_smooth_and_falls_back_to_finest_on_noise():
    smooth = acc.reference_value(H, 1.0 + 0.3 * H**2, se=np.full(4, 1e-6))
    assert smooth["method"] == "richardson"
    assert smooth["order"] == pytest.approx(2.0, abs=1e-6)
    assert smooth["value"] == pytest.approx(1.0, abs=1e-9)
    noisy = acc.reference_value(H, [1.01, 0.99, 1.02, 1.0], se=np.full(4, 0.02))
    assert noisy["method"] == "finest" and noisy["value"] == 1.01 and noisy["step"] == 0.125
    # resolved but differences below twice their standard error: not smooth enough either
    small = acc.reference_value(H, 1.0 + 1e-4 * H**2, se=np.full(4, 1e-3))
    assert small["method"] == "finest"
    assert acc.reference_value(H, [0.1, 0.2, 0.3, 0.4], method="exact")["value"] == 0.0
    assert acc.reference_value(H, 1.0 + 0.3 * H**2, method="finest")["value"] == pytest.approx(
        1.0 + 0.3 * H[0] ** 2)


# ---- error, noise, cheapest step ---------------------------------------------------------------

def test_known_second_order_error_and_noise_are_separated():
    """Seeds shift the value (noise sd 0.05) but not its step dependence: the error is C h^2,
    recovered exactly by the paired differences, with no statistical uncertainty left."""
    offsets = [-0.05, 0.0, 0.05]
    values = ladder(H, [1, 2, 3], lambda h: 1.0 + 0.3 * h**2, offsets)
    table, ref = acc.error_table(values, tolerance=0.01)
    assert ref["method"] == "richardson"
    assert ref["value"] == pytest.approx(1.0, abs=1e-12)
    assert ref["noise"] == pytest.approx(0.05)
    assert table["error"].to_numpy() == pytest.approx(0.3 * H**2, abs=1e-12)
    assert table["relative_error"].to_numpy() == pytest.approx(0.3 * H**2, abs=1e-12)
    assert table["error_se"].to_numpy() == pytest.approx(0.0, abs=1e-12)
    # within 1 %: 0.3 h^2 <= 0.01 for h <= 0.18
    assert table["within"].tolist() == [True, False, False, False]


def test_error_hidden_in_noise_is_within():
    """Unpaired noise (a chaotic observable): an error of 2.6 % under a standard error of ~6 % is
    not distinguishable from zero; the same error without noise is not within 1 %."""
    rng = np.random.default_rng(1)
    noisy = ladder(H, range(6), lambda h: 1.0 + 0.03 * h)
    noisy["value"] += 0.1 * rng.standard_normal(len(noisy))
    table, ref = acc.error_table(noisy, method="finest")
    assert ref["noise"] == pytest.approx(noisy[noisy["step"] == H[0]]["value"].std())
    # pooled scatter of the paired differences ~ 0.1 sqrt(2): se ~ 0.058 with 6 seeds
    assert 0.03 < table["error_se"].iloc[-1] < 0.1
    assert table["within"].all()
    clean = ladder(H, range(6), lambda h: 1.0 + 0.03 * h)
    table, _ = acc.error_table(clean, method="finest")
    # 0.03 (h - 1/8) <= 1 % up to h = 0.458
    assert table["within"].tolist() == [True, True, False, False]


def test_finest_reference_pairs_the_seeds():
    """With a finest-step reference the paired differences cancel the seed offsets exactly."""
    values = ladder(H, [1, 2, 3], lambda h: 2.0 + 0.1 * h, [0.3, -0.2, 0.5])
    table, ref = acc.error_table(values, method="finest")
    assert ref["method"] == "finest"
    assert table["error"].to_numpy() == pytest.approx(0.1 * (H - H[0]), abs=1e-12)
    assert table["error_se"].to_numpy() == pytest.approx(0.0, abs=1e-12)
    assert table["resolved"].tolist() == [False, True, True, True]


def test_residual_observable_is_compared_with_zero():
    values = ladder(H, [1, 2], lambda h: 0.02 * h)
    table, ref = acc.error_table(values, tolerance=0.01, residual=True)
    assert ref["method"] == "exact"
    assert table["relative_error"].to_numpy() == pytest.approx(0.02 * H)
    assert table["within"].tolist() == [True, True, True, False]


def test_cheapest_within():
    step = [1.0, 2.0, 4.0, 8.0]
    assert acc.cheapest_within(step, [8, 4, 2, 1], [True, True, True, False]) == 2
    # contiguous from the finest: a lucky coarse step after a failure does not count
    assert acc.cheapest_within(step, [8, 4, 2, 1], [True, False, True, True]) == 0
    assert acc.cheapest_within(step, [8, 4, 2, 1], [True, False, True, True],
                               contiguous=False) == 3
    # by cost, not by step: a coarser step that ran slower loses; ties go to the larger step
    assert acc.cheapest_within(step, [8, 3, 5, 9], [True] * 4) == 1
    assert acc.cheapest_within(step, [8, 3, 3, 9], [True] * 4) == 2
    assert acc.cheapest_within(step, [8, 4, 2, 1], [False, True, True, True]) is None


def synthetic_cases(seeds=(1, 2, 3)):
    """A long case table of ballmill2d: Gear error 0.2 (h/h0)^2, Verlet 10x that, both around
    the same converged drive power 1.0 W; the rate has seed noise (sd 5 s-1) and noise that
    differs from step to step (+-3 s-1) larger than its step dependence (up to 2 s-1, 4 %)."""
    rows = []
    for series, spc, c, _link in (("gear", [100, 50, 25, 16], 0.002, None),
                                 ("verlet", [50, 25, 16, 10], 0.02, "gear")):
        for n in spc:
            h = 1e-4 / n
            for s in seeds:
                base = dict(name="ballmill", scene="ballmill2d", series=series,
                            ladder="steps_per_contact", ladder_value=float(n), seed=s, dt=h,
                            dt_limit=1e-5, steps=int(1.0 / h), wall_time_s=1e-4 / h * 0.1,
                            engine_hash="abc", millsim_version="0", parameters_json="{}",
                            path=f"{series}/{n}/{s}")
                rows.append(dict(base, observable="drive_power", units="W",
                                 value=1.0 + c * (10 / n) ** 2 + 1e-4 * s))
                rows.append(dict(base, observable="comminution_rate", units="s-1",
                                 value=50 + 5 * (s - 2) + 2 * 10 / n
                                 + 3 * ((s + n) % 3 - 1)))
    return pd.DataFrame(rows)


def test_analyse_borrowed_reference_and_choice():
    cases = synthetic_cases()
    points, choices = acc.analyse(cases, tolerance=0.01, links={("ballmill", "verlet"): "gear"},
                                  methods={"ballmill": "finest"})
    power = points[points["observable"] == "drive_power"].set_index(["series", "ladder_value"])
    # the Verlet series is compared with the finest Gear step: its own finest step has an error
    assert power.loc[("verlet", 50.0), "reference_series"] == "gear"
    expected = 0.02 * (10 / 50) ** 2 - 0.002 * (10 / 100) ** 2
    assert power.loc[("verlet", 50.0), "error"] == pytest.approx(expected, abs=1e-12)
    assert power.loc[("gear", 100.0), "error"] == 0.0
    pick = choices.set_index(["series", "observable"])
    # Gear: 0.002 (10/16)^2 = 0.08 % -> the coarsest; Verlet: 0.02 (10/n)^2 <= 1 % from n >= 15
    assert pick.loc[("gear", "drive_power"), "ladder_value"] == 16
    assert pick.loc[("verlet", "drive_power"), "ladder_value"] == 16
    # the rate's error exceeds 1 % but is not distinguishable from zero: the coarsest step
    rate = points[points["observable"] == "comminution_rate"].set_index(["series", "ladder_value"])
    coarse = rate.loc[("verlet", 10.0)]
    assert abs(coarse["relative_error"]) > 0.01
    assert abs(coarse["error"]) < 2 * coarse["error_se"] and coarse["within"]
    assert pick.loc[("verlet", "comminution_rate"), "ladder_value"] == 10
    both = pick.loc[("verlet", "comminution_rate+drive_power")]
    assert both["ladder_value"] == 16 and both["found"]
    # with a margin below the stability limit (1e-5 s here) the coarsest Verlet step is out
    _, margin = acc.analyse(cases, links={("ballmill", "verlet"): "gear"}, limit_fraction=0.7)
    pick = margin.set_index(["series", "observable"])
    assert pick.loc[("verlet", "comminution_rate"), "ladder_value"] == 16
    assert pick.loc[("gear", "drive_power"), "ladder_value"] == 16  # 6.25e-6 s <= 0.7e-5 s


def test_dataset_roundtrip_summary_and_figure(tmp_path):
    cases = synthetic_cases()
    points, choices = acc.analyse(cases, links={("ballmill", "verlet"): "gear"})
    ds = acc.to_dataset(cases, points, choices, {"tolerance": 0.01, "title": "synthetic"})
    path = tmp_path / "accuracy.nc"
    write_netcdf(path, ds)
    with xr.open_dataset(path, engine="netcdf4") as back:
        back = back.load()
    assert all("units" in back[v].attrs for v in back.variables)
    again = acc.points_frame(back, "point")
    assert len(again) == len(points)
    assert np.allclose(again["error"].to_numpy(float), points["error"].to_numpy(float))
    assert set(acc.points_frame(back, "case")["series"]) == {"gear", "verlet"}
    text = acc.summary_markdown(again, acc.points_frame(back, "choice"))
    assert "ballmill / verlet: drive_power" in text and "of series gear" in text
    out = tmp_path / "fig.png"
    plot("error_vs_runtime_ballmill", path, out)
    assert out.read_bytes()[:8] == PNG
    with pytest.raises(ValueError, match="no accuracy points"):
        plot("error_vs_runtime_stirred_mill", path, tmp_path / "none.png")


def synthetic_stirred_case(path, dt, seed, power, residual):
    data = xr.Dataset({
        "net_power": ((), power, {"units": "W"}),
        "energy_balance_error": ((), residual, {"units": "1"}),
    })
    write_case(path, data, {"scene": "stirred_mill",
                            "parameters": {"dt": dt, "seed": seed, "eta": 0.0},
                            "seed": seed, "dt": dt, "steps": int(1e-3 / dt),
                            "wall_time_s": 1e-6 / dt, "dt_limit": 2e-5})


def test_command_line_from_case_files(tmp_path):
    paths = []
    for dt in (2.5e-6, 5e-6, 1e-5, 2e-5):
        for seed in (1, 2):
            p = tmp_path / f"c{dt}_{seed}.nc"
            synthetic_stirred_case(p, dt, seed, 1.3 + 1e8 * dt**2 + 0.01 * seed, 1e2 * dt)
            paths.append(str(p))
    table = tmp_path / "dry.csv"
    assert main(["analyse", "accuracy", "collect", *paths, "--name", "stirred_mill", "--series",
                 "dry", "--ladder", "dt", "--out", str(table)]) == 0
    out = tmp_path / "accuracy.nc"
    assert main(["analyse", "accuracy", "aggregate", str(table), "--config-json", '{"a": 1}',
                 "--out", str(out), "--summary", str(tmp_path / "summary.md")]) == 0
    with xr.open_dataset(out, engine="netcdf4") as ds:
        points = acc.points_frame(ds.load(), "point")
        assert ds.attrs["config_json"] == '{"a": 1}'
    power = points[points["observable"] == "net_power"]
    assert power["reference_method"].iloc[0] == "richardson"
    assert power["reference"].iloc[0] == pytest.approx(1.315, abs=1e-9)
    assert ds.attrs["Conventions"] == "CF-1.8"  # the one netCDF writer
    assert main(["analyse", "accuracy", "summary", str(out)]) == 0
    assert main(["plot", "error_vs_runtime_stirred_mill", str(out),
                 "--out", str(tmp_path / "f.png")]) == 0
    assert main(["analyse", "accuracy", "collect", paths[0], "--name", "x", "--series", "y",
                 "--ladder", "dt_factor", "--out", str(table)]) == 2


# ---- the Snakemake target -----------------------------------------------------------------------

TINY = {
    "ballmill": {
        "parameters": {"n_over_nc": [1.0], "drum_radius": 0.02, "grain_radius": 0.002,
                       "filling": 0.3, "duration": 0.02, "transient": 0.01},
        "forcechain": {"n_over_nc": [1.0]},
        "animation": {"n_over_nc": 1.0, "duration": 0.015},
    },
    "accuracy": {
        "ballmill": {
            # a placeable charge: the workflow builds the dt_factor 2.5 cases to check their step
            "parameters": {"drum_radius": 0.02, "grain_radius": 0.002, "filling": 0.3,
                           "duration": 0.02, "transient": 0.01},
            "seed": [1, 2],
            "series": {
                "gear": {"set": {"integrator": "gear"}, "ladder": {"dt_factor": [0.5, 1.0]}},
                "verlet": {"set": {"integrator": "verlet"},
                           "ladder": {"dt_factor": [1.0, 2.5]}, "reference": "gear"},
            },
        },
        "stirred_mill": {
            "parameters": {"scale": 0.45, "slice": True, "revolutions": 0.1,
                           "transient_revolutions": 0.05},
            "seed": [1],
            "series": {"wet": {"set": {"eta": 0.1}, "ladder": {"dt": [3e-6, 1.5e-6]}}},
        },
    },
}


def dry_run(tmp_path, config, *targets):
    for name in ("Snakefile", "workflow", "config"):
        src = ROOT / name
        (shutil.copytree if src.is_dir() else shutil.copy)(src, tmp_path / name)
    (tmp_path / "config" / "config.yaml").write_text(yaml.safe_dump(config))
    run = subprocess.run([sys.executable, "-m", "snakemake", "-n", "-p", "--cores", "1", *targets],
                         cwd=tmp_path, capture_output=True, text=True)
    return run.returncode, run.stdout + run.stderr


def job_counts(text):
    counts = {}
    block = text.split("Job stats:", 1)[-1].split("Reasons:", 1)[0]
    for line in block.splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[1].isdigit():
            counts[parts[0]] = int(parts[1])
    return counts


def test_accuracy_target_dry_run(tmp_path):
    code, text = dry_run(tmp_path, TINY, "accuracy")
    assert code == 0, text
    counts = job_counts(text)
    assert counts["simulate_accuracy_ballmill_gear"] == 4  # 2 steps x 2 seeds
    assert counts["simulate_accuracy_ballmill_verlet"] == 4
    assert counts["simulate_accuracy_stirred_mill_wet"] == 2
    assert counts["accuracy_collect"] == 3 and counts["aggregate_accuracy"] == 1
    assert counts["plot_accuracy"] == 2
    assert "results/cases/accuracy_ballmill_verlet/dt_factor~2.5/seed~2/case.nc" in text
    assert "millsim analyse accuracy aggregate" in text
    assert "millsim plot error_vs_runtime_stirred_mill" in text
    assert "--reference ballmill/verlet=gear" in text
    assert "results/plots/error_vs_runtime_stirred_mill.png" in text
    # the default target does not run the accuracy study
    (tmp_path / "all").mkdir()
    code, text = dry_run(tmp_path / "all", TINY)
    assert code == 0, text
    jobs = job_counts(text)
    assert not any(k.startswith(("simulate_accuracy", "aggregate_accuracy")) for k in jobs)


@pytest.mark.parametrize("where, value, named", [
    (("ballmill", "series", "verlet", "reference"), "rk4", "rk4"),
    (("ballmill", "series", "gear", "ladder"), {"steps_per_contact": [5, 25]}, "steps_per_contact"),
    (("ballmill", "series", "gear", "ladder"), {"duration": [1, 2]}, "duration"),
    # the scene's own declaration refuses it (ranges and choices live there), before any job
    (("ballmill", "series", "gear", "set"), {"integrator": "rk4"}, "integrator"),
])
def test_bad_accuracy_config_is_refused(tmp_path, where, value, named):
    config = yaml.safe_load(yaml.safe_dump(TINY))
    block = config["accuracy"]
    *parents, key = where
    for name in parents:
        block = block[name]
    block[key] = value
    code, text = dry_run(tmp_path, config, "accuracy")
    assert code != 0
    assert named in text
