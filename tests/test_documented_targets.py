"""Every `snakemake` target and `--configfile` the documentation names plans (issue 48, item 0).

The commands are read from README.md, config/README.md, docs/*.md and docs/results/*.md, so a
newly documented target or config file is covered without editing this test. One dry run per
config file, all its documented targets at once, in this process (Snakemake's API), in a copy of
the workflow. The quick config's time steps are checked as `snakemake -n` checks them (a case
built as `millsim run` builds it): that is where `snakemake accuracy` stopped, a ladder rung above
a moved lubrication limit. Building a full-scale chamber of config/paper.yaml takes ~7 s, and its
sweeps hold ~150 of them: the other config files are planned with the build stubbed.
"""

import dataclasses
import os
import re
import shlex
import shutil
from pathlib import Path

import pytest
from snakemake import api
from snakemake.settings import types as settings

from millsim.scenes import base

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", ROOT / "config" / "README.md", *sorted((ROOT / "docs").glob("*.md")),
        *sorted((ROOT / "docs" / "results").glob("*.md"))]
# options followed by values up to the next option (Snakemake's nargs="+"/"*")
MANY = {"--configfile", "--configfiles", "--config", "-C", "-R", "--forcerun", "--until", "-U",
        "--cache", "--set-threads", "--set-resources", "--omit-from", "-O", "--rerun-triggers"}
ONE = {"--cores", "-c", "-j", "--jobs", "--workflow-profile", "--profile", "--directory", "-d",
       "--snakefile", "-s"}
NO_VALUE = {"-n", "--dry-run", "-p", "--printshellcmds", "-k", "--keep-going", "-F", "--forceall",
            "--quiet", "-q"}
# commands that do not plan jobs
NOT_PLANNING = {"--report", "--unlock", "--lint", "--list-changes", "--summary", "--help"}


def documented_commands(paths=DOCS):
    """Every `snakemake ...` command in the text of ``paths`` (continued lines joined), as
    (file, argument list)."""
    found = []
    for path in paths:
        text = path.read_text().replace("\\\n", " ")
        for match in re.finditer(r"(?<![\w/.-])snakemake[ \t]+([^`\n#;&|)]*)", text):
            args = match.group(1).strip()
            try:
                words = shlex.split(args)
            except ValueError:  # prose with an odd quote
                words = args.split()
            found.append((path.relative_to(ROOT), words))
    return found


def plan_of(words):
    """(config files, targets, until) of one command; None if it does not plan jobs."""
    if any(w in NOT_PLANNING for w in words) or not words or words[0].startswith("--") and \
            words[0] not in ONE | MANY | NO_VALUE:
        return None
    configfiles, targets, until, k = [], [], [], 0
    while k < len(words):
        w = words[k]
        if w in MANY:
            k += 1
            while k < len(words) and not words[k].startswith("-"):
                if w in ("--configfile", "--configfiles"):
                    configfiles.append(words[k])
                elif w in ("--until", "-U"):
                    until.append(words[k])
                k += 1
            continue
        if w in ONE:
            k += 2
            continue
        if w.startswith("-") or w == "..." or not re.fullmatch(r"[\w./~=-]+", w):
            k += 1
            continue
        targets.append(w)
        k += 1
    return tuple(configfiles), targets, until


def documented_plans():
    """{config files (space-separated) or "": (targets, where they are documented)}; config
    files that are not in the repository (a user's my_study.yaml) are left out."""
    plans = {}
    for path, words in documented_commands():
        plan = plan_of(words)
        if plan is None:
            continue
        configfiles, targets, until = plan
        if any(not (ROOT / c).is_file() for c in configfiles):
            continue
        key = " ".join(configfiles)  # several are merged in order: planned together
        entry = plans.setdefault(key, (set(), set()))
        entry[0].update(targets + until or ["all"])
        entry[1].add(str(path))
    return plans


def test_the_documented_commands_are_found():
    """The parser sees what the README and docs say (a parser that found nothing would make the
    dry run below pass vacuously)."""
    plans = documented_plans()
    assert {"", "config/paper.yaml", "config/bed_trends.yaml"} <= set(plans)
    assert {"all", "accuracy", "ballmill", "ballmill3d", "bed_impact", "stirred_mill",
            "results/plots/ballmill_rate.png"} <= plans[""][0]
    assert "ballmill3d" in plans["config/paper.yaml"][0]
    assert {"paper_ballmill", "paper_bed_impact", "paper_single_particle"} <= \
        plans["config/paper.yaml"][0]
    assert "paper_stirred_mill" in plans["config/paper.yaml config/ls1_power.yaml"][0]
    assert "paper_ballmill3d" in plans["config/paper.yaml config/ballmill3d_lab_power.yaml"][0]
    # `paper` with both 2-core cuts (without the 3D one it runs paper.yaml's 24 lab cases)
    assert "paper" in plans["config/paper.yaml config/ls1_power.yaml "
                           "config/ballmill3d_lab_power.yaml"][0]
    assert plan_of(shlex.split("--cores 2 results/plots/tavares_probability.png --configfile "
                               "a.yaml b.yaml")) == (("a.yaml", "b.yaml"),
                                                     ["results/plots/tavares_probability.png"], [])
    assert plan_of(["--report", "results/report.html"]) is None


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("documented")
    for name in ("Snakefile", "workflow", "config", "profiles"):
        source = ROOT / name
        (shutil.copytree if source.is_dir() else shutil.copy)(source, tmp / name)
    return tmp


@pytest.fixture
def builds(monkeypatch):
    """The scenes' builds, memoised over the seed (the step limit of a case is that of its
    particles' sizes and materials, not of where the seed puts them; a ladder repeats every rung
    over 3 seeds), or stubbed; returns the switch."""
    base.get_scene("ballmill2d")  # load every scene
    done = {}

    def memo(scene):
        def build(values):
            key = (scene.name, repr(sorted((k, v) for k, v in values.items() if k != "seed")))
            if key not in done:
                done[key] = scene.build(values)
            return done[key]
        return build

    def use(real):
        for name, scene in list(base.REGISTRY.items()):
            monkeypatch.setitem(base.REGISTRY, name, dataclasses.replace(
                scene, build=memo(scene) if real else (lambda values: None)))
    return use


PLANS = documented_plans()


@pytest.mark.parametrize("configfile", sorted(PLANS), ids=lambda c: c or "config.yaml")
def test_every_documented_target_plans(workdir, builds, monkeypatch, configfile):
    """A dry run of every target documented with this config file (the quick config's time
    steps checked as `snakemake -n` checks them)."""
    targets, where = PLANS[configfile]
    builds(real=not configfile)
    monkeypatch.chdir(workdir)  # the API changes into its workdir; undone after the test
    monkeypatch.setenv("PATH", os.environ["PATH"])  # common.smk prepends the venv; undone too
    output = settings.OutputSettings(dryrun=True, quiet={settings.Quietness.ALL})
    configs = settings.ConfigSettings(configfiles=[workdir / c for c in configfile.split()])
    with api.SnakemakeApi(output) as sm:
        workflow = sm.workflow(resource_settings=settings.ResourceSettings(cores=2),
                               config_settings=configs, snakefile=workdir / "Snakefile",
                               workdir=workdir)
        try:
            workflow.dag(settings.DAGSettings(targets=targets)).execute_workflow(
                executor="dryrun")
        except Exception as exc:
            raise AssertionError(f"targets {sorted(targets)} with config "
                                 f"{configfile or 'config/config.yaml'} (documented in "
                                 f"{', '.join(sorted(where))}) do not plan: {exc}") from exc
