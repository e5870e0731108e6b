"""Materials, pairwise interaction constants, and the parameter table the contact laws read.

All values SI. Every constructor validates its input and names the offending key and its allowed
range, so that bad input fails before any compilation or simulation starts. What an interaction
holds and how it becomes a parameter row is the contact law's (:mod:`millsim.models.contact`).
"""

import math
from dataclasses import dataclass, field

import numpy as np

from ..engine.spec import CONVENTIONS
from ..util.validation import check_range
from .contact import LAWS, N_PARAMS


@dataclass(frozen=True)
class Material:
    """A solid: density [kg/m3], Young's modulus [Pa] and Poisson ratio (Hertz-Mindlin only)."""

    name: str
    density: float
    youngs_modulus: float = math.nan
    poisson_ratio: float = 0.3

    def __post_init__(self):
        check_range(f"{self.name}.density", self.density, 0.0, lo_open=True)
        check_range(f"{self.name}.poisson_ratio", self.poisson_ratio, -1.0, 0.5, True, True)
        if not math.isnan(self.youngs_modulus):
            check_range(f"{self.name}.youngs_modulus", self.youngs_modulus, 0.0, lo_open=True)

    @property
    def shear_modulus(self):
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))


class Interaction:
    """Constants of the contact between two materials, by the names the contact laws declare
    (``ContactLaw.parameters``: restitution, friction, normal_stiffness, ...). The table's law
    takes its own, fills in its defaults and checks them; constants of other laws are ignored, so
    that one interaction serves several laws."""

    def __init__(self, **values):
        known = {p.name for law in LAWS.values() for p in law.parameters}
        for key in values:
            if key not in known:
                raise ValueError(f"interaction.{key}: not a constant of any contact law "
                                 f"(known: {', '.join(sorted(known))})")
        self.values = values

    def __repr__(self):
        return f"Interaction({', '.join(f'{k}={v!r}' for k, v in self.values.items())})"


@dataclass
class MaterialTable:
    """Materials by index plus the interaction of every pair, compiled into ``pair_params``."""

    materials: list
    interactions: dict = field(default_factory=dict)
    contact_law: str = "hertz_mindlin"

    def __post_init__(self):
        if self.contact_law not in LAWS:
            raise ValueError(f"contact_law: must be one of {sorted(LAWS)}, got {self.contact_law!r}")
        names = [m.name for m in self.materials]
        if len(set(names)) != len(names):
            raise ValueError(f"materials: names must be unique, got {names}")
        self.index = {name: i for i, name in enumerate(names)}

    @property
    def law(self):
        """The contact law as the engine sees it (:class:`~millsim.models.contact.ContactLaw`)."""
        return LAWS[self.contact_law]

    def interaction(self, a: str, b: str) -> Interaction:
        for key in ((a, b), (b, a), "*"):
            if key in self.interactions:
                return self.interactions[key]
        raise ValueError(f"interaction[{a}, {b}]: not defined (give it, or a default under '*')")

    def pair_params(self, convention="clipped") -> np.ndarray:
        """Parameter rows of every material pair (the law's ``parameter_row``); the damping is set
        so that a head-on collision returns the pair's restitution in the given end-of-contact
        convention."""
        if convention not in CONVENTIONS:
            raise ValueError(f"convention: must be one of {CONVENTIONS}, got {convention!r}")
        n = len(self.materials)
        table = np.zeros((n, n, N_PARAMS))
        for i, a in enumerate(self.materials):
            for j, b in enumerate(self.materials):
                inter = self.interaction(a.name, b.name)
                table[i, j] = self.law.parameter_row(a, b, inter.values, convention)
        return table
