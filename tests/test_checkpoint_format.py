"""The checkpoint format (millsim.util.checkpoint): a planted file runs nothing, a foreign header is
refused before the state is read, an object graph comes back with its shared references and
cycles, and a checkpoint that cannot be saved leaves no file and lets the run go on.

No simulation runs here: the graphs are built by hand from millsim's own classes (tests/
test_restart.py resumes a real case to the bit).
"""

import errno
import io
import json
import os
import pickle
import re
import sys
import zipfile

import numpy as np
import pytest

import millsim.io
from millsim.engine.state import Accumulators
from millsim.io import read_checkpoint, write_checkpoint
from millsim.scenes import base, load_module
from millsim.scenes.base import get_scene
from millsim.scenes.driver import Case, Checkpoint, Series
from millsim.util import checkpoint

SCENE = get_scene("ballmill2d")
VALUES = SCENE.resolve({"seed": "3"})
KEY = {"scene": SCENE.name, "parameters": VALUES}


class Planted:
    """Pickles to a call of os.system: what an attacker would plant."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return os.system, (f"touch {self.marker}",)


def plant_zip(path, tree, header=None, members=()):
    """A zip laid out as a checkpoint: ``header`` (default: the one this process would write for
    KEY), ``tree`` as state.json and extra ``members`` (name, bytes)."""
    header = {"format": checkpoint.FORMAT, "version": checkpoint.VERSION,
              **(header or millsim.io._checkpoint_header(KEY))}
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr(checkpoint.HEADER, json.dumps(header))
        for name, data in members:
            zf.writestr(name, data)
        zf.writestr(checkpoint.STATE, json.dumps(tree))


def load(tmp_path, capsys):
    """What the driver would resume from, and the one line it said."""
    state = Checkpoint(tmp_path / "case.nc", SCENE, VALUES, every=0).load()
    err = capsys.readouterr().err
    assert err.count("\n") <= 1, err
    return state, err


def evil_npy(marker):
    """An .npy member of an object array whose pickle calls os.system."""
    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, np.array([Planted(marker)], dtype=object), allow_pickle=True)
    return buffer.getvalue()


@pytest.mark.parametrize("plant", ["pickle", "os.system", "builtins.eval", "re-export",
                                   "method", "npy"])
def test_a_planted_checkpoint_runs_nothing_and_is_ignored(tmp_path, capsys, plant):
    marker, ckpt = tmp_path / "ran", tmp_path / "case.nc.ckpt"
    system = {"t": "object", "id": 0, "class": "os:system",
              "state": {"t": "tuple", "id": 1, "items": [f"touch {marker}"]}}
    if plant == "pickle":  # the old format's file: the attack of issue 50
        ckpt.write_bytes(pickle.dumps(KEY) + pickle.dumps(Planted(marker)))
    elif plant == "os.system":
        plant_zip(ckpt, {"t": "dict", "id": 2, "items": [["case", system]]})
    elif plant == "builtins.eval":
        plant_zip(ckpt, {"t": "class", "name": "builtins:eval"})
    elif plant == "re-export":  # a millsim module's name for a function it imported
        plant_zip(ckpt, {"t": "class", "name": "millsim.util.checkpoint:os.system"})
    elif plant == "method":  # a function of a str bound as a method
        plant_zip(ckpt, {"t": "method", "self": f"touch {marker}", "name": "format"})
    else:
        plant_zip(ckpt, {"t": "array", "id": 0, "member": "arrays/0.npy"},
                  members=[("arrays/0.npy", evil_npy(marker))])
    state, err = load(tmp_path, capsys)
    assert state is None and not marker.exists()
    reason = "unreadable (ValueError: Object arrays cannot be loaded" if plant == "npy" else \
        "not a checkpoint"
    assert err.startswith(f"[millsim] ignoring checkpoint {ckpt}: {reason}"), err
    assert err.rstrip().endswith("starting from step 0")


@pytest.mark.parametrize("name", ["millsim.cli:main", "millsim.io:WriteError", "millsim:LAYERS",
                                  "millsim.engine.state:np", "millsim.engine.nowhere:X",
                                  "millsim.engine..state:Accumulators", "os.path:join"])
def test_only_classes_of_the_physics_layers_are_named(tmp_path, capsys, name):
    plant_zip(tmp_path / "case.nc.ckpt", {"t": "object", "id": 0, "class": name,
                                           "state": {"t": "dict", "id": 1, "items": []}})
    state, err = load(tmp_path, capsys)
    assert state is None and ": not a checkpoint (" in err and name in err


@pytest.mark.parametrize("header, differ", [
    ({"engine_hash": "0" * 12}, "engine_hash"),
    ({"numpy_version": "1.0"}, "numpy_version"),
    ({"parameters": {**VALUES, "seed": 4}}, "parameter seed"),
    ({"scene": "silo"}, "scene"),
])
def test_a_foreign_header_is_refused_before_the_state_is_read(tmp_path, capsys, monkeypatch,
                                                              header, differ):
    plant_zip(tmp_path / "case.nc.ckpt", {"t": "class", "name": "builtins:eval"},
              header={**millsim.io._checkpoint_header(KEY), **header})
    monkeypatch.setattr(checkpoint._Reader, "decode", lambda *_: pytest.fail("the state was read"))
    state, err = load(tmp_path, capsys)
    assert state is None and f": written under another {differ}; starting from step 0" in err


def test_a_header_of_another_format_version_or_none_is_refused(tmp_path, capsys):
    ckpt = tmp_path / "case.nc.ckpt"
    plant_zip(ckpt, None, header={**millsim.io._checkpoint_header(KEY), "version": 99})
    state, err = load(tmp_path, capsys)
    assert state is None and "not a checkpoint of this version (format version 99, this " \
        "millsim reads 1)" in err
    with zipfile.ZipFile(ckpt, "w") as zf:
        zf.writestr("other.json", "{}")
    assert load(tmp_path, capsys)[1].endswith(": not a checkpoint (no header); starting from "
                                              "step 0\n")


def graph():
    """Millsim objects with shared references, a cycle, object keys and every leaf type."""
    a, b = Case(), Case()
    shared = np.arange(6.0).reshape(2, 3)
    series = Series("mass", "kg", "mass")
    a.other, b.other = b, a  # a cycle through two objects
    a.shared, b.shared = shared, shared
    a.view_of_self = [a]
    a.by_object = {b: "b", series: (shared, shared)}
    a.rng = b.rng = np.random.default_rng(7)
    a.method = b.chunk  # a bound method of an object still being read
    a.kind = Series
    a.counts = Accumulators(np.zeros(4, dtype=np.int64), np.ones(2, dtype=np.int32), shared, [])
    a.leaves = [None, True, 2**100, -0.0, float("nan"), float("inf"), "s", np.float32(1.5),
                np.int64(-3), np.bool_(True), np.zeros((0, 3)), np.asfortranarray(shared)]
    return {"case": a, "steps_total": 11, "resumed_at_steps": [3, 7]}


def test_an_object_graph_comes_back_with_its_references_and_cycles(tmp_path):
    path = tmp_path / "case.nc.ckpt"
    state = graph()
    write_checkpoint(path, KEY, state)
    back = read_checkpoint(path, KEY)
    a = back["case"]
    b = a.other
    assert type(a) is Case and type(b) is Case and b.other is a and a.view_of_self[0] is a
    assert a.shared is b.shared and a.rng is b.rng and a.counts.dissipation is a.shared
    (key_b, key_series), values = a.by_object.keys(), list(a.by_object.values())
    assert key_b is b and key_series == Series("mass", "kg", "mass") and values[0] == "b"
    assert values[1][0] is values[1][1] is a.shared
    assert a.method.__self__ is b and a.method.__func__ is Case.chunk and a.kind is Series
    assert type(a.counts) is Accumulators and a.counts.n_events == []
    np.testing.assert_array_equal(a.shared, state["case"].shared)
    for got, want in zip(a.leaves, state["case"].leaves, strict=True):
        assert type(got) is type(want)
        np.testing.assert_array_equal(got, want)
    assert str(a.leaves[3]) == "-0.0" and a.leaves[11].flags.f_contiguous
    assert back["resumed_at_steps"] == [3, 7] and back["steps_total"] == 11
    # written again, the read graph gives the same file contents: nothing was lost on the way
    again = tmp_path / "again.ckpt"
    write_checkpoint(again, KEY, back)
    with zipfile.ZipFile(path) as one, zipfile.ZipFile(again) as two:
        assert one.namelist() == two.namelist()
        assert all(one.read(n) == two.read(n) for n in one.namelist() if n != checkpoint.HEADER)
    assert a.rng.random(3).tolist() == state["case"].rng.random(3).tolist()


@pytest.mark.parametrize("value, what", [
    (lambda: 0, "builtins.function"),
    (open, "builtins.builtin_function_or_method"),
    (np.array([object()]), "an array of Python objects"),
    (np.random.RandomState(1), "numpy.random.mtrand.RandomState"),
    (zipfile.ZipFile, "the class zipfile.ZipFile"),
    ({1, 2}.__iter__(), "builtins.set_iterator"),
])
def test_what_the_writer_does_not_know_is_a_type_error_naming_where(tmp_path, value, what):
    case = Case()
    case.f = [value]
    with pytest.raises(TypeError, match=re.escape(f"checkpoint: state['case'].f[0] is {what}")):
        write_checkpoint(tmp_path / "case.nc.ckpt", KEY, {"case": case})
    assert list(tmp_path.iterdir()) == []


def test_a_failed_save_leaves_no_file_says_one_line_and_waits_for_the_next_due_time(
        tmp_path, capsys, monkeypatch):
    out = tmp_path / "case.nc"
    written = checkpoint.write

    def disk_full(path, *_):
        with open(path, "wb") as fh:
            fh.write(b"partial")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(checkpoint, "write", disk_full)
    saver = Checkpoint(out, SCENE, VALUES, every=3600)
    saver.save({"steps_total": 7})  # does not raise
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(
        f"[millsim] checkpoint not saved: cannot write {saver.path}: disk full"), err
    assert "the run goes on without it, next try in 3600 s" in err
    assert list(tmp_path.iterdir()) == [] and not saver.due()

    monkeypatch.setattr(checkpoint, "write", written)
    saver.save({"steps_total": 8})
    assert saver.path.exists() and Checkpoint(out, SCENE, VALUES, 0).load() == {"steps_total": 8}


USER_SCENE = '''
from millsim.scenes.base import Scene, register
from millsim.scenes.driver import Case


class Helper:
    pass


class TinyCase(Case):
    def __init__(self, values):
        super().__init__()
        self.helper = Helper()
        self.helper.case = self


register(Scene("tiny_user_scene", "a user's scene of no physics", (), TinyCase))
'''


def test_a_scene_from_outside_millsim_keeps_its_classes_in_its_checkpoint(tmp_path, capsys,
                                                                          monkeypatch):
    """A --scene-module (or plugin) scene's Case lives in its own package: its classes may be
    named, looked up among the modules already imported, never imported by the checkpoint."""
    monkeypatch.setattr(base, "REGISTRY", dict(base.REGISTRY))  # the other tests never see it
    (tmp_path / "tiny.py").write_text(USER_SCENE)
    module = load_module(str(tmp_path / "tiny.py"))
    monkeypatch.setitem(sys.modules, module.__name__, module)  # removed again after the test
    scene = get_scene("tiny_user_scene")
    saver = Checkpoint(tmp_path / "case.nc", scene, {}, every=0)
    assert saver.packages == (module.__name__,)
    saver.save({"case": scene.build({})})
    case = saver.load()["case"]
    assert type(case) is module.TinyCase and case.helper.case is case
    assert type(case.helper) is module.Helper
    # read as a checkpoint of a millsim scene: the user's classes are not allowed
    with pytest.raises(ValueError, match=f"not a checkpoint \\(class {module.__name__}:TinyCase "
                                         "is not millsim's"):
        read_checkpoint(saver.path, saver.key)
    plant_zip(saver.path, {"t": "class", "name": f"{module.__name__}.sub:Helper"},
              header=millsim.io._checkpoint_header(saver.key))
    assert saver.load() is None and f"no class {module.__name__}.sub:Helper" in \
        capsys.readouterr().err
