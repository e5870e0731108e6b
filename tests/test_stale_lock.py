"""A study killed outright resumes with the same command (issue 48, item 5): the lock Snakemake
leaves behind is removed when no Snakemake process on this machine runs in the directory, and
kept while one does."""

import os
import subprocess
import sys
import time
from pathlib import Path

from millsim.workflow import remove_stale_locks


def _locks(directory):
    locks = directory / ".snakemake" / "locks"
    locks.mkdir(parents=True)
    for name in ("0.input.lock", "0.output.lock"):
        (locks / name).write_text("results/x.nc\n")
    return locks


def test_a_lock_without_a_live_run_is_removed_and_said_in_one_line(tmp_path):
    locks = _locks(tmp_path)
    said = []
    removed = remove_stale_locks(tmp_path, say=said.append)
    assert sorted(p.name for p in removed) == ["0.input.lock", "0.output.lock"]
    assert list(locks.iterdir()) == []
    assert len(said) == 1 and "removed the lock of a killed Snakemake run" in said[0]
    assert remove_stale_locks(tmp_path, say=said.append) == [] and len(said) == 1


def test_a_lock_of_a_live_run_in_the_directory_is_kept(tmp_path):
    """A process whose command line names snakemake, working in the directory, holds it (a
    stand-in: python running a script called snakemake, which sleeps)."""
    locks = _locks(tmp_path)
    script = tmp_path / "snakemake"
    script.write_text("import time\ntime.sleep(60)\n")
    live = subprocess.Popen([sys.executable, str(script)], cwd=tmp_path)
    try:
        for _ in range(200):  # until it has exec'd (before, it has pytest's command line)
            if b"snakemake" in Path(f"/proc/{live.pid}/cmdline").read_bytes():
                break
            time.sleep(0.05)
        assert remove_stale_locks(tmp_path, say=print) == []
        assert len(list(locks.iterdir())) == 2
        # the same process in another directory does not hold this one
        other = tmp_path / "elsewhere"
        other.mkdir()
        _locks(other)
        assert len(remove_stale_locks(other, say=print)) == 2
    finally:
        live.kill()
        live.wait()
    assert len(remove_stale_locks(tmp_path, say=print)) == 2


def test_what_counts_as_a_snakemake_process():
    from millsim.workflow import is_snakemake

    assert is_snakemake(["/work/.venv/bin/snakemake", "--cores", "2"])
    assert is_snakemake(["/usr/bin/python3", "/work/.venv/bin/snakemake", "--cores", "2"])
    assert is_snakemake(["python3.11", "-m", "snakemake", "--target-jobs", "x"])
    # a shell that names it, an editor of the Snakefile, another Python program: no
    assert not is_snakemake(["/bin/bash", "-c", "snakemake --cores 2"])
    assert not is_snakemake(["vim", "snakemake/Snakefile"])
    assert not is_snakemake(["python3", "-m", "pytest", "snakemake"])
    assert not is_snakemake(["python3", "snakemake.py"])
    assert not is_snakemake([])


def test_the_snakemake_that_started_us_holds_its_lock(tmp_path):
    """A Snakemake that reads the Snakefile again in a child (to run a job) must not take its
    parent's live lock for a stale one."""
    locks = _locks(tmp_path)
    script = tmp_path / "snakemake"
    script.write_text(
        "import subprocess, sys\n"
        "from millsim.workflow import remove_stale_locks\n"
        "child = 'from millsim.workflow import remove_stale_locks; "
        "print(len(remove_stale_locks(\".\", say=lambda line: None)))'\n"
        "print(subprocess.run([sys.executable, '-c', child], capture_output=True, text=True)"
        ".stdout.strip())\n")
    out = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True,
                         text=True, env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "0" and len(list(locks.iterdir())) == 2
