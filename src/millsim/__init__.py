"""millsim: a numba DEM engine and Snakemake pipeline for mill and breakage parameter studies."""

import hashlib
from functools import lru_cache
from importlib import metadata
from pathlib import Path

try:
    __version__ = metadata.version("millsim")
except metadata.PackageNotFoundError:  # running from a source tree without install
    __version__ = "0.0.0+src"


# The package in four layers that only look down (tests/test_layers.py holds the code to it): a
# module may import from its own layer and the ones before it. "base" is shared by all.
LAYERS = (
    ("base", ("util", "io")),
    ("engine", ("engine",)),
    ("models", ("models",)),
    ("scenes", ("scenes",)),
    ("studies", ("analysis", "plots", "cli", "cli_analyse", "workflow")),
)
# What decides the numbers in a case file: everything a scene can import, i.e. every layer below
# the studies. A change there re-runs cached cases; plotting, the command line and the analysis
# do not, so editing them leaves finished cases alone.
PHYSICS_SOURCES = tuple(part for _, parts in LAYERS[:-1] for part in parts)


@lru_cache(maxsize=1)
def provenance_hash() -> str:
    """Short hash of the source files that decide simulation results.

    The pipeline passes it as a rule parameter so that an engine change re-runs cached cases
    (Snakemake's own code trigger only sees the rule's script, not imported modules). numba's
    kernel cache is keyed by it too.
    """
    digest = hashlib.sha256()
    root = Path(__file__).parent
    files = []
    for part in PHYSICS_SOURCES:
        path = root / part
        files += sorted(path.rglob("*.py")) if path.is_dir() else [path.with_suffix(".py")]
    for path in files:
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]
