"""What the Snakefile needs from millsim besides the scenes: a study that resumes with the same
command after any interruption.

Snakemake locks its working directory while it runs and removes the lock when it ends, also on
Ctrl-C or SIGTERM. A run killed outright (SIGKILL, the OOM killer, a power loss, the end of a
session's machine) leaves the lock behind, and the same command then stops with "Directory cannot
be locked" until `snakemake --unlock` is run. A lock is stale when no Snakemake process on this
machine works in the directory; the Snakefile removes such a lock when it is read, which is before
Snakemake takes its own. Processes on other machines cannot be seen: a directory shared by two
hosts' Snakemake runs at the same time is not protected by this check (config `stale_locks:
keep` turns it off).
"""

from __future__ import annotations

import os
from pathlib import Path


def _snakemake_processes_in(directory, own):
    """Process ids of the Snakemake processes (other than ``own`` and its ancestors) whose
    working directory is ``directory`` (Linux /proc; none where it cannot be read)."""
    skip = set()
    pid = own
    while pid > 1:  # our ancestors: the shell or make that started us is no other run
        skip.add(pid)
        try:
            stat = Path(f"/proc/{pid}/stat").read_text()
        except OSError:
            break
        pid = int(stat.rsplit(")", 1)[1].split()[1])
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) in skip:
            continue
        try:
            command = (entry / "cmdline").read_bytes().split(b"\0")
            here = (entry / "cwd").resolve()
        except OSError:
            continue
        if here == directory and any(b"snakemake" in part for part in command[:3]):
            found.append(int(entry.name))
    return found


def remove_stale_locks(directory=".", own=None, say=print):
    """Remove Snakemake's lock files of ``directory`` when no other Snakemake process on this
    machine runs there; returns the files removed (none when a run is live or there is no
    lock)."""
    directory = Path(directory).resolve()
    locks = sorted((directory / ".snakemake" / "locks").glob("*.lock"))
    if not locks or not Path("/proc/self").exists():
        return []
    live = _snakemake_processes_in(directory, os.getpid() if own is None else own)
    if live:
        return []
    for lock in locks:
        lock.unlink(missing_ok=True)
    say(f"[millsim] removed the lock of a killed Snakemake run ({len(locks)} files in "
        f"{directory / '.snakemake' / 'locks'}; no Snakemake process runs here); resuming")
    return locks
