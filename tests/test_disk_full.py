"""Writers on a full, read-only or refusing filesystem: each output is complete or absent, and the
command ends with one line naming the file and the cause, exit code 2, no traceback.

The filesystems are small tmpfs mounts made by the test, so they need root and a kernel that lets
this process mount (a container may not); elsewhere the tests are skipped with the reason. No
simulation runs: the cases are written directly, as `millsim run` writes them at its end.
"""

import errno
import os
import subprocess
import uuid

import numpy as np
import pytest
import xarray as xr
from test_plots import synthetic_case

from millsim import cli
from millsim.cli import main
from millsim.io import WriteError, atomic_target, write_case, write_netcdf


def _mount(path, options):
    path.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)],
                          capture_output=True, text=True)
    if done.returncode:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")


@pytest.fixture
def small_fs(tmp_path):
    """Mount a tmpfs of the given options (e.g. "size=256k") at a fresh directory; unmounted
    afterwards."""
    if not hasattr(os, "geteuid") or os.geteuid() != 0:
        pytest.skip("mounting a small filesystem needs root")
    mounted = []

    def mount(options="size=256k"):
        path = tmp_path / f"fs{len(mounted)}"
        _mount(path, options)
        mounted.append(path)
        return path

    yield mount
    for path in mounted:
        subprocess.run(["umount", "-l", str(path)], check=False)


def _fill(directory, leave=0):
    """Fill ``directory``'s filesystem but ``leave`` bytes."""
    st = os.statvfs(directory)
    size = st.f_bavail * st.f_frsize - leave
    with open(directory / "filler", "wb") as fh:
        fh.write(b"\0" * size)


def _dataset(nbytes):
    return xr.Dataset({"a": ("n", np.random.default_rng(0).random(nbytes // 8), {"units": "1"})},
                      attrs={"title": "test"})


def _one_line(err):
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def test_netcdf_larger_than_the_free_space_refused_before_writing(small_fs):
    fs = small_fs("size=256k")
    with pytest.raises(WriteError, match=r"cannot write .*a\.nc: disk full") as exc:
        write_netcdf(fs / "a.nc", _dataset(1_000_000))
    assert exc.value.errno == errno.ENOSPC
    assert "at least 1 MB needed" in str(exc.value)
    assert os.listdir(fs) == []


@pytest.mark.parametrize("leave", [0, 100_000], ids=["full", "nearly-full"])
def test_netcdf_failing_mid_write_says_disk_full(small_fs, leave, monkeypatch):
    """netCDF4 says "Permission denied" on a full disk and "NetCDF: HDF error" when it runs out
    mid-write; both are diagnosed as the disk full. The size check before writing is skipped
    (statvfs answers only the second time), as where the estimate was too low."""
    fs = small_fs("size=1m")
    _fill(fs, leave)
    calls = []
    statvfs = os.statvfs

    def late_statvfs(path):
        calls.append(path)
        if len(calls) == 1:
            raise OSError(errno.ENOSYS, "no statvfs")
        return statvfs(path)

    monkeypatch.setattr(os, "statvfs", late_statvfs)
    with pytest.raises(WriteError, match=r"cannot write .*a\.nc: disk full"):
        write_netcdf(fs / "a.nc", _dataset(400_000))
    assert os.listdir(fs) == ["filler"]


def test_python_writer_on_a_full_disk(small_fs):
    """A JSON or CSV writer (Python's own file writes) that runs out: one line, no file."""
    fs = small_fs("size=64k")
    _fill(fs, 4096)
    with pytest.raises(WriteError, match=r"cannot write .*out\.json: disk full"):
        cli._write_json(fs / "out.json", {"x": "y" * 200_000})
    assert os.listdir(fs) == ["filler"]


def test_no_inode_left(small_fs):
    fs = small_fs("size=1m,nr_inodes=2")
    (fs / "taken").touch()
    with pytest.raises(ValueError, match=r"cannot write .*a\.nc: .*No space left on device"):
        write_netcdf(fs / "a.nc", _dataset(1000))
    assert os.listdir(fs) == ["taken"]


def test_read_only_filesystem_refused_before_any_work(small_fs, tmp_path, capsys):
    fs = small_fs("size=1m,ro")
    cases = [synthetic_case(tmp_path / f"c{s}.nc", s) for s in (0.5, 1.0)]
    assert main(["aggregate", "ballmill2d", *map(str, cases), "--out", str(fs / "agg.nc")]) == 2
    line = _one_line(capsys.readouterr().err)
    assert f"cannot write {fs / 'agg.nc'}" in line and "Read-only file system" in line


def test_aggregate_on_a_full_disk(small_fs, tmp_path, capsys):
    fs = small_fs("size=64k")
    _fill(fs)
    cases = [synthetic_case(tmp_path / f"c{s}.nc", s) for s in (0.5, 1.0, 1.5)]
    assert main(["aggregate", "ballmill2d", *map(str, cases), "--out", str(fs / "agg.nc")]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(f"millsim: error: cannot write {fs / 'agg.nc'}: disk full")
    assert os.listdir(fs) == ["filler"]


def test_figure_on_a_full_disk(small_fs, tmp_path, capsys):
    fs = small_fs("size=64k")
    _fill(fs, 8192)
    cases = [synthetic_case(tmp_path / f"c{s}.nc", s) for s in (0.5, 1.0)]
    agg = tmp_path / "agg.nc"
    assert main(["aggregate", "ballmill2d", *map(str, cases), "--out", str(agg)]) == 0
    out = fs / "rate.png"
    assert main(["plot", "ballmill_rate", str(agg), "--out", str(out)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(f"millsim: error: cannot write {out}: disk full")
    assert os.listdir(fs) == ["filler"]


def test_case_write_on_a_full_disk_keeps_the_checkpoint(small_fs, monkeypatch, capsys):
    """`millsim run`'s final write (the simulation replaced by its result) on a full disk: one
    line, exit 2, no case file, and the checkpoint beside it is left for the re-run."""
    from millsim.scenes.base import Scene

    fs = small_fs("size=64k")
    out = fs / "case.nc"
    checkpoint = fs / "case.nc.ckpt"
    checkpoint.write_bytes(b"state")
    _fill(fs)

    def run(scene, values, ctx=None, out=None):
        write_case(out, _dataset(200_000), {"scene": scene.name, "parameters": values, "seed": 0,
                                            "dt": 1e-6, "steps": 10, "wall_time_s": 1.0})

    monkeypatch.setattr(Scene, "run", run)
    assert main(["run", "collision", "--out", str(out), "--quiet"]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(f"millsim: error: cannot write {out}: disk full")
    assert sorted(os.listdir(fs)) == ["case.nc.ckpt", "filler"]


def test_a_failure_that_is_not_the_filesystem_stays_itself(tmp_path):
    """A writer's own bug is not reported as a disk problem, and leaves no file."""
    with pytest.raises(RuntimeError, match="a bug"), atomic_target(tmp_path / "x.nc") as tmp:
        tmp.write_bytes(b"partial")
        raise RuntimeError("a bug")
    assert os.listdir(tmp_path) == []


def test_permission_from_errno_named(tmp_path, monkeypatch):
    """A write refused with EACCES where the directory has room (a file made read-only between
    the check and the write, or a quota) names the cause from the errno."""
    target = tmp_path / f"{uuid.uuid4().hex}.csv"
    with pytest.raises(WriteError, match=r"cannot write .*\.csv: disk quota exceeded"), \
            atomic_target(target):
        raise OSError(errno.EDQUOT, os.strerror(errno.EDQUOT))
    with pytest.raises(WriteError, match=r"cannot write .*\.csv: permission denied"), \
            atomic_target(target):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES))
    assert os.listdir(tmp_path) == []
