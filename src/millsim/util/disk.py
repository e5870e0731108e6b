"""Free space and sizes on disk, for the writers' checks and messages (io, util.snapshots)."""

import os
from pathlib import Path


def free_bytes(path: str | os.PathLike[str]) -> int | None:
    """Free space [B] on the disk that holds ``path`` (or would: the nearest existing parent);
    None where the system cannot say (no statvfs)."""
    where = Path(path).absolute()
    while not where.exists() and where != where.parent:
        where = where.parent
    try:
        st = os.statvfs(where)
    except (OSError, AttributeError):  # no statvfs (Windows)
        return None
    return st.f_bavail * st.f_frsize


def format_bytes(n: float) -> str:
    """``n`` bytes for a message, in decimal units: 512 B, 3.2 MB."""
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.3g} {unit}"
        n /= 1000
    raise AssertionError
