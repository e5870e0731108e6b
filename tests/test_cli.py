"""The command line: help, scene listing, a real run to a self-describing file, bad input, and the
analyses' bad input."""

import subprocess
import sys

import pytest

from millsim.cli import main
from millsim.io import case_parameters, read_case


def test_help_and_scenes(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--help"])
    assert exit_info.value.code == 0
    # one front door: every stage of the pipeline is a subcommand
    out = capsys.readouterr().out
    for command in ("scenes", "run", "info", "aggregate", "plot", "analyse"):
        assert command in out
    with pytest.raises(SystemExit) as exit_info:
        main(["analyse", "--help"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    for study in ("accuracy", "stirred-mill", "tavares"):
        assert study in out
    assert main(["scenes"]) == 0
    out = capsys.readouterr().out
    for scene in ("collision", "packing", "ballmill2d"):
        assert scene in out
    assert main(["scenes", "collision"]) == 0
    assert "restitution = 0.5 [1] (0, 1]" in capsys.readouterr().out


def test_run_writes_self_describing_case(tmp_path, capsys):
    out = tmp_path / "c.nc"
    assert main(["run", "collision", "--set", "contact_law=linear_hw", "--set", "dim=2",
                 "--out", str(out), "--quiet"]) == 0
    ds = read_case(out)
    assert ds.attrs["scene"] == "collision"
    assert case_parameters(ds)["contact_law"] == "linear_hw"
    for key in ("seed", "dt", "steps", "wall_time_s", "millsim_version", "engine_hash"):
        assert key in ds.attrs
    assert all("units" in ds[v].attrs for v in ds.variables)
    assert main(["info", str(out)]) == 0
    assert "restitution" in capsys.readouterr().out


@pytest.mark.parametrize("sets,needle", [
    (["foo=1"], "foo: unknown parameter"),
    (["radius=-1"], "radius: -1 is outside the allowed range (0, inf)"),
    (["density=0"], "density: 0 is outside the allowed range (0, inf)"),
    (["friction=-0.1"], "friction: -0.1 is outside the allowed range [0, inf)"),
    (["restitution=0"], "restitution: 0 is outside the allowed range (0, 1]"),
    (["restitution=1.2"], "restitution: 1.2 is outside the allowed range (0, 1]"),
    (["dt=1e-3"], "dt: 0.001 s exceeds the stability limit"),
])
def test_bad_input_one_line_nonzero_and_no_file(tmp_path, capsys, sets, needle):
    out = tmp_path / "bad.nc"
    args = ["run", "collision", "--out", str(out), "--quiet"]
    for item in sets:
        args += ["--set", item]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert needle in err
    assert len(err.splitlines()) == 1
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_unknown_scene_from_a_real_process(tmp_path):
    out = tmp_path / "x.nc"
    proc = subprocess.run([sys.executable, "-m", "millsim.cli", "run", "nosuchscene", "--out", str(out)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert "scene: unknown scene 'nosuchscene'" in proc.stderr
    assert not out.exists()


@pytest.mark.parametrize("args,needle", [
    (["analyse", "stirred-mill", "friction", "nosuch.nc", "--reference", "r.csv", "--table", "t.csv",
      "--summary", "s.csv", "--choice", "c.json"], "nosuch.nc"),
    (["analyse", "tavares", "aggregate", "nosuch.nc", "--out", "t.nc"], "nosuch.nc"),
    (["analyse", "accuracy", "aggregate", "nosuch.csv", "--out", "a.nc"], "nosuch.csv"),
])
def test_analyse_bad_input_one_line_and_no_file(tmp_path, monkeypatch, capsys, args, needle):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert needle in err and len(err.splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("container", ["box", "drum"])
def test_packing_case_file(tmp_path, container):
    out = tmp_path / "p.nc"
    # Three lattice layers in the box (one layer of 400 would have no contacts at all).
    assert main(["run", "packing", "--set", f"container={container}", "--set", "n=1200",
                 "--set", "settle_steps=3000", "--set", "spinup_steps=1000", "--set", "steps=1000",
                 "--set", "record_every=500", "--out", str(out), "--quiet"]) == 0
    ds = read_case(out)
    assert ds.attrs["scene"] == "packing" and ds.attrs["steps"] == 3000 + (1000 if container == "drum" else 0) + 1000
    assert float(ds.particle_steps_per_second) > 0
    assert (ds.contacts_per_particle > 0).all()
    if container == "drum":
        # The shell drives the charge: positive mean power into it.
        assert float(ds.shell_power) > 0
