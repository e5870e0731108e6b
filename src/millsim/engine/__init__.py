"""The DEM engine: particles, contacts, walls, kinematic bodies, integrators, time step."""

import numba

# Each step opens two short parallel regions; OpenMP starts them in microseconds, TBB and the
# workqueue fallback take 10-50x longer, which dominates small systems.
numba.config.THREADING_LAYER_PRIORITY = ["omp", "tbb", "workqueue"]

from .materials import Interaction, Material, MaterialTable
from .simulation import Simulation, SimulationError
from .spec import PhysicsSpec
from .timestep import TimeStepError

__all__ = ["Interaction", "Material", "MaterialTable", "PhysicsSpec", "Simulation",
           "SimulationError", "TimeStepError"]
