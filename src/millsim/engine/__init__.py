"""The DEM engine: particles, contacts, walls, kinematic bodies, integrators, time step.

It imports no model: contact laws, breakage and fluids (``millsim.models``) are handed to
:class:`Simulation` as objects that bring their hooks.
"""

import os
import shutil
import time
from pathlib import Path

import numba

from .. import provenance_hash
from .kernel_cache import lock_cache_writes

# A kernel cache of another code version unused for this long is removed (each holds tens of MB;
# every edit below the studies makes a new one).
CACHE_KEEP_DAYS = 14


def _prune_kernel_caches(cache):
    """Mark ``cache`` as used now and remove its siblings unused for CACHE_KEEP_DAYS.

    A directory's modification time is its last use: every process touches its own on import.
    Other checkouts of other code versions keep theirs while they are used.
    """
    cache.mkdir(parents=True, exist_ok=True)
    os.utime(cache)
    cutoff = time.time() - CACHE_KEEP_DAYS * 86400
    for old in cache.parent.glob("numba-*"):
        try:
            if old != cache and old.is_dir() and old.stat().st_mtime < cutoff:
                shutil.rmtree(old, ignore_errors=True)
        except OSError:  # removed meanwhile by another process
            pass


# numba's on-disk cache only checks the file a function is defined in, not the files it calls or
# inlines; keying the cache directory by a hash of the whole package makes stale kernels impossible.
if not os.environ.get("NUMBA_CACHE_DIR"):
    _cache_root = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    _cache = _cache_root / "millsim" / f"numba-{provenance_hash()}"
    numba.config.CACHE_DIR = str(_cache)
    try:
        _prune_kernel_caches(_cache)
    except OSError:  # a read-only cache directory: nothing to mark or prune
        pass

lock_cache_writes()

# Each step opens two short parallel regions; OpenMP starts them in microseconds, TBB and the
# workqueue fallback take 10-50x longer, which dominates small systems.
numba.config.THREADING_LAYER_PRIORITY = ["omp", "tbb", "workqueue"]

from .insertion import Pour
from .simulation import Guards, Simulation, SimulationError, StepPolicy
from .spec import PhysicsSpec
from .state import BYTES_PER_PARTICLE
from .timestep import TimeStepError

__all__ = ["BYTES_PER_PARTICLE", "Guards", "PhysicsSpec", "Pour", "Simulation",
           "SimulationError", "StepPolicy", "TimeStepError"]
