"""Restartable cases: a case killed (SIGKILL) after a checkpoint and run again by the same command,
by hand or by Snakemake, resumes from its checkpoint and writes the case file of an uninterrupted
run; a checkpoint of other parameters or code is not used; none is left once the case is written.

The case: a small ball mill with Weibull fragmentation, killed once its checkpoint holds fractures,
so that what the resumed run continues includes the breakage model's state (twin pairs, peak
forces, the split generator, dust awaiting refill) as well as contacts, Gear history and the drum.
"""

import contextlib
import errno
import io
import os
import shlex
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import millsim.io
import millsim.util.checkpoint
from millsim.cli import main
from millsim.io import read_case, read_checkpoint, write_checkpoint
from millsim.models.contact import LAWS
from millsim.scenes.base import get_scene
from millsim.scenes.driver import Checkpoint

# 0.1 s of a 2 cm drum: ~260 grains, 21162 Gear steps in 20 chunks, fractures from the second on
SETS = {"drum_radius": "0.02", "grain_radius": "0.002", "filling": "0.3", "duration": "0.1",
        "transient": "0.02", "record_interval": "0.005", "snapshot_interval": "0.01",
        "weibull_c": "1e-4", "seed": "3"}
RUN = ["run", "ballmill2d", *(f"--set={k}={v}" for k, v in SETS.items())]
SCENE = get_scene("ballmill2d")
VALUES = SCENE.resolve(SETS)
# what may differ between two runs of one case: how long they took, and when (and by which
# command line) the file was written
TIMING = {"wall_time_s", "compute_seconds", "created_utc", "history", "resumed_at_steps"}


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    """The reference case file, of a run whose checkpoint saves, one after every chunk, all fail
    on a full disk: each says so in one line, leaves no file, and the run goes on."""
    out = tmp_path_factory.mktemp("uninterrupted") / "case.nc"

    def disk_full(path, *_):
        with open(path, "wb") as fh:
            fh.write(b"partial")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    err = io.StringIO()
    with pytest.MonkeyPatch.context() as mp, contextlib.redirect_stderr(err):
        mp.setattr(millsim.util.checkpoint, "write", disk_full)
        assert main([*RUN, "--checkpoint-every", "1e-9", "--out", str(out), "--quiet"]) == 0
    lines = err.getvalue().splitlines()
    saying = f"[millsim] checkpoint not saved: cannot write {out}.ckpt: disk full (no space left"
    assert len(lines) > 10 and all(line.startswith(saying) for line in lines)
    assert all(line.endswith("; the run goes on without it, next try in 1e-09 s") for line in lines)
    assert os.listdir(out.parent) == ["case.nc"]
    return read_case(out)


def assert_same_case(a, b):
    """Every variable and coordinate exactly equal (NaN where NaN); attributes equal but timing."""
    assert set(a.variables) == set(b.variables)
    for name in a.variables:
        assert a[name].dims == b[name].dims, name
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
        assert a[name].attrs == b[name].attrs, name
    for key in (a.attrs.keys() | b.attrs.keys()) - TIMING:
        np.testing.assert_array_equal(a.attrs.get(key), b.attrs.get(key), err_msg=key)


def kill_once_it_broke(proc, ckpt, pid):
    """SIGKILL process ``pid`` as soon as the checkpoint at ``ckpt`` holds a fracture; the state
    of the checkpoint it left behind."""
    deadline = time.monotonic() + 600
    while True:
        assert proc.poll() is None, "the run ended before its checkpoint held a fracture"
        assert time.monotonic() < deadline, "no checkpoint with a fracture within 10 min"
        try:
            if read_checkpoint(ckpt, {"scene": SCENE.name, "parameters": VALUES})["case"].split.events:
                break
        except FileNotFoundError:
            pass
        time.sleep(0.02)
    os.kill(pid(), signal.SIGKILL)
    proc.wait()
    return read_checkpoint(ckpt, {"scene": SCENE.name, "parameters": VALUES})


def test_a_killed_run_resumes_from_its_checkpoint_to_the_same_case_file(tmp_path, capsys,
                                                                        uninterrupted):
    out, ckpt = tmp_path / "case.nc", tmp_path / "case.nc.ckpt"
    command = [*RUN, "--checkpoint-every", "1e-9", "--out", str(out), "--quiet"]
    started = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "millsim.cli", *command],
                            stderr=subprocess.DEVNULL)
    state = kill_once_it_broke(proc, ckpt, lambda: proc.pid)
    assert proc.returncode == -signal.SIGKILL and not out.exists()
    assert 0 < state["steps_total"] < uninterrupted.attrs["steps"]
    # the run's wall time so far, within the time the process lived
    assert 0 < state["wall_time_s"] < time.monotonic() - started
    broken = len(state["case"].split.events)

    # the checkpoint of other parameters is not used, and is gone once that case is written
    other = tmp_path / "other.nc"
    shutil.copy(ckpt, f"{other}.ckpt")
    assert RUN[-1] == "--set=seed=3"  # replaced, not given twice (that is refused)
    assert main([*RUN[:-1], "--set=seed=4", "--out", str(other), "--quiet"]) == 0
    assert (f"[millsim] ignoring checkpoint {other}.ckpt: written under another parameter seed; "
            "starting from step 0") in capsys.readouterr().err
    assert read_case(other).attrs["resumed_at_steps"] == ""
    assert not os.path.exists(f"{other}.ckpt")

    resuming = time.monotonic()
    assert main(command) == 0
    resume_took = time.monotonic() - resuming
    assert f"resuming from {ckpt} at step {state['steps_total']}" in capsys.readouterr().err
    assert not ckpt.exists()
    resumed = read_case(out)
    # the case's wall time: the killed run's up to its checkpoint, then the resumed run's
    assert state["wall_time_s"] < resumed.attrs["wall_time_s"] <= state["wall_time_s"] + resume_took
    assert resumed.attrs["resumed_at_steps"] == str(state["steps_total"])
    assert int(resumed["fracture_events"][-1]) > broken  # it broke before and after the kill
    assert_same_case(uninterrupted, resumed)


def test_snakemake_reruns_a_killed_case_and_it_resumes(tmp_path, uninterrupted):
    """A job killed under Snakemake fails; Snakemake removes its declared output (there is none
    yet: the case file is written atomically at the end) but not the checkpoint, and the next
    `snakemake` runs the same command, which resumes."""
    command = shlex.join([sys.executable, "-m", "millsim.cli", *RUN, "--checkpoint-every", "1e-9"])
    shell = f"echo $$ > job.pid; exec {command} --out {{output}} > {{log}} 2>&1"
    (tmp_path / "Snakefile").write_text(
        f"rule case:\n    output: 'case.nc'\n    log: 'case.log'\n    shell: {shell!r}\n")
    snakemake = [sys.executable, "-m", "snakemake", "--cores", "1", "--directory", str(tmp_path),
                 "--snakefile", str(tmp_path / "Snakefile")]
    proc = subprocess.Popen(snakemake, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    state = kill_once_it_broke(proc, tmp_path / "case.nc.ckpt",
                               lambda: int((tmp_path / "job.pid").read_text()))
    assert proc.returncode != 0 and not (tmp_path / "case.nc").exists()
    assert (tmp_path / "case.nc.ckpt").exists()

    rerun = subprocess.run(snakemake, capture_output=True, text=True)
    assert rerun.returncode == 0, rerun.stderr
    assert f"resuming from case.nc.ckpt at step {state['steps_total']}" in \
        (tmp_path / "case.log").read_text()
    assert not (tmp_path / "case.nc.ckpt").exists()
    assert_same_case(uninterrupted, read_case(tmp_path / "case.nc"))


def test_a_checkpoint_of_other_code_or_no_checkpoint_at_all_is_ignored(tmp_path, capsys,
                                                                       monkeypatch):
    out = tmp_path / "case.nc"
    checkpoint = Checkpoint(out, SCENE, VALUES, every=0)
    checkpoint.save({"steps_total": 7})
    assert Checkpoint(out, SCENE, VALUES, every=0).load() == {"steps_total": 7}
    software = millsim.io._software_attrs
    monkeypatch.setattr(millsim.io, "_software_attrs",
                        lambda: {**software(), "engine_hash": "0" * 12})
    checkpoint.save({"steps_total": 7})
    monkeypatch.undo()
    assert Checkpoint(out, SCENE, VALUES, every=0).load() is None
    assert "written under another engine_hash; starting from step 0" in capsys.readouterr().err
    checkpoint.path.write_bytes(b"not a pickle")
    assert Checkpoint(out, SCENE, VALUES, every=0).load() is None
    assert f"ignoring checkpoint {checkpoint.path}: not a checkpoint" in capsys.readouterr().err


def test_compiled_functions_are_refused_and_a_failed_write_leaves_nothing(tmp_path):
    path = tmp_path / "case.nc.ckpt"
    with pytest.raises(TypeError, match="compiled code is rebuilt on load, never saved"):
        write_checkpoint(path, {}, {"law": LAWS["linear_hw"].force})
    assert list(tmp_path.iterdir()) == []
