"""The report: verdicts (failed first), the landing page's headline numbers from small synthetic
aggregates, calibrated values with their intervals (against hand-computed ones), one caption per
figure, the one figure style, and the figures' honesty rules (no trend line through fewer than 3
points, signed typology shares, the energy-balance residual on its own scale). No simulation."""

import json
import re
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
import pytest
import xarray as xr
from test_plots import synthetic_case

from millsim.analysis.aggregate import aggregate
from millsim.analysis.report import landing_rst, ordered, summarise, verdict_lines
from millsim.analysis.stirred_mill import (
    calibrate_friction,
    calibrate_viscosity,
    interval,
    predict,
    read_reference,
)
from millsim.cli import main
from millsim.io import write_netcdf
from millsim.plots import PLOTS
from millsim.plots.stirred_mill import typology_figure
from millsim.plots.style import RC

ROOT = Path(__file__).resolve().parents[1]


def verdict(check, passed):
    return dict(study="s", check=check, rule=f"rule of {check}", value=f"value of {check}",
                passed=passed)


def test_verdicts_print_failed_first_with_their_rule(tmp_path, capsys):
    given = [verdict("a", True), verdict("b", False), verdict("c", None), verdict("d", False),
             verdict("e", True)]
    path = tmp_path / "summary.json"
    path.write_text(json.dumps({"verdicts": given, "synthetic_reference": True}))
    assert main(["verdicts", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "millsim verdicts: 2 of 5 FAILED"
    body = [line for line in lines[1:] if not line.startswith("NOTE")]
    # failed, undecided, passed; the given order within each
    assert [line.split()[0] for line in body] == ["FAIL", "FAIL", "n/a", "PASS", "PASS"]
    assert [re.search(r"s: (\w): ", line).group(1) for line in body] == list("bdcae")
    assert all(f"[rule: rule of {c}]" in line for c, line in zip("bdcae", body))
    assert "SYNTHETIC" in lines[-1]
    assert [v["check"] for v in ordered(given)] == list("bdcae")


def test_all_passed_is_said_once():
    lines = verdict_lines({"verdicts": [verdict("a", True)]})
    assert lines == ["millsim verdicts: all 1 passed",
                     "PASS  s: a: value of a  [rule: rule of a]"]


def stirred_aggregate(path, rolling=-0.06, residual=2e-5, rpm=(2000.0, 3000.0)):
    """A stirred-mill power aggregate of 2 viscosities x the speeds ``rpm`` with made-up
    numbers: power = rpm / 1000 * (1 + 10 eta), a negative rolling share in the wet cases."""
    eta, rpm = np.array([0.0, 0.1]), np.asarray(rpm, float)
    power = (rpm[None, :] / 1000) * (1 + 10 * eta[:, None])
    shares = np.empty((2, rpm.size, 4))
    for i, e in enumerate(eta):
        roll = rolling if e > 0 else 0.02
        shares[i, :] = [0.45, 0.0, 0.55 - roll, roll]
    ds = xr.Dataset(
        {"net_power": (("eta", "rpm"), power, {"units": "W"}),
         "net_power_ci": (("eta", "rpm"), 0.1 * power, {"units": "W"}),
         "energy_balance_error": (("eta", "rpm"), np.full(power.shape, residual), {"units": "1"}),
         "typology_fraction": (("eta", "rpm", "typology"), shares, {"units": "1"}),
         "dissipation_power": (("eta", "rpm", "audit_term"), power[..., None] / 2 * np.ones(2),
                               {"units": "W"})},
        coords={"eta": ("eta", eta, {"units": "Pa s"}), "rpm": ("rpm", rpm, {"units": "min-1"}),
                "typology": ("typology", ["impact", "torsion", "shearing", "rolling"],
                             {"units": "1"}),
                "audit_term": ("audit_term", ["a", "b"], {"units": "1"})},
        attrs={"stacked_over": json.dumps(["eta", "rpm"]), "title": "stirred-mill aggregate"})
    write_netcdf(path, ds)
    return path


def test_landing_page_holds_the_headline_numbers_of_the_aggregates(tmp_path):
    cases = [synthetic_case(tmp_path / f"case_{s}.nc", s) for s in (0.5, 1.0, 1.5)]
    ballmill = tmp_path / "ballmill.nc"
    write_netcdf(ballmill, aggregate("ballmill2d", cases, ["n_over_nc"]))
    stirred = stirred_aggregate(tmp_path / "stirred.nc")
    text = landing_rst(summarise(ballmill, stirred_path=stirred))
    # synthetic_case: rate 10 exp(-(n - 1)^2) s-1 +- 0.5, drive power 2 n W
    assert "highest comminution rate: 10 \u00b1 0.5 s\u207b\u00b9 at n/n\\_c = 1" in text
    assert "highest drive power: 3 W at n/n\\_c = 1.5" in text
    # stirred: 3 W at eta 0.1 Pa s and 2000 min-1 (rpm / 1000 (1 + 10 eta)), its interval 10 %
    # and its energy-balance residual 2e-5 as a per cent, in the table too
    assert "   * - 0.1\n     - 2000\n     - 4 \u00b1 0.4\n     - 45 / 61 / -6\n     - 0.002\n" in text
    assert "All 1 checks passed." in text
    assert "largest 0.002 %" in text  # the residual 2e-5, as a per cent
    assert "SYNTHETIC" not in text  # no calibration given, no flag


def test_landing_page_puts_a_failed_verdict_first_and_flags_a_synthetic_reference(tmp_path):
    stirred = stirred_aggregate(tmp_path / "stirred.nc", residual=0.05)
    summary = summarise(stirred_path=stirred)
    summary["synthetic_reference"] = True
    text = landing_rst(summary)
    assert text.index("SYNTHETIC REFERENCE") < text.index("Verification verdicts")
    assert "**1 of 1 checks FAILED**" in text
    assert "   * - **FAIL**\n     - stirred\\_mill: energy balance" in text


def test_every_registered_figure_has_its_own_caption():
    captions = [p.caption for p in PLOTS.values()]
    assert all(len(c) > 80 for c in captions)
    assert len(set(captions)) == len(captions)
    # the report shows each figure with the caption of its registry entry
    assert (ROOT / "workflow/report/plot.rst").read_text().strip() \
        == "{{ snakemake.params.caption }}"
    for rules in (ROOT / "workflow/rules").glob("*.smk"):
        text = rules.read_text()
        for output in re.finditer(r"report\(\n(.*?)\n\s*\),", text, re.S):
            assert 'caption="../report/plot.rst"' in output.group(1), rules.name
        # each a caption per figure: the registry's entry for the figure (a family's member has
        # the study it shows prepended)
        assert text.count('caption="../report/plot.rst"') \
            == len(re.findall(r"caption=(figure_caption|accuracy_caption|PLOTS\[)", text)), \
            rules.name


def test_typology_draws_a_negative_share_below_zero_and_nothing_above_100(tmp_path):
    ds = xr.load_dataset(stirred_aggregate(tmp_path / "s.nc", rolling=-0.056, residual=1e-5))
    fig = typology_figure(ds)
    shares, residual = fig.axes[:2]
    tops = [bar.get_y() + bar.get_height() for bar in shares.patches]
    bottoms = [min(bar.get_y(), bar.get_y() + bar.get_height()) for bar in shares.patches]
    assert max(tops) <= 100
    assert min(bottoms) == pytest.approx(-5.6)
    assert [t.get_text() for t in shares.texts if t.get_text().startswith("sum")] \
        == ["sum 100 %\nof 2 W", "sum 100 %\nof 3 W", "sum 100 %\nof 4 W", "sum 100 %\nof 6 W"]
    # the residual of 0.001 % fills its own axis instead of vanishing against +-2 %
    lo, hi = residual.get_ylim()
    assert max(abs(lo), hi) < 0.01
    assert min(bar.get_height() for bar in residual.patches) / (hi - lo) > 0.2


# ---- calibrated values with their intervals ---------------------------------------------------

def test_interval_of_one_condition_is_where_the_power_stays_within_its_half_width():
    # P = 10 x against R = 12 with half-width 2: |10 x - 12| <= 2, x in [1.0, 1.4]
    iv = interval([0.0, 1.0, 2.0], [0.0, 10.0, 20.0], [2.0, 2.0, 2.0], 12.0)
    assert iv["best"] == pytest.approx(1.2, abs=5e-4)
    assert (iv["lo"], iv["hi"]) == pytest.approx((1.0, 1.4), abs=5e-4)
    assert iv["scale"] == 1.0 and not iv["lo_open"] and not iv["hi_open"]
    # the grid ends at 2: an interval reaching it is open there
    assert interval([0.0, 1.0, 2.0], [0.0, 10.0, 20.0], [2.0] * 3, 19.0)["hi_open"]


def test_interval_of_disagreeing_conditions_is_widened_by_the_scale_factor():
    """Two speeds, P = 10 x at both, references 10 and 14, half-widths 1: q = (10x - 10)^2 +
    (10x - 14)^2 is 8 at its minimum x = 1.2, so S^2 = 1.96^2 x 8 / 1 = 30.73 and q - 8 =
    2 (10x - 12)^2 <= S^2 gives x = 1.2 +- 1.96 x 2 / 10 = [0.808, 1.592]."""
    power = [[0.0, 0.0], [10.0, 10.0], [20.0, 20.0]]
    iv = interval([0.0, 1.0, 2.0], power, np.ones((3, 2)), [10.0, 14.0])
    assert iv["scale"] == pytest.approx(1.96**2 * 8)
    assert (iv["lo"], iv["best"], iv["hi"]) == pytest.approx((0.808, 1.2, 1.592), abs=5e-4)


def calibration_files(tmp_path, twin_friction=0.3):
    """The four calibration inputs of `millsim report`, from stages 1-3 run on a made-up table:
    P = rpm / 1000 (1 + 2 mu + 5 eta) +- 0.1 W at mu = 0.2, 0.3, 0.4, against a synthetic
    twin at mu = 0.3 whose source text names ``twin_friction`` as its generating friction."""
    rpms, mus, etas = [1000.0, 2000.0], [0.2, 0.3, 0.4], [0.01, 0.03, 0.1]

    def power(mu, eta, rpm):
        return rpm / 1000 * (1 + 2 * mu + 5 * eta)

    cases = pd.DataFrame([dict(friction=mu, eta=e, rpm=r, net_power=power(mu, e, r),
                               net_power_ci=0.1)
                          for mu in mus for e in [0.0, *etas] for r in rpms])
    reference = tmp_path / "reference.csv"
    reference.write_text("rpm,fluid,eta_exp,net_power,source\n" + "".join(
        f"{r},{f},{e},{power(0.3, e, r)},synthetic twin friction {twin_friction}\n"
        for f, e in (("dry", 0.0), ("A", 0.03)) for r in rpms))
    ref = read_reference(reference)
    _, _, friction = calibrate_friction(cases, ref)
    _, fluids = calibrate_viscosity(cases, ref, friction["friction"], 2000.0)
    paths = tmp_path / "friction.json", tmp_path / "viscosity.json", tmp_path / "prediction.csv"
    paths[0].write_text(json.dumps(friction))
    paths[1].write_text(json.dumps(dict(friction=friction["friction"], rpm=2000.0,
                                        fluids=fluids)))
    predict(cases, ref, friction["friction"], {"A": 0.03}).to_csv(paths[2], index=False)
    return [*paths, reference]


def test_calibrated_friction_has_the_hand_computed_interval(tmp_path):
    """Power linear in mu, slope 2 rpm / 1000 at each speed, half-width 0.1 W, exact reference:
    q = sum ((2 r (mu - 0.3)) / 0.1)^2 = 2000 (mu - 0.3)^2 <= 1, so mu = 0.3 +- 1 / sqrt(2000)
    = [0.2776, 0.3224]."""
    friction = json.loads(calibration_files(tmp_path)[0].read_text())
    iv = friction["friction_interval"]
    assert (iv["lo"], iv["hi"]) == pytest.approx((0.3 - 2000**-0.5, 0.3 + 2000**-0.5), abs=1e-4)
    assert iv["scale"] == 1.0  # the speeds agree: no widening
    summary = summarise(calibration_paths=calibration_files(tmp_path))
    table = summary["studies"][0]["table"]
    assert table[0] == ["parameter", "calibrated (grid)", "refined", "95 % interval",
                        "twin's generating value"]
    assert table[1] == ["friction \u03bc", "0.3", "0.3", "[0.278, 0.322]", "0.3"]
    assert table[2][:2] == ["\u03b7_sim of A [Pa s]", "0.03"] and table[2][4] == "0.03"


@pytest.mark.parametrize("twin_friction,passed", [(0.3, True), (0.33, False)])
def test_millsim_report_writes_the_page_and_prints_the_verdicts_failed_first(
        tmp_path, capsys, twin_friction, passed):
    """The command end to end: a stirred aggregate and the calibration files in, the summary
    and the landing page out, the verdicts printed; a twin generated at mu = 0.33 lies outside
    the calibrated [0.278, 0.322] and its verdict fails, first."""
    stirred = stirred_aggregate(tmp_path / "stirred.nc")
    cal = calibration_files(tmp_path, twin_friction)
    summary, page = tmp_path / "summary.json", tmp_path / "landing.rst"
    assert main(["report", "--stirred", str(stirred), "--calibration", *map(str, cal),
                 "--json", str(summary), "--rst", str(page)]) == 0
    printed = capsys.readouterr().out.splitlines()
    check = "stirred_mill: calibration recovers the twin's friction \u03bc"
    verdict = next(v for v in json.loads(summary.read_text())["verdicts"]
                   if f"{v['study']}: {v['check']}" == check)
    assert verdict["passed"] is passed
    assert verdict["value"] == f"{twin_friction:g} vs [0.278, 0.322]"
    text = page.read_text()
    assert text.startswith(".. warning::\n\n   **SYNTHETIC REFERENCE.**")
    assert "NOTE  the stirred-mill reference power is a SYNTHETIC twin" in printed[-1]
    # three verdicts: the energy balance and the twin's friction and eta_sim recovered
    if passed:
        assert printed[0] == "millsim verdicts: all 3 passed" and "All 3 checks passed." in text
    else:
        assert printed[0] == "millsim verdicts: 1 of 3 FAILED"
        assert printed[1].startswith(f"FAIL  {check}: 0.33 vs [0.278, 0.322]  [rule: ")
        assert "**1 of 3 checks FAILED** (listed first)" in text
        assert text.index("**FAIL**") < text.index("PASS")
    # `millsim verdicts` prints the same from the summary; the exit status is 0 either way (a
    # failed check is a result to read, not a broken run)
    assert main(["verdicts", str(summary)]) == 0
    assert capsys.readouterr().out.splitlines() == printed


# ---- the figure style -------------------------------------------------------------------------

@pytest.fixture
def saved(monkeypatch):
    """The figures `millsim plot` saves, with the rcParams in force at the time."""
    from matplotlib.figure import Figure

    figures = []
    original = Figure.savefig

    def savefig(fig, *args, **kwargs):
        figures.append((fig, dict(matplotlib.rcParams)))
        return original(fig, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return figures


def test_a_registered_figure_is_drawn_in_the_one_style(tmp_path, saved):
    from PIL import Image

    out = tmp_path / "power.png"
    assert main(["plot", "stirred_mill_power", str(stirred_aggregate(tmp_path / "s.nc")),
                 "--out", str(out)]) == 0
    (fig, rc), = saved
    for key in ("font.size", "font.family", "savefig.dpi", "legend.fontsize", "axes.grid"):
        assert rc[key] == matplotlib.rcParams.validate[key](RC[key]), key
    assert Image.open(out).info["dpi"] == pytest.approx((RC["savefig.dpi"],) * 2, abs=0.1)  # pixels per metre
    ax = fig.axes[0]
    assert ax.xaxis.label.get_fontsize() == RC["axes.labelsize"]
    assert ax.get_xticklabels()[0].get_fontsize() == RC["xtick.labelsize"]
    assert ax.xaxis.label.get_text() == "agitator speed [min$^{-1}$]"
    assert ax.get_legend().get_texts()[0].get_text() == r"$\eta_\mathrm{sim}$ = 0 Pa s"
    # the style does not leak: a figure drawn afterwards has matplotlib's defaults
    assert matplotlib.rcParams["savefig.dpi"] != RC["savefig.dpi"]


@pytest.mark.parametrize("speeds,line,note", [
    ((2000.0, 3000.0), "None", "2 speeds: no trend line"),
    ((2000.0,), "None", "1 speed: no trend line"),
    ((2000.0, 2500.0, 3000.0), "-", None),
])
def test_fewer_than_three_points_draw_no_trend_line_and_say_how_many(tmp_path, saved, speeds,
                                                                      line, note):
    agg = stirred_aggregate(tmp_path / "s.nc", rpm=speeds)
    assert main(["plot", "stirred_mill_power", str(agg), "--out", str(tmp_path / "p.png")]) == 0
    ax = saved[0][0].axes[0]
    simulated = [c.lines[0] for c in ax.containers]  # one errorbar per viscosity
    assert len(simulated) == 2 and {d.get_linestyle() for d in simulated} == {line}
    assert [len(d.get_xdata()) for d in simulated] == [len(speeds)] * 2
    notes = [t.get_text() for t in ax.texts if "trend" in t.get_text()]
    assert notes == ([note] if note else [])


def test_the_ballmill_rate_figure_follows_the_same_rule(tmp_path, saved):
    cases = [synthetic_case(tmp_path / f"case_{s}.nc", s) for s in (0.5, 1.0)]
    agg = tmp_path / "ballmill.nc"
    write_netcdf(agg, aggregate("ballmill2d", cases, ["n_over_nc"]))
    assert main(["plot", "ballmill_rate", str(agg), "--out", str(tmp_path / "p.png")]) == 0
    rate, power = saved[0][0].axes
    assert [c.lines[0].get_linestyle() for c in rate.containers] == ["None"]
    assert [t.get_text() for t in power.texts] == ["2 speeds: no trend line"]


@pytest.mark.parametrize("slice_,expected", [
    (1, "periodic slice around 1 of 4 disks, scale 0.45, 2,487 beads: not the LS1's power"),
    (0, "full chamber, 4 disks, scale 1, 2,487 beads + 655 agitator spheres"),
])
def test_the_stirred_figures_name_the_simulated_domain(tmp_path, saved, slice_, expected):
    """A full-chamber study must not be captioned as the quick slice, nor the slice as the LS1."""
    agg = tmp_path / "s.nc"
    ds = xr.open_dataset(stirred_aggregate(tmp_path / "raw.nc")).load()
    ds.attrs.update(param_slice=slice_, param_scale=1.0 if slice_ == 0 else 0.45, param_disks=4)
    ds["n_bead"] = (("eta", "rpm"), np.full((2, 2), 2487), {"units": "1"})
    ds["n_agitator_particles"] = (("eta", "rpm"), np.full((2, 2), 655), {"units": "1"})
    write_netcdf(agg, ds)
    for figure in ("stirred_mill_power", "stirred_mill_typology"):
        assert main(["plot", figure, str(agg), "--out", str(tmp_path / f"{figure}.png")]) == 0
    power, typology = (fig for fig, _ in saved)
    assert power.get_suptitle() == expected
    assert typology.get_suptitle() == expected
