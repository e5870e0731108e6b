"""The scripts in examples/ run as a user runs them, and a scene from outside the package
registers itself (``--scene-module``, the entry-point group ``millsim.scenes``).

Both examples use the physics of tests/test_wall_kinds.py (3D, walls, linear_history), so
they share its compiled step loop in the kernel cache; a handful of particles, under 10 s warm.
"""

import re
import subprocess
import sys
from pathlib import Path

import pytest

from millsim import scenes
from millsim.cli import main
from millsim.io import read_case
from millsim.scenes.base import REGISTRY, get_scene

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
MY_SCENE = EXAMPLES / "my_scene.py"


def run_example(*args):
    """A script of examples/ in a fresh Python, from the repository root, as the README has
    it."""
    done = subprocess.run([sys.executable, *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    return done


def number(pattern, text):
    found = re.search(pattern, text)
    assert found, f"{pattern!r} not in {text!r}"
    return float(found.group(1))


def test_simulation_by_hand_falls_and_rests_as_computed():
    """The script's own checks, read from what it prints: free fall to machine precision, and
    each sphere at rest one radius up less m g / k_n."""
    out = run_example(str(EXAMPLES / "simulation_by_hand.py")).stdout
    assert out.startswith("3 particles, dt = ")
    assert number(r"largest \|z - \(z0 - g t\^2/2\)\| = (\S+) m", out) < 1e-12
    assert number(r"largest \|z - \(R - m g / k_n\)\| = (\S+) m", out) < 1e-9
    assert number(r"largest speed (\S+) m/s", out) < 1e-6


@pytest.fixture
def no_user_scene():
    """Leave the registry as the other tests expect it (my_drop out of it), and the module
    unimported (a second load registers it again)."""
    yield
    REGISTRY.pop("my_drop", None)
    for name in [m for m in sys.modules if m.startswith("millsim_user_scene_")]:
        del sys.modules[name]


def test_scene_module_runs_a_users_scene(tmp_path, capsys, no_user_scene):
    """`millsim scenes/run/aggregate --scene-module FILE`: the scene is listed, described, run to
    a case file and stacked; an unknown module or file is one line and exit code 2."""
    module = ["--scene-module", str(MY_SCENE)]
    assert main(["scenes", *module]) == 0
    assert re.search(r"^my_drop +spheres dropped onto a floor", capsys.readouterr().out, re.M)
    assert main(["scenes", "my_drop", *module]) == 0
    assert "height = 0.008 [m] (0, inf)" in capsys.readouterr().out

    cases = []
    for n in (1, 2):
        cases.append(tmp_path / f"drop{n}.nc")
        assert main(["run", "my_drop", *module, "--set", f"n={n}", "--out", str(cases[-1])]) == 0
        err = capsys.readouterr().err
        # the end is an event (rest): no made-up percentage or ETA on the progress lines
        assert " % " not in err and "ETA" not in err
        assert re.search(r"my_drop: step \d+  \d particles  t = \S+ s simulated  \d+ s elapsed",
                         err), err
    # the same case again: its step loop is in memory, nothing is compiled, and nothing says so
    assert main(["run", "my_drop", *module, "--set", "n=2", "--out", str(tmp_path / "again.nc")]) == 0
    err = capsys.readouterr().err
    assert "particles" in err and "compiling" not in err, err
    ds = read_case(cases[-1], "my_drop")
    assert float(ds["rest_height"]) == pytest.approx(float(ds["rest_height_expected"]), abs=1e-9)
    assert 0.0 < float(ds["settle_time"]) < 2.0

    agg = tmp_path / "agg.nc"
    assert main(["aggregate", "my_drop", *module, *map(str, cases), "--over", "n",
                 "--out", str(agg)]) == 0
    assert main(["info", str(agg)]) == 0
    out = capsys.readouterr().out
    assert "aggregate: millsim my_drop: 2 cases stacked over n" in out and "n = 1, 2" in out

    assert main(["scenes", "--scene-module", "no_such_module_here"]) == 2
    assert "--scene-module: no module named 'no_such_module_here'" in capsys.readouterr().err
    assert main(["scenes", "--scene-module", str(tmp_path / "missing.py")]) == 2
    assert "missing.py: no such file" in capsys.readouterr().err


def test_entry_point_group_registers_an_installed_scene(monkeypatch, no_user_scene):
    """An installed package's entry point in group millsim.scenes is loaded with the built-in
    scenes; a broken one is named in one ValueError."""
    from importlib import metadata

    monkeypatch.syspath_prepend(str(EXAMPLES))
    monkeypatch.delitem(sys.modules, "my_scene", raising=False)
    found = metadata.EntryPoints([metadata.EntryPoint("my_drop", "my_scene", "millsim.scenes")])
    monkeypatch.setattr(scenes.metadata, "entry_points",
                        lambda group: found if group == "millsim.scenes" else [])
    monkeypatch.setattr(scenes, "_loaded_entry_points", False)
    REGISTRY.pop("my_drop", None)
    assert get_scene("my_drop").summary.startswith("spheres dropped onto a floor")

    broken = metadata.EntryPoints([metadata.EntryPoint("bad", "no_such_plugin", "millsim.scenes")])
    monkeypatch.setattr(scenes.metadata, "entry_points", lambda group: broken)
    monkeypatch.setattr(scenes, "_loaded_entry_points", False)
    with pytest.raises(ValueError, match=r"scene plugin 'bad' \(no_such_plugin, entry point group "
                                         r"millsim.scenes\): ModuleNotFoundError"):
        get_scene("collision")
    monkeypatch.setattr(scenes, "_loaded_entry_points", True)
