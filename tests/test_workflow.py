"""The Snakemake pipeline through its API: a small sweep, caching of finished cases, bad config."""

import copy
import math
import re
from pathlib import Path

import pytest
import yaml
from snakemake import api
from snakemake.settings import types as settings

from millsim.io import case_parameters, read_case

ROOT = Path(__file__).resolve().parents[1]


def tiny_config(speeds):
    """Cases of a fraction of a second in a small drum: the pipeline, not the physics, is tested."""
    return {
        "ballmill": {
            "parameters": {
                "n_over_nc": speeds,
                "drum_radius": 0.02,
                "grain_radius": 0.002,
                "filling": 0.3,
                "duration": 0.02,
                "transient": 0.01,
                "record_interval": 0.005,
                "snapshot_interval": 0.005,
                "seed": 3,
            },
            "forcechain": {"n_over_nc": [1.0]},
            "animation": {"n_over_nc": 1.0, "duration": 0.015},
        }
    }


def snakemake(workdir, config, dryrun=False):
    """Run the default target with ``config`` as config/config.yaml; return the files it wrote."""
    (workdir / "config" / "config.yaml").write_text(yaml.safe_dump(config))
    updated = []
    output = settings.OutputSettings(dryrun=dryrun, quiet={settings.Quietness.ALL})
    with api.SnakemakeApi(output) as sm:
        workflow = sm.workflow(
            resource_settings=settings.ResourceSettings(cores=2),
            snakefile=workdir / "Snakefile",
            workdir=workdir,
        )
        workflow.dag().execute_workflow(executor="dryrun" if dryrun else "local",
                                        updated_files=updated)
    return {str(Path(f)) for f in updated}


def case(study, speed):
    return f"results/cases/{study}/n_over_nc~{speed}/case.nc"


def speeds(workdir):
    return list(read_case(workdir / "results/aggregate/ballmill.nc")["n_over_nc"].values)


def test_sweep_runs_once_and_reruns_only_the_changed_case(workdir):
    written = snakemake(workdir, tiny_config([0.5, 1.0]))
    expected = {
        case("ballmill", 0.5), case("ballmill", 1.0), case("ballmill_forcechain", 1.0),
        case("ballmill_animation", 1.0), "results/aggregate/ballmill.nc",
        "results/aggregate/ballmill_forcechain.nc", "results/plots/ballmill_rate.png",
        "results/plots/ballmill_force_chains.png",
        "results/plots/ballmill_animation/n_over_nc~1.0.gif",
    }
    assert expected <= written
    assert all((workdir / f).stat().st_size > 0 for f in written)
    assert speeds(workdir) == [0.5, 1.0]
    # a case holds what its config asked for: the swept and fixed values, the steps that its
    # duration implies, and the critical speed of its drum, n_c = sqrt(g / (R - r)) / (2 pi)
    for speed in (0.5, 1.0):
        ds = read_case(workdir / case("ballmill", speed))
        params = case_parameters(ds)
        assert params["n_over_nc"] == speed and params["drum_radius"] == 0.02 and params["seed"] == 3
        assert ds.attrs["steps"] == round(0.02 / ds.attrs["dt"])
        assert float(ds["n_c"]) == pytest.approx(math.sqrt(9.81 / (0.02 - 0.002)) / (2 * math.pi), rel=1e-12)

    assert snakemake(workdir, tiny_config([0.5, 1.0])) == set()

    rerun = snakemake(workdir, tiny_config([0.5, 1.5]))
    cases = {f for f in rerun if f.startswith("results/cases/")}
    assert cases == {case("ballmill", 1.5)}
    assert "results/aggregate/ballmill.nc" in rerun
    assert "results/aggregate/ballmill_forcechain.nc" not in rerun
    assert speeds(workdir) == [0.5, 1.5]


@pytest.mark.parametrize("path, value, named", [
    (("colour",), "red", "colour"),
    (("ballmill", "speeds"), [1.0], "speeds"),
    (("ballmill", "parameters", "n_over_nc"), [0.5, 0.0], "n_over_nc"),
    (("ballmill", "parameters", "n_over_nc"), -1.0, "n_over_nc"),
    (("ballmill", "forcechain", "n_over_nc"), [], "n_over_nc"),
    (("ballmill", "parameters", "filling"), 0.0, "filling"),
    (("ballmill", "parameters", "filling"), 1.0, "filling"),
    (("ballmill", "animation", "filling"), [0.3, 1.2], "filling"),
    (("ballmill", "parameters", "fragmentation"), False, "fragmentation"),
    # not in the schema: the scene's own declaration refuses it, still before any job
    (("ballmill", "parameters", "grain_radiuss"), 0.001, "grain_radiuss"),
    # these used to pass the dry run and fail inside the jobs
    (("ballmill", "parameters", "n_over_nc"), [0.5, 1.0, 0.5], "n_over_nc: 0.5 repeats"),
    (("ballmill", "parameters", "dt"), 1e-3, "dt: 0.001 s exceeds the stability limit"),
    (("ballmill", "parameters", "n_grains"), 10**12, "n_grains: 1000000000000 particles need"),
    (("ballmill", "parameters", "grain_radius"), 0.05, "grain_radius: the largest grain"),
])
def test_bad_config_is_refused_before_any_job(workdir, path, value, named):
    config = tiny_config([0.5, 1.0])
    *parents, key = path
    block = config
    for name in parents:
        block = block[name]
    block[key] = value
    with pytest.raises(Exception) as refused:
        snakemake(workdir, config, dryrun=True)
    # named in the message or the location, not merely in Snakemake's excerpt of the schema
    text = str(refused.value)
    where = text.split("Failed validating")[0] + "".join(re.findall(r"On instance\S*", text))
    assert named in where
    assert not (workdir / "results").exists()


SINGLE_PARTICLE = {
    "probability": {"mode": "single", "material": ["copper_ore"], "energy_ratio": [1.0]},
    "repeated": {"material": "copper_ore", "gamma": [5.0]},
    "fragmentation": {"mode": "single", "material": ["copper_ore"], "energy_ratio": [2.0]},
}


@pytest.mark.parametrize("edit, message", [
    # the material names are the materials file's, not the schema's
    ({"single_particle": {"probability": {"material": ["copper_ore", "my_ore"]}}},
     "config single_particle.probability: material: 'my_ore' not in config/materials.yaml; "
     "known: copper_ore, granulite, limestone"),
    ({"materials_file": "config/nosuch.yaml"},
     "config single_particle.probability: config/nosuch.yaml: materials file not found"),
    # one materials file for every case: the top-level key, not a scene parameter
    ({"single_particle": {"parameters": {"materials_file": "config/materials.yaml"}}},
     "materials_file"),
])
def test_materials_are_checked_against_the_file_before_any_job(workdir, edit, message):
    config = {**tiny_config([0.5]), "single_particle": copy.deepcopy(SINGLE_PARTICLE)}
    for key, value in edit.items():
        if isinstance(value, dict):
            for block, entries in value.items():
                config[key].setdefault(block, {}).update(entries)
        else:
            config[key] = value
    with pytest.raises(Exception) as refused:
        snakemake(workdir, config, dryrun=True)
    assert message in str(refused.value).split("Failed validating")[0]
    assert not (workdir / "results").exists()


def test_every_rule_calls_millsim():
    """One front door: the shell command of every rule is a `millsim` command."""
    rules = [*sorted((ROOT / "workflow" / "rules").glob("*.smk")), ROOT / "Snakefile"]
    commands = [(path.name, m.group(1)) for path in rules
                for m in re.finditer(r'shell:\s*\n\s*f?"([^"]*)"', path.read_text())]
    assert len(commands) >= 15
    wrong = [f"{name}: {cmd}" for name, cmd in commands if not cmd.startswith("millsim ")]
    assert not wrong, "\n".join(wrong)
    assert not any("python" in path.read_text() for path in rules if path.suffix == ".smk")


@pytest.mark.parametrize("scene, own, other", [
    ("stirred_mill", "results/aggregate/stirred_mill.nc", "ballmill"),
    ("ballmill3d", "results/aggregate/ballmill3d.nc", "stirred_mill"),
    ("ballmill", "results/aggregate/ballmill.nc", "stirred_mill"),
    ("bed_impact", "results/aggregate/bed_breakage.nc", "tavares"),
    ("single_particle", "results/aggregate/tavares_verification.nc", "bed_"),
])
def test_one_scene_target_plans_that_scene_only(workdir, monkeypatch, scene, own, other):
    """`snakemake <scene>` (the README's 'run one scene'): the shipped config's jobs of that
    scene, none of another's."""
    updated = []
    output = settings.OutputSettings(dryrun=True, quiet={settings.Quietness.ALL})
    with api.SnakemakeApi(output) as sm:
        workflow = sm.workflow(resource_settings=settings.ResourceSettings(cores=2),
                               snakefile=workdir / "Snakefile", workdir=workdir)
        workflow.dag(settings.DAGSettings(targets={scene})).execute_workflow(
            executor="dryrun", updated_files=updated)
    planned = {str(Path(f)) for f in updated}
    assert own in planned
    assert not [f for f in planned if other in f]


def test_slurm_profile_sizes_every_simulate_rule():
    """SLURM as written: every case rule gets threads and a wall-time limit (else the plugin's
    30-minute default kills the paper-scale cases), threads fit a 2-CPU node, the status check
    does not need an accounting database."""
    profile = yaml.safe_load((ROOT / "profiles" / "slurm" / "profile.yaml").read_text())
    text = "\n".join(p.read_text() for p in (ROOT / "workflow" / "rules").glob("*.smk"))
    simulate = set(re.findall(r"rule (simulate_\w+):", text))
    simulate |= set(re.findall(r"use rule \w+ as (simulate_\w+)", text))
    assert {"simulate_ballmill", "simulate_stirred_mill", "simulate_bed_impact"} <= simulate
    assert simulate <= set(profile["set-threads"])
    assert all(1 <= n <= 2 for n in profile["set-threads"].values())
    limits = profile["set-resources"]
    assert all(limits[rule]["runtime"] > profile["default-resources"]["runtime"]
               for rule in simulate)
    assert profile["slurm-status-command"] == "squeue"
