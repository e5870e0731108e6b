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


def is_snakemake(argv):
    """Whether a command line (a list of str) runs Snakemake: the ``snakemake`` script itself, a
    Python running it, or ``python -m snakemake``; a shell that merely names it in its command
    string (``sh -c "snakemake ..."``) does not (its child does, and is found on its own)."""
    names = [Path(a).name for a in argv[:3]]
    if not names:
        return False
    if names[0] == "snakemake":
        return True
    return names[0].startswith("python") and len(names) > 1 and (
        names[1] == "snakemake" or names[1:3] == ["-m", "snakemake"])


def _snakemake_processes_in(directory, own):
    """Process ids of the Snakemake processes other than ``own`` whose working directory is
    ``directory`` (Linux /proc; none where it cannot be read). A Snakemake that started ``own``
    (one that runs jobs by reading the Snakefile again) counts: its lock is live."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == own:
            continue
        try:
            argv = (entry / "cmdline").read_bytes().decode(errors="replace").split("\0")
            here = (entry / "cwd").resolve()
        except OSError:
            continue
        if here == directory and is_snakemake(argv):
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
