"""The DEM engine: particles, contacts, walls, kinematic bodies, integrators, time step.

It imports no model: contact laws, breakage and fluids (``millsim.models``) are handed to
:class:`Simulation` as objects that bring their hooks.
"""

import os
from pathlib import Path

import numba

from .. import provenance_hash

# numba's on-disk cache only checks the file a function is defined in, not the files it calls or
# inlines; keying the cache directory by a hash of the whole package makes stale kernels impossible.
if not os.environ.get("NUMBA_CACHE_DIR"):
    _cache_root = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    numba.config.CACHE_DIR = str(_cache_root / "millsim" / f"numba-{provenance_hash()}")

# Each step opens two short parallel regions; OpenMP starts them in microseconds, TBB and the
# workqueue fallback take 10-50x longer, which dominates small systems.
numba.config.THREADING_LAYER_PRIORITY = ["omp", "tbb", "workqueue"]

from .simulation import Guards, Simulation, SimulationError, StepPolicy
from .spec import PhysicsSpec
from .timestep import TimeStepError

__all__ = ["Guards", "PhysicsSpec", "Simulation", "SimulationError", "StepPolicy", "TimeStepError"]
