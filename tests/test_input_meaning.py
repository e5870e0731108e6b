"""Inputs that would change what a result means are refused (issue 50, item 4): cases of two code
versions stacked, an STL liner that is not the drum, `liner` where the scene has no drum, a key
given twice, two outputs in one file, a reference table the calibration cannot use, and a config
path that would break (or inject into) a job's shell command. Each refusal: exit code 2 (or the
workflow refusing to load), one line naming the key or file, and no file written. No simulation
runs here."""

import json
import re
import shutil
from pathlib import Path

import pytest
import xarray as xr
import yaml
from snakemake import api
from snakemake.settings import types as settings
from test_bad_input import files, one_line, tiny_case

import millsim
from millsim.cli import main
from millsim.engine.mesh_io import box_mesh, liner_mesh, write_stl
from millsim.io import read_case, write_case

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "meshes" / "ballmill_liner.stl"


# ---- millsim aggregate: one code version per aggregate, recorded ------------------------------

@pytest.mark.parametrize("key, attr", [("engine_hash", "provenance_hash"),
                                       ("millsim_version", "__version__")])
def test_aggregate_refuses_cases_of_two_code_versions(tmp_path, monkeypatch, capsys, key, attr):
    monkeypatch.chdir(tmp_path)
    tiny_case(tmp_path / "new.nc")
    ours = read_case(tmp_path / "new.nc").attrs[key]
    old = "0ld" if attr == "__version__" else (lambda: "0ld")
    monkeypatch.setattr(millsim, attr, old)
    tiny_case(tmp_path / "old.nc", n_over_nc=0.5)
    before = files(tmp_path)
    assert main(["aggregate", "ballmill2d", "new.nc", "old.nc", "--out", "agg.nc"]) == 2
    assert one_line(capsys) == (
        f"millsim: error: {key}: {ours} in new.nc but 0ld in old.nc; cases of different code "
        "versions do not stack: run the older ones again")
    assert files(tmp_path) == before


def test_the_tavares_aggregate_refuses_cases_of_two_code_versions(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    tiny_case(tmp_path / "new.nc", scene="single_particle")
    ours = read_case(tmp_path / "new.nc").attrs["engine_hash"]
    monkeypatch.setattr(millsim, "provenance_hash", lambda: "0ld")
    tiny_case(tmp_path / "old.nc", scene="single_particle", seed=2)
    assert main(["analyse", "tavares", "aggregate", "new.nc", "old.nc", "--out", "t.nc"]) == 2
    assert one_line(capsys) == (
        f"millsim: error: engine_hash: {ours} in new.nc but 0ld in old.nc; cases of different "
        "code versions do not stack: run the older ones again")
    assert not (tmp_path / "t.nc").exists()


def test_an_aggregate_records_the_code_of_its_cases(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    tiny_case(tmp_path / "a.nc")
    tiny_case(tmp_path / "b.nc", n_over_nc=0.5)
    assert main(["aggregate", "ballmill2d", "a.nc", "b.nc", "--out", "agg.nc"]) == 0
    case, agg = read_case(tmp_path / "a.nc").attrs, read_case(tmp_path / "agg.nc").attrs
    assert agg["engine_hash"] == case["engine_hash"] == millsim.provenance_hash()
    assert agg["millsim_version"] == case["millsim_version"] == millsim.__version__


# ---- packing: the STL liner is the drum, and only where there is a drum -----------------------

def _liner(path, radius=0.1, length=0.05, center=(0.0, 0.0, 0.0)):
    """A plain liner (liner_mesh's axis z turned onto the scene's y by a rotation, (x, y, z) ->
    (y, z, x), which keeps the winding outward)."""
    v, f = liner_mesh(radius, length, segments=64, center=center)
    write_stl(path, v[:, [1, 2, 0]], f)
    return path


DRUM = ["container=drum", "drum_radius=0.1", "drum_length=0.05"]


@pytest.mark.parametrize("sets, needle", [
    # a valid solid 5 m beside the drum: the charge would fall out of the shell it replaces
    ([*DRUM, "liner=far.stl"], "liner: far.stl: does not enclose the drum's axis (x = z = 0): "
                               "360 of 360 rays from it meet no wall"),
    # a file in mm read as m: 1000 times the drum
    ([*DRUM, f"liner={EXAMPLE}", "liner_scale=1000"],
     "its shell lies 100 m from the axis but drum_radius is 0.1 m"),
    ([*DRUM, f"liner={EXAMPLE}", "liner_scale=1000"], "units? liner_scale is 1000 (1e-3: a file "
                                                      "in mm); the liner spans x [-110, 110]"),
    # drum_radius that is not the liner's: the lattice start would not be the liner's drum
    (["container=drum", "drum_length=0.05", f"liner={EXAMPLE}"],
     "its shell lies 0.1 m from the axis but drum_radius is 0.04 m"),
    ([*DRUM[:2], "drum_length=0.08", f"liner={EXAMPLE}"],
     "does not run along the drum's axis from y = 0 to drum_length = 0.08 m"),
    ([*DRUM, "liner=block.stl"], "liner: block.stl: the drum's axis (x = z = 0) lies inside the "
                                 "liner's solid"),
    ([*DRUM, "liner=beside.stl"], "liner: beside.stl: does not enclose the drum's axis"),
    # a liner where the scene has no drum was ignored, even a garbage file
    (["container=box", "liner=garbage.stl"],
     "liner: 'garbage.stl': container=box takes no liner (it replaces the shell of "
     "container=drum)"),
    (["container=drum", "liner_scale=0.001"], "liner_scale: 0.001 given without a liner"),
    (["container=drum", "liner=garbage.stl"], "garbage.stl: not readable as STL"),
])
def test_a_liner_that_is_not_the_drum_is_refused(tmp_path, monkeypatch, capsys, sets, needle):
    monkeypatch.chdir(tmp_path)
    _liner(tmp_path / "far.stl", center=(0.0, 5.0, 0.0))  # x = 5 m after the turn
    write_stl(tmp_path / "block.stl", *box_mesh((-0.11, 0.0, -0.11), (0.11, 0.05, 0.11)))
    write_stl(tmp_path / "beside.stl", *box_mesh((0.05, 0.0, -0.02), (0.07, 0.05, 0.02)))
    (tmp_path / "garbage.stl").write_text("not a mesh\n")
    before = files(tmp_path)
    args = [a for s in sets for a in ("--set", s)]
    assert main(["run", "packing", *args, "--out", "c.nc", "--quiet"]) == 2
    assert needle in one_line(capsys)
    assert files(tmp_path) == before


def test_a_liner_that_is_the_drum_is_accepted(tmp_path):
    from millsim.scenes.base import get_scene

    scene = get_scene("packing")
    values = scene.resolve(dict(container="drum", liner=str(EXAMPLE), drum_radius=0.1,
                                drum_length=0.05))
    assert values["liner"] == str(EXAMPLE)
    # within 5 %: a 64-gon's faces lie 0.12 % inside its circle, mm with liner_scale 1e-3
    mm = _liner(tmp_path / "mm.stl", radius=40.0, length=40.0)
    scene.resolve(dict(container="drum", liner=str(mm), liner_scale=1e-3, drum_radius=0.041))
    with pytest.raises(ValueError, match="drum_radius is 0.043 m"):
        scene.resolve(dict(container="drum", liner=str(mm), liner_scale=1e-3, drum_radius=0.043))


def test_a_thin_slice_of_a_large_mill_is_not_taken_for_a_unit_slip(tmp_path):
    """The liner of a slice of a large mill, in m (R = 1 m, 0.1 m long), with drum_radius set
    10 % off: refused for the radius without a hint at the units, which are right (the hint is
    for a liner a thousand times too large or small: tests above)."""
    from millsim.scenes.base import get_scene

    liner = _liner(tmp_path / "slice.stl", radius=1.0, length=0.1)
    with pytest.raises(ValueError, match="drum_radius is 1.1 m") as refused:
        get_scene("packing").resolve(dict(container="drum", liner=str(liner), drum_radius=1.1,
                                          drum_length=0.1))
    assert "units?" not in str(refused.value)


# ---- the command line: a key twice, two outputs in one file ------------------------------------

@pytest.mark.parametrize("args, needle", [
    (["run", "collision", "--set", "seed=1", "--set", "seed=2", "--out", "c.nc"],
     "--set: seed given twice ('1' and '2'); give it once"),
    (["run", "collision", "--set", "seed=1", "--set", " seed = 1", "--out", "c.nc"],
     "--set: seed given twice"),
    (["aggregate", "ballmill2d", "t.nc", "--over", "seed", "--over", "seed", "--out", "a.nc"],
     "over: seed given twice; give each parameter once"),
    (["analyse", "accuracy", "aggregate", "t.csv", "--method", "a=finest", "--method",
      "a=richardson", "--out", "a.nc"], "--method: a given twice"),
    (["report", "--json", "x", "--rst", "x"], "--rst: 'x' is also --json; give each output its "
                                              "own file"),
    (["report", "--json", "x", "--rst", "./sub/../x"], "--rst: './sub/../x' is also --json"),
    (["analyse", "stirred-mill", "friction", "c.nc", "--reference", "r.csv", "--table", "t.csv",
      "--summary", "s.csv", "--choice", "t.csv"], "--choice: 't.csv' is also --table"),
    (["analyse", "stirred-mill", "viscosity", "c.nc", "--reference", "r.csv", "--friction",
      "f.json", "--rpm", "2500", "--table", "t", "--choice", "t"], "--choice: 't' is also --table"),
    (["analyse", "accuracy", "aggregate", "t.csv", "--out", "a.nc", "--summary", "a.nc"],
     "--summary: 'a.nc' is also --out"),
])
def test_a_key_twice_or_two_outputs_in_one_file_are_refused(tmp_path, monkeypatch, capsys, args,
                                                            needle):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    (tmp_path / "t.csv").write_text("x\n1\n")
    tiny_case(tmp_path / "t.nc")
    before = files(tmp_path)
    assert main(args) == 2
    assert needle in one_line(capsys)
    assert files(tmp_path) == before


# ---- the workflow: reference tables before any job, quoted paths in every command -------------

def tiny_config(reference):
    """One ball-mill case of each study and a stirred-mill study of few points: loading and
    planning, not running, is tested."""
    return {
        "ballmill": {
            "parameters": {"n_over_nc": [0.5], "drum_radius": 0.02, "grain_radius": 0.002,
                           "filling": 0.3, "duration": 0.02, "transient": 0.01, "seed": 3,
                           "dt_factor": 1.0},
            "forcechain": {"n_over_nc": [1.0]},
            "animation": {"n_over_nc": 1.0, "duration": 0.015},
        },
        "stirred_mill": {
            "parameters": {"scale": 0.45, "slice": True, "revolutions": 4,
                           "transient_revolutions": 2, "seed": 1},
            "power": {"friction": 0.3, "eta": [0.0], "rpm": [2500]},
            "calibration": {"reference": reference, "friction": [0.3, 0.4], "rpm": [2500],
                            "eta_rpm": 2500, "eta": [0.03, 0.1]},
        },
    }


def snakemake(workdir, config, target, dryrun=True, **output):
    (workdir / "config" / "config.yaml").write_text(yaml.safe_dump(config))
    # mtime alone: the made-up cases of a test have no Snakemake metadata to compare
    dag = settings.DAGSettings(targets={target}, rerun_triggers={settings.RerunTrigger.MTIME})
    with api.SnakemakeApi(settings.OutputSettings(dryrun=dryrun, **output)) as sm:
        workflow = sm.workflow(resource_settings=settings.ResourceSettings(cores=2),
                               snakefile=workdir / "Snakefile", workdir=workdir)
        workflow.dag(dag).execute_workflow(executor="dryrun" if dryrun else "local")


SHIPPED = (ROOT / "config" / "reference" / "stirred_mill_power.csv").read_text()


@pytest.mark.parametrize("text, needle", [
    ("", "config/bad.csv: empty"),
    ("\x00\x01garbage\n", "config/bad.csv: missing column(s)"),
    (SHIPPED.splitlines()[0] + "\n", "config/bad.csv: no rows"),
    (SHIPPED.replace("2500,dry", "2000,dry"), "config/bad.csv: no row with fluid = 'dry' at a "
                                              "calibration speed [2500] rpm"),
])
def test_an_unusable_reference_table_is_refused_before_any_job(workdir, text, needle):
    (workdir / "config" / "bad.csv").write_text(text)
    with pytest.raises(Exception) as refused:
        snakemake(workdir, tiny_config("config/bad.csv"), "all", quiet={settings.Quietness.ALL})
    message = str(refused.value)
    assert "config stirred_mill: calibration: reference: " in message and needle in message
    assert not (workdir / "results").exists()


PREFORMATTED = {"params.sets", "params.over", "params.options", "params.args", "params.config",
                "threads"}  # argument lists built (and shlex-quoted) by the rules, and an integer


def test_every_value_in_a_shell_command_is_quoted():
    """Each placeholder of every rule's shell command has Snakemake's :q, but the argument lists
    the rules quote themselves (shlex) and the thread count."""
    rules = sorted((ROOT / "workflow" / "rules").glob("*.smk"))
    shells = [m.group(1) for path in rules
              for m in re.finditer(r'shell:\s*\n((?:\s*"[^"\n]*"\n)+)', path.read_text())]
    assert len(shells) >= 15
    fields = [f for shell in shells for f in re.findall(r"\{([^{}]*)\}", shell)]
    bare = sorted({f for f in fields if not f.endswith(":q") and f not in PREFORMATTED})
    assert not bare


def test_a_path_with_a_space_and_a_semicolon_reaches_the_command_quoted(workdir, capfd):
    """`snakemake -n -p` with a reference table at 'config/my ref;x.csv': every command that
    names it quotes it (the `;` would otherwise end the command there); then the calibration's
    first stage runs with it, on made-up cases."""
    shutil.copy(workdir / "config" / "reference" / "stirred_mill_power.csv",
                workdir / "config" / "my ref;x.csv")
    config = tiny_config("config/my ref;x.csv")
    snakemake(workdir, config, "results/report/summary.json", printshellcmds=True,
              quiet={settings.Quietness.PROGRESS})
    commands = [line for line in capfd.readouterr().err.splitlines() if "millsim " in line]
    named = [c for c in commands if "my ref" in c]
    assert len(named) == 4  # the three calibration stages and the report
    assert all("'config/my ref;x.csv'" in c for c in named)
    assert not [c for c in named if re.search(r"(?<!')config/my ref", c)]
    # plain paths are left as they are
    assert any("--out results/aggregate/stirred_mill.nc > " in c for c in commands)

    for friction in (0.3, 0.4):
        path = workdir / f"results/cases/stirred_mill/friction~{friction}/eta~0.0/rpm~2500/case.nc"
        path.parent.mkdir(parents=True)
        power = dict(net_power=1.255 + friction, net_power_ci=0.1, energy_balance_error=0.0)
        params = dict(friction=friction, eta=0.0, rpm=2500.0, seed=1)
        write_case(path, xr.Dataset({k: ((), v, {"units": "W"}) for k, v in power.items()}),
                   {"scene": "stirred_mill", "parameters": params, "seed": 1, "dt": 1e-5,
                    "steps": 10, "wall_time_s": 1.0})
    snakemake(workdir, config, "results/calibration/stirred_mill_friction.json", dryrun=False,
              quiet={settings.Quietness.ALL})
    choice = json.loads((workdir / "results/calibration/stirred_mill_friction.json").read_text())
    assert choice["friction"] == 0.3  # 1.555 W, the reference's dry power at 2500 rpm
