"""``linear_history``: linear spring-dashpot with a tangential spring and Coulomb limit (the LabStar
LS1 paper). Row: k_n [N/m], k_t [N/m], zeta_n, zeta_t (damping ratios, from the restitution), mu."""

import math

from numba import njit

from ...engine.jit_options import FAST
from .base import ContactLaw, Parameter
from .kernels import _split, _spring_friction
from .spring_dashpot import (
    damping_ratio,
    linear_collision_time,
    linear_contact_bound,
    linear_contact_time,
    linear_restitution,
)

P_K_N, P_K_T, P_ZETA_N, P_ZETA_T, P_MU_LIN = 0, 1, 2, 3, 4


@njit(cache=True, fastmath=FAST)
def linear_history(p, xi, n0, n1, n2, v0, v1, v2, m_eff, clip, hist, k, dt):
    """Linear spring-dashpot, damping from a damping ratio, tangential spring with Coulomb limit."""
    vn, t0, t1, t2 = _split(n0, n1, n2, v0, v1, v2)
    kn = p[P_K_N]
    kt = p[P_K_T]
    fn = kn * xi - 2.0 * p[P_ZETA_N] * math.sqrt(m_eff * kn) * vn
    if clip and fn < 0.0:
        fn = 0.0
    ct = 2.0 * p[P_ZETA_T] * math.sqrt(m_eff * kt)
    f0, f1, f2 = _spring_friction(kt, ct, p[P_MU_LIN] * abs(fn), t0, t1, t2, n0, n1, n2, hist, k, dt)
    return fn, f0, f1, f2


def _linear_history_force(law):
    def linear_history_force(p, xi, n0, n1, n2, v0, v1, v2, m_eff, r_eff, clip, hist, k, dt):
        fn, f0, f1, f2 = law(p, xi, n0, n1, n2, v0, v1, v2, m_eff, clip, hist, k, dt)
        return fn, f0, f1, f2, p[P_K_N] * xi

    return linear_history_force


class LinearHistory(ContactLaw):
    name = "linear_history"
    parameters = (
        Parameter("restitution", 0.5, 0.0, 1.0, lo_open=True, doc="head-on restitution"),
        Parameter("friction", 0.5, doc="Coulomb friction coefficient"),
        Parameter("normal_stiffness", None, lo_open=True, doc="k_n [N/m]"),
        Parameter("tangential_stiffness_ratio", 2.0 / 7.0, lo_open=True, doc="k_t / k_n"),
    )
    columns = ("k_n", "k_t", "zeta_n", "zeta_t", "mu")
    spring_columns = 3

    def row(self, a, b, values, convention):
        zeta = damping_ratio(values["restitution"], convention)
        k_n = values["normal_stiffness"]
        return {"k_n": k_n, "k_t": k_n * values["tangential_stiffness_ratio"], "zeta_n": zeta,
                "zeta_t": zeta, "mu": values["friction"]}

    def _damping_rate(self, p, m_eff):
        return 2.0 * p[P_ZETA_N] * math.sqrt(p[P_K_N] / m_eff)

    def bounds(self, mat, p, ra, m_eff, r_eff, names, impact_speed, dim, integrator):
        bound, t_c = linear_contact_bound(p[P_K_N], m_eff, self._damping_rate(p, m_eff), names,
                                          integrator)
        return (bound,), t_c

    def contact_time(self, p, m_eff, r_eff, speed):
        return linear_contact_time(p[P_K_N], m_eff, self._damping_rate(p, m_eff))[0]

    def stiffness_and_damping(self, p, m_eff):
        k_n = float(p[P_K_N])
        return k_n, 2.0 * float(p[P_ZETA_N]) * math.sqrt(k_n / m_eff)

    def restitution(self, p, m_eff, convention):
        return linear_restitution(float(p[P_ZETA_N]), convention == "clipped")

    def collision_time(self, p, m_eff, r_eff, speed, clipped):
        w0 = math.sqrt(float(p[P_K_N]) / m_eff)
        return linear_collision_time(w0, float(p[P_ZETA_N]) * w0, clipped)


LINEAR_HISTORY = LinearHistory(_linear_history_force, linear_history)
