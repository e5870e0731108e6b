"""The report's first screen in a real browser: `snakemake --report` of a tiny workflow whose
landing page is the real workflow/report/workflow.rst with a `landing_rst` of a made-up summary,
opened in headless Chromium at 1400 x 1000. The title, the synthetic-reference warning and the
first verdict row are on the first screen, and nothing of the page is above the scroll origin
(Snakemake 9 centres its home view in a 100vh box, which put the top of a long page out of reach).

Needs Playwright (the test extra) and a Chromium: Debian's /usr/bin/chromium (`apt-get install
chromium`, .ci/run does it), or MILLSIM_CHROMIUM naming another; skipped with the reason otherwise.
MILLSIM_REPORT_SCREENSHOT=docs/figures/report_first_screen.png also saves the first screen there.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from millsim.analysis.report import landing_rst

sync_api = pytest.importorskip("playwright.sync_api",
                               reason="playwright is not installed (pip install -e '.[test]')")

ROOT = Path(__file__).resolve().parents[1]
WIDTH, HEIGHT = 1400, 1000
CHROMIUM = os.environ.get("MILLSIM_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"

# The shape and length of the quick study's page (9 verdicts, 2 failed, every study's table); the
# numbers are made up, only the layout is tested.
# the rule as the quick study words it: its length sets the table's width, and so the page's
TAVARES_RULE = ("eq 1 against the broken count at each energy, exact two-sided binomial test; the "
                "energies (impacts) combined by Bonferroni, the run's verdicts by Holm at 5 % "
                "family-wise (millsim.analysis.tavares_verification.binomial_p_value, bonferroni, "
                "holm)")
TWIN_RULE = ("the synthetic twin's generating value inside the 95 % interval of the calibrated "
             "one (millsim.analysis.stirred_mill.interval)")
SUMMARY = dict(
    synthetic_reference=True,
    verdicts=[
        dict(study="tavares", check=f"probability: {mode}", rule=TAVARES_RULE,
             value=value, passed=passed)
        for mode, value, passed in [("drop weight, limestone", "2 of 4 inside (50 %)", False),
                                    ("slow compression, limestone", "4 of 4 inside (100 %)", True),
                                    ("drop weight, copper ore", "4 of 4 inside (100 %)", True)]
    ] + [
        dict(study="tavares", check="t10: breakage_at first_reach", rule=TAVARES_RULE,
             value="0 of 3 inside (0 %)", passed=False),
        dict(study="tavares", check="t10: breakage_at end_of_loading", rule=TAVARES_RULE,
             value="3 of 3 inside (100 %)", passed=True),
        dict(study="stirred_mill", check="energy balance",
             rule="|agitator work - energy changes - dissipation| <= 2 % of the work, steady "
                  "window (millsim.analysis.stirred_mill.ENERGY_BALANCE_TOLERANCE)",
             value="largest 0.41 % (eta 0.1 Pa s, 3000 min-1)", passed=True),
    ] + [
        dict(study="stirred_mill", check=f"calibration recovers the twin's {name}",
             rule=TWIN_RULE, value=value, passed=True)
        for name, value in [("friction \u03bc", "0.3 vs [0.21, 0.38]"),
                            ("\u03b7_sim of water [Pa s]", "0.001 vs [\u2264 0, 0.02]"),
                            ("\u03b7_sim of glycerol [Pa s]", "0.1 vs [0.08, 0.13]")]
    ],
    studies=[
        dict(title="Ball mill 2D, comminution against mill speed", headline=[
            ("highest comminution rate", "10 \u00b1 0.5 s\u207b\u00b9 at n/n_c = 1"),
            ("highest drive power", "3 W at n/n_c = 1.5")]),
        dict(title="Ball mill 2D, force chains", headline=[
            ("cases", "3: n/n_c = 0.5, 1, 1.5")]),
        dict(title="Bed impact breakage", headline=[("cases", "12 in 4 conditions")],
             table=[["material", "rings x layers", "energy [J]", "broken mass [%]"]]
             + [["limestone", "3 x 2", str(e), str(10 * e)] for e in (1, 2, 4, 8)]),
        dict(title="Stirred media mill, power-draw calibration", headline=[
            ("reference", "SYNTHETIC twin (engine output), not a measurement")],
             table=[["parameter", "calibrated (grid)", "refined", "95 % interval",
                     "twin's generating value"],
                    ["friction \u03bc", "0.3", "0.29", "[0.21, 0.38]", "0.3"]]),
    ],
    # the quick study's command: a literal block does not wrap, so it sets the page's width
    command=("millsim report"
             " --ballmill results/aggregate/ballmill.nc"
             " --forcechain results/aggregate/ballmill_forcechain.nc"
             " --bed results/aggregate/bed_breakage.nc"
             " --tavares results/aggregate/tavares_verification.nc"
             " --stirred results/aggregate/stirred_mill.nc"
             " --calibration results/calibration/stirred_mill_friction.json"
             " results/calibration/stirred_mill_viscosity.json"
             " results/calibration/stirred_mill_prediction.csv"
             " config/reference/stirred_mill_power.csv"
             " --json results/report/summary.json"
             " --rst results/report/landing.rst"),
)

SNAKEFILE = f"""\
report: "{ROOT / 'workflow/report/workflow.rst'}"


rule all:
    input:
        "results/plots/figure.svg",


rule figure:
    output:
        report(
            "results/plots/figure.svg",
            caption="{ROOT / 'workflow/report/plot.rst'}",
            # the study's longest category name: it sets the menu's width, and so the page's
            category="Tavares single-particle verification",
        ),
    params:
        caption="A figure, so that the report has a category as the study's has.",
    shell:
        "echo '<svg xmlns=\\"http://www.w3.org/2000/svg\\" width=\\"10\\" height=\\"10\\"/>' "
        "> {{output}}"
"""


def build_report(workdir, summary=SUMMARY):
    """results/report.html of a one-rule workflow whose landing page is the real one."""
    (workdir / "results/report").mkdir(parents=True)
    (workdir / "results/report/landing.rst").write_text(landing_rst(summary))
    (workdir / "Snakefile").write_text(SNAKEFILE)
    snakemake = [sys.executable, "-m", "snakemake", "--cores", "1", "--quiet", "all"]
    for extra in ([], ["--report", "results/report.html"]):
        subprocess.run(snakemake + extra, cwd=workdir, check=True, capture_output=True)
    return workdir / "results/report.html"


@pytest.fixture(scope="module")
def browser():
    if not Path(CHROMIUM).exists():
        pytest.skip(f"no Chromium at {CHROMIUM} (apt-get install chromium, or set "
                    "MILLSIM_CHROMIUM); Playwright cannot download its own build offline")
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM)
        yield browser
        browser.close()


def test_report_opens_on_its_title_warning_and_verdicts(tmp_path, browser):
    report = build_report(tmp_path)
    page = browser.new_page(viewport=dict(width=WIDTH, height=HEIGHT))
    page.goto(report.as_uri())
    title = page.locator("h1.title")
    title.wait_for()
    page.wait_for_timeout(500)  # the Tailwind runtime styles the page after React renders it
    if shot := os.environ.get("MILLSIM_REPORT_SCREENSHOT"):
        page.screenshot(path=shot)
    warning = page.locator(".warning")
    first_row = page.locator("#verification-verdicts table tbody tr").first
    assert "SYNTHETIC REFERENCE" in warning.inner_text()
    assert "FAIL" in first_row.inner_text()
    for element in (title, warning, first_row):
        box = element.bounding_box()
        assert box is not None
        assert 0 <= box["y"] and box["y"] + box["height"] <= HEIGHT, (element, box)
        # and not cut at the right edge (a page wider than its pane scrolls sideways)
        assert 0 <= box["x"] and box["x"] + box["width"] <= WIDTH, (element, box)
    # nothing above the scroll origin: the page's top is where its scroll pane starts
    top = page.evaluate("""() => {
        const doc = document.querySelector("h1.title").closest(".document");
        let pane = doc.parentElement;
        while (pane && !["auto", "scroll"].includes(getComputedStyle(pane).overflowY)) {
            pane = pane.parentElement;
        }
        return [doc.getBoundingClientRect().top - pane.getBoundingClientRect().top
                + pane.scrollTop, pane.scrollTop];
    }""")
    assert top[0] >= 0 and top[1] == 0, top
    # the tables get the width of the window, not a 500 px column beside the rule graph
    assert page.locator(".document").bounding_box()["width"] >= 0.6 * WIDTH
    page.close()
