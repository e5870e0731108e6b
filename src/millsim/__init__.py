"""millsim: a numba DEM engine and Snakemake pipeline for mill and breakage parameter studies."""

import hashlib
from functools import lru_cache
from importlib import metadata
from pathlib import Path

try:
    __version__ = metadata.version("millsim")
except metadata.PackageNotFoundError:  # running from a source tree without install
    __version__ = "0.0.0+src"


@lru_cache(maxsize=1)
def provenance_hash() -> str:
    """Short hash of every source file of the package.

    The pipeline passes it as a rule parameter so that a change of the engine re-runs cached cases
    (Snakemake's own code trigger only sees the rule's script, not imported modules).
    """
    digest = hashlib.sha256()
    root = Path(__file__).parent
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]
