"""The report: verdicts (failed first), the landing page's headline numbers from small synthetic
aggregates, one caption per figure, and the figures' honesty rules (signed typology shares, the
energy-balance residual on its own scale). No simulation."""

import json
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from test_plots import synthetic_case

from millsim.analysis.aggregate import aggregate
from millsim.analysis.report import landing_rst, ordered, summarise, verdict_lines
from millsim.cli import main
from millsim.io import write_netcdf
from millsim.plots import PLOTS
from millsim.plots.stirred_mill import typology_figure

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


def stirred_aggregate(path, rolling=-0.06, residual=2e-5):
    """A stirred-mill power aggregate of 2 x 2 cases with made-up numbers: power = rpm / 1000
    * (1 + 10 eta), a negative rolling share in the wet cases."""
    eta, rpm = np.array([0.0, 0.1]), np.array([2000.0, 3000.0])
    power = (rpm[None, :] / 1000) * (1 + 10 * eta[:, None])
    shares = np.empty((2, 2, 4))
    for i, e in enumerate(eta):
        roll = rolling if e > 0 else 0.02
        shares[i, :] = [0.45, 0.0, 0.55 - roll, roll]
    ds = xr.Dataset(
        {"net_power": (("eta", "rpm"), power, {"units": "W"}),
         "net_power_ci": (("eta", "rpm"), 0.1 * power, {"units": "W"}),
         "energy_balance_error": (("eta", "rpm"), np.full((2, 2), residual), {"units": "1"}),
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
    assert "   * - 0.1\n     - 2000\n     - 4 \u00b1 0.4\n     - 45 / 61 / -6" in text
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
