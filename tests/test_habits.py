"""The habits of the ecosystem (licence, citation, the SLURM extra, a lint-clean workflow) and the
small things a user reads that must be true: the progress line, `millsim info`, and every
documentation path or section named in the package's help texts and docstrings."""

import io
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import xarray as xr
import yaml

from millsim.cli import main
from millsim.io import write_case, write_netcdf
from millsim.scenes.driver import Progress

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


# ---- licence, citation, extras --------------------------------------------------------------

def test_licence_is_an_spdx_string_with_its_file():
    """PEP 639: `license = "MIT"` and the file, which setuptools >= 77 reads without the
    deprecation warning a `{text = ...}` table gets."""
    project = PYPROJECT["project"]
    assert project["license"] == "MIT" and project["license-files"] == ["LICENSE"]
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("MIT License\n\nCopyright (c) 2026 the millsim developers\n")
    setuptools = [r for r in PYPROJECT["build-system"]["requires"] if r.startswith("setuptools")]
    assert setuptools == ["setuptools>=77"]


def test_citation_cites_the_software_and_the_three_papers():
    """CITATION.cff in the shape CFF 1.2.0 requires (cffconvert --validate passed on it); a DOI
    only where the project's sources give one."""
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert cff["cff-version"] == "1.2.0" and cff["type"] == "software"
    assert cff["message"] and cff["title"].startswith("millsim") and cff["authors"]
    assert cff["license"] == PYPROJECT["project"]["license"]
    assert str(cff["version"]) == PYPROJECT["project"]["version"]
    refs = cff["references"]
    assert [r["year"] for r in refs[:2]] == [2000, 2021]
    assert refs[0]["authors"][0]["family-names"] == "Buchholtz"
    assert refs[1]["authors"][0]["family-names"] == "Tavares"
    assert "LabStar LS1" in refs[2]["title"]
    assert all(r["type"] == "article" and r["title"] and r["authors"] for r in refs)
    assert [r.get("doi") for r in refs] == ["10.1007/PL00011052", None, None]


def test_slurm_plugin_is_an_extra_named_where_it_is_needed():
    """`pip install millsim[slurm]`; the profile, the README and docs/pipeline.md say so, and
    the profile what Snakemake's message without it means."""
    (requirement,) = PYPROJECT["project"]["optional-dependencies"]["slurm"]
    assert requirement.startswith("snakemake-executor-plugin-slurm>=2.8")
    profile = (ROOT / "profiles/slurm/profile.yaml").read_text()
    assert '".[slurm]"' in profile and "invalid choice: 'slurm'" in profile
    for doc in ("README.md", "docs/pipeline.md"):
        assert "millsim[slurm]" in (ROOT / doc).read_text(), doc


# ---- the workflow: lint, conda, caching noise -----------------------------------------------

def test_lint_finds_no_missing_environment_and_no_caching_noise():
    """`snakemake --lint`: every rule names the conda environment (workflow/envs/millsim.yaml),
    and no run prints "eligible for caching" (the rules are marked only with --cache); what is
    left is answered in docs/testing.md ("Lint")."""
    done = subprocess.run([sys.executable, "-m", "snakemake", "--lint"], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    text = done.stdout + done.stderr
    assert "Lints for" in text or "Congratulations" in text, text[-2000:]  # it ran
    assert "Specify a conda environment" not in text
    assert "eligible for caching" not in text
    findings = set(re.findall(r"^    \* (.+?)(?: in line \d+)?:$", text, re.M))
    assert findings <= {"Mixed rules and functions in same snakefile.",
                        "Path composition with '+'"}, findings
    env = yaml.safe_load((ROOT / "workflow/envs/millsim.yaml").read_text())
    assert "pip" in env["dependencies"]
    deploy = (ROOT / "workflow/envs/millsim.post-deploy.sh").read_text()
    assert "-c requirements/constraints.txt -e ." in deploy


# ---- the progress line ----------------------------------------------------------------------

def progress_lines(updates, compiles_before=0, compiles_after=0):
    """What Progress prints for ``updates`` [(fraction, note, sim_time)], with numba compile
    events before and after the first chunk."""
    from numba.core import event

    stream = io.StringIO()
    progress = Progress("scene", every=0.0, stream=stream)
    for _ in range(compiles_before):
        with event.trigger_event("numba:compile", data={}):
            pass
    progress.begin(5)
    for k, (fraction, note, sim_time) in enumerate(updates):
        progress.update(fraction, note, 10 * (k + 1), 5, sim_time)
        if k == 0:
            for _ in range(compiles_after):
                with event.trigger_event("numba:compile", data={}):
                    pass
    progress.finish(10 * len(updates))
    return stream.getvalue().splitlines()


def test_progress_says_compiling_only_when_numba_compiles():
    """Said once, when numba's compile event comes during the build or the first chunk; not at
    all when the step loop comes from the kernel cache (no event), nor for a later compile."""
    said = [line for line in progress_lines([(0.5, "", 1.0)] * 3, compiles_before=3)
            if "compiling the step loop" in line]
    assert len(said) == 1
    assert not [line for line in progress_lines([(0.5, "", 1.0)] * 3, compiles_after=2)
                if "compiling" in line]
    from numba.core import event

    before = len(event._registered["numba:compile"])
    progress_lines([(0.5, "", 1.0)])
    assert len(event._registered["numba:compile"]) == before  # the watcher is gone


def test_progress_of_a_case_that_ends_on_an_event_shows_times_not_a_percentage():
    """A fraction the case cannot give (None), or one stuck at 0 (a ball still falling), shows
    the simulated and the elapsed time; a known fraction a percentage and an ETA."""
    unknown = progress_lines([(None, "", 0.01), (None, "falling", 0.02), (0.0, "", 0.03)])[1:-1]
    assert unknown == [f"[millsim] scene: step {s}  5 particles  t = {t} s simulated  0 s elapsed"
                       + note for s, t, note in ((20, 0.02, "  falling"), (30, 0.03, ""))]
    known = progress_lines([(0.1, "", 0.01), (0.2, "", 0.02), (0.4, "", 0.03)])[1:-1]
    assert [line.split("step")[0] for line in known] == ["[millsim] scene:  20.0 %  ",
                                                        "[millsim] scene:  40.0 %  "]
    assert all(re.search(r"ETA \d+ s$", line) for line in known)
    assert not any(re.search(r"  0\.0 %|ETA -", line) for line in unknown + known)


def test_the_eta_extrapolates_the_rate_since_the_first_chunk(monkeypatch):
    """ETA = (1 - f) / rate, the rate (f - f0) / (t - t0) counted from the first known fraction
    after the first chunk (so not the compilation): on a clock of 10 s a chunk, fractions 0.1,
    0.2 and 0.4 give ETAs of 0.8 / 0.01 = 80 s and 0.6 / 0.015 = 40 s."""
    from millsim.scenes import driver

    clock = [0.0]
    monkeypatch.setattr(driver, "time", type("Clock", (), {"perf_counter": lambda: clock[0]}))
    stream = io.StringIO()
    progress = Progress("scene", every=0.0, stream=stream)
    for t, fraction in ((10.0, 0.1), (20.0, 0.2), (30.0, 0.4)):
        clock[0] = t
        progress.update(fraction, "", 1, 5)
    etas = re.findall(r"ETA (\d+) s", stream.getvalue())
    assert etas == ["80", "40"]


def test_a_case_records_its_steps_and_a_wall_time_within_the_run_s():
    """The provenance of a case (docs/pipeline.md): its steps (the collision records every step,
    from t = 0) and its wall time, which holds the compiled loop's seconds and lies within the
    time the caller saw the run take."""
    import time

    from millsim.scenes import load_all
    from millsim.scenes.base import RunContext, get_scene

    load_all()
    scene = get_scene("collision")
    values = scene.resolve({})
    start = time.perf_counter()
    ds, provenance = scene.run(values, RunContext())
    took = time.perf_counter() - start
    assert provenance["steps"] == ds.time.size - 1
    assert provenance["steps"] == round(float(ds.time[-1]) / provenance["dt"])
    assert provenance["compute_seconds"] <= provenance["wall_time_s"] <= took
    # threads: the number asked for, 0 where none was (docs/pipeline.md, "Provenance of a case")
    assert provenance["threads"] == 0
    assert scene.run(values, RunContext(threads=1))[1]["threads"] == 1


@pytest.mark.parametrize("overrides", [
    dict(n=40, settle_steps=300, steps=300, record_every=100),
    dict(container="drum", n=40, settle_steps=200, spinup_steps=200, steps=200, record_every=100),
], ids=["box", "drum"])
def test_a_staged_case_reports_progress_in_zero_to_one_naming_its_stage(monkeypatch, overrides):
    """A case's progress is (fraction done in [0, 1], a short note) (scenes/driver.py): the
    packing's stages (settle, spin-up in a drum, timed) share one fraction that only grows
    across them, each note names a stage, in order, and the last fraction is 1."""
    from helpers import progress_of

    seen = progress_of(monkeypatch, "packing", overrides)
    fractions = [f for f, _ in seen]
    assert all(0.0 <= f <= 1.0 for f in fractions) and fractions == sorted(fractions)
    assert fractions[-1] == 1.0
    stages = ["settle", "spinup", "timed"] if "spinup_steps" in overrides else ["settle", "timed"]
    notes = [note for _, note in seen[:-1]]  # the stage under way after each chunk
    assert set(notes) <= set(stages) and notes == sorted(notes, key=stages.index)


# ---- millsim info: every millsim file -------------------------------------------------------

def fake_case(path, speed):
    ds = xr.Dataset({"restitution": ((), 0.5, {"units": "1", "long_name": "restitution"})})
    params = {"speed": speed, "seed": 0}
    write_case(path, ds, {"scene": "collision", "parameters": params, "seed": 0, "dt": 1e-6,
                          "steps": 10, "wall_time_s": 1.0})
    return str(path)


def test_info_describes_cases_aggregates_and_analysis_outputs(tmp_path, capsys):
    cases = [fake_case(tmp_path / f"c{k}.nc", speed) for k, speed in enumerate((1.0, 2.0))]
    agg = tmp_path / "agg.nc"
    assert main(["aggregate", "collision", *cases, "--over", "speed", "--out", str(agg)]) == 0
    assert main(["info", str(agg)]) == 0
    out = capsys.readouterr().out
    assert "kind             aggregate: millsim collision: 2 cases stacked over speed" in out
    assert "cases            2" in out and "    speed = 1, 2" in out
    assert re.search(r"restitution +\[1\] 2 ", out)

    other = tmp_path / "analysis.nc"
    write_netcdf(other, xr.Dataset({"x": ("k", [1.0], {"units": "m"})},
                                   attrs={"title": "millsim accuracy study: a test"}))
    assert main(["info", str(other)]) == 0
    assert "kind             analysis output: millsim accuracy study" in capsys.readouterr().out

    assert main(["info", cases[0]]) == 0
    assert "    speed = 1.0" in capsys.readouterr().out
    foreign = tmp_path / "foreign.nc"
    xr.Dataset({"a": ("x", [1.0])}).to_netcdf(foreign)
    assert main(["info", str(foreign)]) == 2
    assert capsys.readouterr().err.startswith(f"millsim: error: {foreign}: not a millsim file")


# ---- documentation named in the package -----------------------------------------------------

# a path from the repository root (not part of another path: shared/reference/... is outside)
PATH = re.compile(r"(?<![\w/.-])((?:docs|config|bench|examples|workflow|tools|profiles)/[\w./-]*\w)")
# FILE.md, "Section" / FILE.md section "Section" / README section "Section" (quotes escaped or not)
SECTION = re.compile(r"([\w/.-]+\.md|README)(?:,| section)? \\?\"([^\"\\\n]+)\\?\"")
ANCHOR = re.compile(r"([\w/.-]+\.md)#([\w-]+)")


def headings(path):
    return [line.lstrip("#").strip() for line in path.read_text().splitlines()
            if line.startswith("#")]


def slug(heading):
    """GitHub's anchor of a heading."""
    return re.sub(r"[^\w\- ]", "", heading.lower()).replace(" ", "-")


def named_docs():
    """(source file, path, section or None, anchor or None) of every mention in src/."""
    for source in sorted((ROOT / "src").rglob("*.py")):
        text = source.read_text()
        for m in PATH.finditer(text):
            yield source, m.group(1).rstrip("."), None, None
        for m in SECTION.finditer(text):
            yield source, "README.md" if m.group(1) == "README" else m.group(1), m.group(2), None
        for m in ANCHOR.finditer(text):
            yield source, m.group(1), None, m.group(2)


def test_every_document_named_in_the_package_exists():
    """Help texts, parameter descriptions, figure captions and docstrings name files of the
    repository, sections and anchors of them: each must exist (docs/walls.md and the README's
    "Accuracy" section did not)."""
    missing = []
    named = list(named_docs())
    assert len(named) > 20  # the scan sees them
    for source, path, section, anchor in named:
        where = f"{source.relative_to(ROOT)}: {path}"
        if "<" in path or "*" in path:  # a pattern (results/cases/<study>/...), not a file
            continue
        target = ROOT / path
        if not target.exists():
            missing.append(f"{where} (no such file)")
        elif section and not any(section.lower() in h.lower() for h in headings(target)):
            missing.append(f'{where}, "{section}" (no such section)')
        elif anchor and anchor not in {slug(h) for h in headings(target)}:
            missing.append(f"{where}#{anchor} (no such anchor)")
    assert not missing, "\n".join(missing)


@pytest.mark.parametrize("command", ["run", "scenes", "info", "aggregate"])
def test_help_texts_name_no_missing_document(command, capsys):
    """The same for what `millsim COMMAND --help` prints (argparse rewraps the help texts)."""
    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for m in PATH.finditer(text):
        assert (ROOT / m.group(1).rstrip(".")).exists(), m.group(1)
    for m in SECTION.finditer(text):
        assert any(m.group(2).lower() in h.lower() for h in headings(ROOT / m.group(1))), m.group(0)



def test_readme_links_reach_their_files_and_sections():
    """Every relative link of the README (and of examples/README.md) names a file that exists
    and, with #anchor, a heading of it (GitHub's anchors)."""
    broken = []
    for readme in (ROOT / "README.md", ROOT / "examples" / "README.md"):
        for m in re.finditer(r"\]\(([^)\s]+)\)", readme.read_text()):
            if re.match(r"\w+:", m.group(1)):  # a URL
                continue
            path, _, anchor = m.group(1).partition("#")
            target = readme.parent / path if path else readme
            if not target.exists():
                broken.append(f"{readme.name}: {m.group(1)} (no such file)")
            elif anchor and anchor not in {slug(h) for h in headings(target)}:
                broken.append(f"{readme.name}: {m.group(1)} (no such anchor)")
    assert not broken, "\n".join(broken)
