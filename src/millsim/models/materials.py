"""Materials, pairwise interaction constants, and the parameter table the contact laws read.

All values SI. Every constructor validates its input and names the offending key and its allowed
range, so that bad input fails before any compilation or simulation starts.
"""

import math
from dataclasses import dataclass, field
from functools import cache

import numpy as np
from scipy.optimize import brentq

from ..engine.spec import CONVENTIONS
from ..util.validation import check_range
from . import contact as law
from .contact import TWO_SQRT_5_6


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
    normal_damping_rate, tangential_damping_rate [1/s]: gamma_N and gamma_T of Buchholtz et al. 2000
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


# Two conventions for the end of a contact (``PhysicsSpec.convention``); in both, a head-on
# collision of the pair returns the restitution asked for.
# - ``clipped`` (default): the normal force never pulls, the contact ends when it reaches zero,
#   before the overlap does. The damping is solved for once per restitution from the clipped
#   relation (closed form for the linear laws, one ODE root for Hertz).
# - ``unclipped``: the force may pull at the end (EDEM, LIGGGHTS ``limitForce off``, MercuryDPM),
#   the contact ends at zero overlap; the damping is the textbook one of those codes.


def linear_restitution(zeta, clipped):
    """Restitution of a head-on collision with a linear spring-dashpot of damping ratio zeta, in
    units of w0 from its contact time t_c (``contact.linear_collision_time``): e = exp(-zeta t_c)
    while underdamped (Schwager & Poeschel 2007, Granular Matter 9, 465, for the clipped end);
    overdamped and clipped, with the decay rates l1 < l2 = 2 zeta - l1, e = (l1 / l2) exp(-l1 t_c)
    (the same derivation with real exponents)."""
    if zeta <= 0.0:
        return 1.0
    t_c = law.linear_collision_time(1.0, zeta, clipped)
    if math.isinf(t_c):
        return 0.0
    if zeta <= 1.0:
        return math.exp(-zeta * t_c)
    l1 = zeta - math.sqrt(zeta * zeta - 1.0)
    return l1 / (2.0 * zeta - l1) * math.exp(-l1 * t_c)


@cache
def damping_ratio(restitution, convention="clipped"):
    """Damping ratio zeta of the linear laws whose head-on restitution is ``restitution``."""
    if restitution >= 1.0:
        return 0.0
    ln_e = math.log(restitution)
    unclipped = -ln_e / math.sqrt(math.pi**2 + ln_e**2)
    if convention == "unclipped":
        return unclipped
    # the clipped contact ends earlier and returns more: zeta lies above the unclipped one
    return brentq(lambda z: math.log(linear_restitution(z, True)) - ln_e, unclipped, 100.0,
                  xtol=1e-15, rtol=1e-15)


def hertz_restitution(beta_term, clipped):
    """Restitution of the Hertz law with EDEM damping 2 sqrt(5/6) |beta| sqrt(S_n m*) = beta_term
    sqrt(S_n m*), from its normal ODE (DOP853, rtol 1e-11). With this damping form e depends on
    beta only, not on speed, masses, radii or moduli, so the ODE runs in units where all are 1:
    x'' = -(4/3) x^(3/2) - sqrt(2) beta_term x^(1/4) x'."""
    from scipy.integrate import solve_ivp

    root2 = math.sqrt(2.0)

    def force(y):
        a = math.sqrt(max(y[0], 0.0))
        return (4.0 / 3.0) * a * a * a + root2 * beta_term * math.sqrt(a) * y[1]

    def rhs(_, y):
        f = force(y)
        return [y[1], -(max(f, 0.0) if clipped else f)]

    end = (lambda _, y: force(y)) if clipped else (lambda _, y: y[0])
    end.terminal, end.direction = True, -1
    sol = solve_ivp(rhs, (0.0, 100.0), [1e-14, 1.0], events=end, method="DOP853", rtol=1e-11,
                    atol=1e-14)
    return -float(sol.y_events[0][0][1])


@cache
def hertz_beta_term(restitution, convention="clipped"):
    """The damping factor 2 sqrt(5/6) |beta| of the Hertz law whose head-on restitution is
    ``restitution``. Unclipped: EDEM's beta = ln e / sqrt(ln^2 e + pi^2), for which the
    attractive-end ODE returns e exactly (Antypov & Elliott 2011, EPL 94, 50004). Clipped: the
    root of the clipped ODE's e(beta) (monotone; it has no closed form), found once per value."""
    if restitution >= 1.0:
        return 0.0
    ln_e = math.log(restitution)
    unclipped = -TWO_SQRT_5_6 * ln_e / math.sqrt(ln_e**2 + math.pi**2)
    if convention == "unclipped":
        return unclipped
    return brentq(lambda b: math.log(hertz_restitution(b, True)) - ln_e, unclipped, 100.0,
                  xtol=1e-13, rtol=1e-12)


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

    def pair_params(self, convention="clipped") -> np.ndarray:
        """Parameter rows of every material pair; the damping is set so that a head-on collision
        returns the pair's restitution in the given end-of-contact convention."""
        if convention not in CONVENTIONS:
            raise ValueError(f"convention: must be one of {CONVENTIONS}, got {convention!r}")
        n = len(self.materials)
        table = np.zeros((n, n, law.N_PARAMS))
        for i, a in enumerate(self.materials):
            for j, b in enumerate(self.materials):
                inter = self.interaction(a.name, b.name)
                inter.validate((a.name, b.name), self.contact_law)
                table[i, j] = self._row(a, b, inter, convention)
        return table

    def _row(self, a, b, inter, convention):
        row = np.zeros(law.N_PARAMS)
        if self.contact_law == "linear_hw":
            row[law.P_K_N] = inter.normal_stiffness
            row[law.P_GAMMA_N] = inter.normal_damping_rate
            row[law.P_GAMMA_T] = inter.tangential_damping_rate
            row[law.P_MU_HW] = inter.friction
        elif self.contact_law == "linear_history":
            zeta = damping_ratio(inter.restitution, convention)
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
            row[law.P_E_STAR] = e_star
            row[law.P_G_STAR] = g_star
            row[law.P_BETA_TERM] = hertz_beta_term(inter.restitution, convention)
            row[law.P_MU_HM] = inter.friction
            row[law.P_MU_ROLL] = inter.rolling_friction
            row[law.P_SQRT_2E] = math.sqrt(2.0 * e_star)
            row[law.P_SQRT_8G] = math.sqrt(8.0 * g_star)
        return row
