"""Materials, pairwise interaction constants, and the parameter table the contact laws read.

All values SI. Every constructor validates its input and names the offending key and its allowed
range, so that bad input fails before any compilation or simulation starts.
"""

import math
from dataclasses import dataclass, field

import numpy as np

from ..util.validation import check_range
from . import contact as law


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


@dataclass(frozen=True)
class Interaction:
    """Constants of the contact between two materials.

    restitution, friction, rolling_friction: used by ``linear_history`` and ``hertz_mindlin``.
    normal_stiffness [N/m]: linear laws. tangential_stiffness_ratio: k_t / k_n (``linear_history``).
    normal_damping_rate, tangential_damping_rate [1/s]: seed 000's gamma_N and gamma_T
    (``linear_hw``, damping force m_eff * gamma * velocity).
    """

    restitution: float = 0.5
    friction: float = 0.5
    rolling_friction: float = 0.0
    normal_stiffness: float = math.nan
    tangential_stiffness_ratio: float = 2.0 / 7.0
    normal_damping_rate: float = math.nan
    tangential_damping_rate: float = math.nan

    def validate(self, pair, contact_law):
        name = f"interaction[{pair[0]}, {pair[1]}]"
        check_range(f"{name}.friction", self.friction, 0.0)
        check_range(f"{name}.rolling_friction", self.rolling_friction, 0.0)
        if contact_law == "linear_hw":
            check_range(f"{name}.normal_stiffness", self.normal_stiffness, 0.0, lo_open=True)
            check_range(f"{name}.normal_damping_rate", self.normal_damping_rate, 0.0)
            check_range(f"{name}.tangential_damping_rate", self.tangential_damping_rate, 0.0)
        else:
            check_range(f"{name}.restitution", self.restitution, 0.0, 1.0, lo_open=True)
        if contact_law == "linear_history":
            check_range(f"{name}.normal_stiffness", self.normal_stiffness, 0.0, lo_open=True)
            check_range(f"{name}.tangential_stiffness_ratio", self.tangential_stiffness_ratio, 0.0,
                        lo_open=True)


def damping_ratio(restitution):
    """Damping ratio zeta of a linear oscillator whose restitution (zero-overlap end) is e."""
    if restitution >= 1.0:
        return 0.0
    ln_e = math.log(restitution)
    return -ln_e / math.sqrt(math.pi**2 + ln_e**2)


def effective_moduli(a: Material, b: Material):
    """E* and G* of a Hertz-Mindlin contact (G* as in EDEM/MUSEN)."""
    e_star = 1.0 / ((1 - a.poisson_ratio**2) / a.youngs_modulus + (1 - b.poisson_ratio**2) / b.youngs_modulus)
    g_star = 1.0 / ((2 - a.poisson_ratio) / a.shear_modulus + (2 - b.poisson_ratio) / b.shear_modulus)
    return e_star, g_star


@dataclass
class MaterialTable:
    """Materials by index plus the interaction of every pair, compiled into ``pair_params``."""

    materials: list
    interactions: dict = field(default_factory=dict)
    contact_law: str = "hertz_mindlin"

    def __post_init__(self):
        if self.contact_law not in law.LAWS:
            raise ValueError(f"contact_law: must be one of {sorted(law.LAWS)}, got {self.contact_law!r}")
        names = [m.name for m in self.materials]
        if len(set(names)) != len(names):
            raise ValueError(f"materials: names must be unique, got {names}")
        self.index = {name: i for i, name in enumerate(names)}

    @property
    def law(self):
        """The contact law as the engine sees it (:class:`~millsim.models.contact.ContactLaw`)."""
        return law.LAWS[self.contact_law]

    def interaction(self, a: str, b: str) -> Interaction:
        for key in ((a, b), (b, a), "*"):
            if key in self.interactions:
                return self.interactions[key]
        raise ValueError(f"interaction[{a}, {b}]: not defined (give it, or a default under '*')")

    def pair_params(self) -> np.ndarray:
        n = len(self.materials)
        table = np.zeros((n, n, law.N_PARAMS))
        for i, a in enumerate(self.materials):
            for j, b in enumerate(self.materials):
                inter = self.interaction(a.name, b.name)
                inter.validate((a.name, b.name), self.contact_law)
                table[i, j] = self._row(a, b, inter)
        return table

    def _row(self, a, b, inter):
        row = np.zeros(law.N_PARAMS)
        if self.contact_law == "linear_hw":
            row[law.P_K_N] = inter.normal_stiffness
            row[law.P_GAMMA_N] = inter.normal_damping_rate
            row[law.P_GAMMA_T] = inter.tangential_damping_rate
            row[law.P_MU_HW] = inter.friction
        elif self.contact_law == "linear_history":
            zeta = damping_ratio(inter.restitution)
            row[law.P_K_N] = inter.normal_stiffness
            row[law.P_K_T] = inter.normal_stiffness * inter.tangential_stiffness_ratio
            row[law.P_ZETA_N] = zeta
            row[law.P_ZETA_T] = zeta
            row[law.P_MU_LIN] = inter.friction
        else:
            for m in (a, b):
                if math.isnan(m.youngs_modulus):
                    raise ValueError(f"{m.name}.youngs_modulus: required by hertz_mindlin")
            e_star, g_star = effective_moduli(a, b)
            ln_e = math.log(inter.restitution)
            beta = ln_e / math.sqrt(ln_e**2 + math.pi**2)
            row[law.P_E_STAR] = e_star
            row[law.P_G_STAR] = g_star
            row[law.P_BETA_TERM] = -law.TWO_SQRT_5_6 * beta
            row[law.P_MU_HM] = inter.friction
            row[law.P_MU_ROLL] = inter.rolling_friction
            row[law.P_SQRT_2E] = math.sqrt(2.0 * e_star)
            row[law.P_SQRT_8G] = math.sqrt(8.0 * g_star)
        return row
