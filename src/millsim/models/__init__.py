"""Models the engine runs: contact laws and materials, lubrication, breakage (Buchholtz et al. 2000,
Tavares et al. 2021, the LabStar LS1 paper).

Each is an object a scene hands to :class:`~millsim.engine.Simulation`; it brings the hooks the
compiled loop calls and its own state layout (see :mod:`millsim.engine.models`).
"""

from .breakage.tavares_engine import TavaresModel
from .breakage.weibull import WeibullModel
from .lubrication import Lubrication
from .materials import Interaction, Material, MaterialTable

__all__ = ["Interaction", "Lubrication", "Material", "MaterialTable", "TavaresModel", "WeibullModel"]
