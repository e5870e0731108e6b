"""Contact laws as plug-ins: one module per law (its constants, parameter row, validation, step
bounds, restitution mapping and compiled kernel, a :class:`~.base.ContactLaw`), listed in ``LAWS``.

Adding a law: a module beside these with its ``ContactLaw`` subclass and instance, one line below,
and its test. A :class:`~millsim.models.materials.MaterialTable` selects a law by its name; the
engine reaches it only through the ``ContactLaw`` interface.
"""

from ...engine.timestep import register_bound_kinds
from .base import N_PARAMS, ContactLaw, Parameter
from .hertz_hw import HERTZ_HW
from .hertz_mindlin import HERTZ_MINDLIN
from .linear_history import LINEAR_HISTORY
from .linear_hw import LINEAR_HW

LAWS = {law.name: law for law in (LINEAR_HW, LINEAR_HISTORY, HERTZ_MINDLIN, HERTZ_HW)}
for _law in LAWS.values():
    register_bound_kinds(_law.bound_kinds)

__all__ = ["LAWS", "N_PARAMS", "ContactLaw", "Parameter"]
