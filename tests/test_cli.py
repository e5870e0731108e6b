"""The command line: help, scene listing, a real run to a self-describing file, bad input, and the
analyses' bad input."""

import math
import subprocess
import sys

import pytest

import millsim
from millsim.cli import main
from millsim.io import case_parameters, read_case
from millsim.scenes.base import get_scene


def test_help_and_scenes(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--help"])
    assert exit_info.value.code == 0
    # one front door: every stage of the pipeline is a subcommand
    out = capsys.readouterr().out
    for command in ("scenes", "run", "info", "aggregate", "plot", "analyse", "report", "verdicts"):
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
    """A 2D linear_hw pair collision at a requested step, through the command line. The file holds
    that step, the step count its time record implies, every parameter as given, the software
    versions of this process, SI units by name, and the physics of the damped linear oscillator.

    Closed form (linear_hw of Buchholtz et al. 2000, ballmill.md section 5): relative overlap
    x'' = -w0^2 x - 2 beta x', w0^2 = k / m_eff, beta = gamma_N / 2, w = sqrt(w0^2 - beta^2);
    x = (v/w) e^(-beta t) sin(w t). The clipped force m_eff (w0^2 x + 2 beta x') reaches zero at
    w t_c = pi - atan2(2 beta w, w^2 - beta^2), where the separation speed is v e^(-beta t_c) (so
    e = exp(-beta t_c)); the largest overlap is at tan(w t) = w / beta. The contact end is
    interpolated between steps, an error of order dt / t_c = 1e-3; the overlap is sampled every
    step, error O((w dt)^2).
    """
    out = tmp_path / "c.nc"
    dt = 2e-7
    assert main(["run", "collision", "--set", "contact_law=linear_hw", "--set", "dim=2",
                 "--set", f"dt={dt}", "--out", str(out), "--quiet"]) == 0
    ds = read_case(out)
    assert ds.attrs["scene"] == "collision"
    assert ds.attrs["dt"] == dt and ds.attrs["seed"] == 0
    time = ds["time"].values
    assert ds.attrs["steps"] == len(time) - 1
    assert time[-1] == pytest.approx(ds.attrs["steps"] * dt, rel=1e-12)
    assert ds.attrs["wall_time_s"] > 0
    assert ds.attrs["millsim_version"] == millsim.__version__
    assert ds.attrs["engine_hash"] == millsim.provenance_hash()
    params = case_parameters(ds)
    # every parameter round-trips exactly: the two given and the defaults of the declaration
    assert params == {p.name: p.default for p in get_scene("collision").params} | {
        "contact_law": "linear_hw", "dim": 2, "dt": dt}
    units = {"time": "s", "overlap": "m", "normal_force": "N", "normal_velocity": "m s-1",
             "restitution": "1", "contact_time": "s", "restitution_analytic": "1",
             "contact_time_analytic": "s", "max_overlap": "m"}
    assert {v: ds[v].attrs["units"] for v in ds.variables} == units

    m_eff = 2500.0 * math.pi * 1e-3**2 * 0.01 / 2  # density pi r^2 thickness, reduced mass of twins
    w0 = math.sqrt(8e3 / m_eff)
    beta = 800.0 / 2
    w = math.sqrt(w0**2 - beta**2)
    t_c = (math.pi - math.atan2(2 * beta * w, w**2 - beta**2)) / w
    t_m = math.atan2(w, beta) / w
    assert float(ds["restitution_analytic"]) == pytest.approx(math.exp(-beta * t_c), rel=1e-12)
    assert float(ds["contact_time_analytic"]) == pytest.approx(t_c, rel=1e-12)
    assert float(ds["restitution"]) == pytest.approx(math.exp(-beta * t_c), rel=1e-3)
    assert float(ds["contact_time"]) == pytest.approx(t_c, rel=2 * dt / t_c)
    assert float(ds["max_overlap"]) == pytest.approx(math.exp(-beta * t_m) * math.sin(w * t_m) / w,
                                                     rel=1e-4)  # v = 1 m/s
    assert float(ds["normal_velocity"][0]) == pytest.approx(-1.0)  # approaching at the set speed

    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "restitution = 0.5" in text and "contact_law = linear_hw" in text


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
    drum = container == "drum"
    assert ds.attrs["scene"] == "packing" and ds.attrs["steps"] == 3000 + (1000 if drum else 0) + 1000
    # settling (and spin-up) at settle_dt = 1e-5 s, then the timed stage at dt = 1e-6 s
    assert ds.attrs["dt"] == 1e-6
    assert float(ds["time"][-1]) == pytest.approx((3000 + (1000 if drum else 0)) * 1e-5 + 1000 * 1e-6)
    # throughput = particle steps of the timed stage / its wall time
    assert float(ds.particle_steps_per_second) == pytest.approx(
        1200 * 1000 / float(ds.timed_wall_time), rel=1e-12)
    assert ds.particle_steps_per_second.attrs["units"] == "s-1"
    assert (ds.contacts_per_particle > 0).all()  # a bed lying on the floor touches itself
    if drum:
        # the shell's power is its drive torque (minus the charge's torque on it, about its y
        # axis) x its angular velocity 9.5 rad/s; and positive: the shell drives the charge
        assert float(ds.shell_power) == pytest.approx(-float(ds.shell_torque) * 9.5, rel=1e-9)
        assert float(ds.shell_power) > 0
        assert ds.shell_power.attrs["units"] == "W" and ds.shell_torque.attrs["units"] == "N m"
