"""millsim: a numba DEM engine and Snakemake pipeline for mill and breakage parameter studies."""

import hashlib
from functools import lru_cache
from importlib import metadata
from pathlib import Path, PurePosixPath

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


def physics_order(paths, parts=PHYSICS_SOURCES):
    """Of ``paths`` (posix, relative to the package), the physics sources ``parts`` in the order
    the engine hash reads them: a folder's ``.py`` files sorted, a module as itself. Shared with
    millsim.analysis.physics_files, which hashes a past commit's files the same way."""
    paths = set(paths)
    order = []
    for part in parts:
        inside = sorted((q for q in paths if q.startswith(f"{part}/") and q.endswith(".py")),
                        key=PurePosixPath)
        single = part if part.endswith(".py") else f"{part}.py"
        order += inside if inside else ([single] if single in paths else [])
    return order


def source_digest(contents):
    """12 hex digits over {relative path: bytes}, in the given order."""
    digest = hashlib.sha256()
    for path, data in contents.items():
        digest.update(path.encode())
        digest.update(data)
    return digest.hexdigest()[:12]


@lru_cache(maxsize=1)
def provenance_hash() -> str:
    """Short hash of the source files that decide simulation results.

    The pipeline passes it as a rule parameter so that an engine change re-runs cached cases
    (Snakemake's own code trigger only sees the rule's script, not imported modules). numba's
    kernel cache is keyed by it too.
    """
    root = Path(__file__).parent
    files = [q.relative_to(root).as_posix() for q in root.rglob("*.py")]
    return source_digest({q: (root / q).read_bytes() for q in physics_order(files)})
