"""``linear_hw``: linear spring-dashpot with Haff-Werner friction (Buchholtz et al. 2000).

Row: k_n [N/m], gamma_n [1/s], gamma_t [1/s], mu. The damping is a rate (force m_eff gamma
velocity), so the restitution is a result of the constants, not one of them.
"""

import math

from numba import njit

from ...engine.integrators import DAMPING_LIMIT
from ...engine.jit_options import FAST
from ...engine.timestep import StepBound
from .base import ContactLaw, Parameter
from .kernels import _split
from .spring_dashpot import (
    linear_collision_time,
    linear_contact_bound,
    linear_contact_time,
    linear_restitution,
)

P_K_N, P_GAMMA_N, P_GAMMA_T, P_MU_HW = 0, 1, 2, 3
# Contacts with immovable partners (wall disks, lifters) that can hold one particle at once.
DASHPOT_CONTACTS = 3


@njit(cache=True, fastmath=FAST)
def linear_hw(p, xi, n0, n1, n2, v0, v1, v2, m_eff, clip):
    """Linear spring-dashpot with Haff-Werner friction F_T = -min(m_eff gamma_t |v_t|, mu F_N) t_hat."""
    vn, t0, t1, t2 = _split(n0, n1, n2, v0, v1, v2)
    fn = p[P_K_N] * xi - m_eff * p[P_GAMMA_N] * vn
    if clip and fn < 0.0:
        fn = 0.0
    vt = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    if vt == 0.0 or fn == 0.0:
        return fn, 0.0, 0.0, 0.0
    ft = min(m_eff * p[P_GAMMA_T] * vt, p[P_MU_HW] * abs(fn))  # |F_n|: an unclipped pull too
    s = -ft / vt
    return fn, s * t0, s * t1, s * t2


def _linear_hw_force(law):
    def linear_hw_force(p, xi, n0, n1, n2, v0, v1, v2, m_eff, r_eff, clip, hist, k, dt):
        fn, f0, f1, f2 = law(p, xi, n0, n1, n2, v0, v1, v2, m_eff, clip)
        return fn, f0, f1, f2, p[P_K_N] * xi

    return linear_hw_force


def tangential_dashpot_bound(gamma_t, dim, integrator):
    """Step bound of the Haff-Werner tangential force below its Coulomb limit.

    There F_T = -m_eff gamma_T v_t is a dashpot on the slip of the contact point, which moves
    with translation and spin: one contact with an immovable partner relaxes the slip at
    (1 + m a^2 / I) gamma_T = 3 gamma_T (disks) or 3.5 gamma_T (spheres) (a pair of free
    particles at the same rate), and a particle held by DASHPOT_CONTACTS such contacts at up to
    that many times this rate. gamma_T does not scale with the contact stiffness, so the
    collision-time bounds do not cover it. Measured (tests/test_stability.py, a centrifuged 2D
    ball mill, Gear): at 6 gamma_T dt = 0.142 the slip oscillates at the Coulomb limit and the
    charge gains energy (audit residual -1.1 % of the drum work in 0.5 s, -30 % at 0.26), at
    0.129 and below the audit closes (3e-4).
    """
    rate = DASHPOT_CONTACTS * (3.0 if dim == 2 else 3.5) * gamma_t
    g = DAMPING_LIMIT[integrator]
    limit = g / rate
    return StepBound(
        "tangential_dashpot",
        f"the tangential dashpot gamma_T = {gamma_t:g} 1/s of the Haff-Werner friction "
        f"(slip relaxation up to {rate:.4g} 1/s for a particle held by {DASHPOT_CONTACTS} "
        f"contacts; {integrator} needs rate x dt <= {g:g})",
        limit, 0.5 * limit, "; or lower gamma_T")


class LinearHW(ContactLaw):
    name = "linear_hw"
    parameters = (
        Parameter("normal_stiffness", None, lo_open=True, doc="k_n [N/m]"),
        Parameter("normal_damping_rate", None, doc="gamma_N [1/s], damping force m_eff gamma_N v_n"),
        Parameter("tangential_damping_rate", None, doc="gamma_T [1/s] of the Haff-Werner friction"),
        Parameter("friction", 0.5, doc="Coulomb friction coefficient"),
    )
    columns = ("k_n", "gamma_n", "gamma_t", "mu")
    bound_kinds = ("tangential_dashpot", "linear_contact")

    def row(self, a, b, values, convention):
        return {"k_n": values["normal_stiffness"], "gamma_n": values["normal_damping_rate"],
                "gamma_t": values["tangential_damping_rate"], "mu": values["friction"]}

    def bounds(self, mat, p, ra, m_eff, r_eff, names, impact_speed, dim, integrator):
        bounds = []
        if p[P_GAMMA_T] > 0:
            bounds.append(tangential_dashpot_bound(float(p[P_GAMMA_T]), dim, integrator))
        bound, t_c = linear_contact_bound(p[P_K_N], m_eff, p[P_GAMMA_N], names, integrator)
        return (*bounds, bound), t_c

    def contact_time(self, p, m_eff, r_eff, speed):
        return linear_contact_time(p[P_K_N], m_eff, p[P_GAMMA_N])[0]

    def stiffness_and_damping(self, p, m_eff):
        return float(p[P_K_N]), float(p[P_GAMMA_N])

    def restitution(self, p, m_eff, convention):
        w0 = math.sqrt(float(p[P_K_N]) / m_eff)
        return linear_restitution(float(p[P_GAMMA_N]) / 2.0 / w0, convention == "clipped")

    def collision_time(self, p, m_eff, r_eff, speed, clipped):
        return linear_collision_time(math.sqrt(float(p[P_K_N]) / m_eff), float(p[P_GAMMA_N]) / 2.0,
                                     clipped)


LINEAR_HW = LinearHW(_linear_hw_force, linear_hw)
