"""``hertz_hw``: Hertz normal force with the EDEM damping of ``hertz_mindlin`` and the history-free
Haff-Werner friction of ``linear_hw``, F_T = -min(m_eff gamma_T |v_t|, mu |F_N|) t_hat.

A Hertzian contact that keeps no per-contact state (no tangential spring): cheaper, and the
friction law of Buchholtz et al. 2000 at Hertz's normal stiffness. Row: E* [Pa],
2 sqrt(5/6) |beta|, sqrt(2 E*), gamma_T [1/s], mu. The normal force and its restitution mapping
are Hertz-Mindlin's; the tangential dashpot bounds the step as in ``linear_hw``.
"""

import math

import numpy as np
from numba import njit

from ...engine.jit_options import FAST
from .base import ContactLaw, Parameter
from .hertz_mindlin import HERTZ_MINDLIN, effective_moduli, hertz_beta_term
from .kernels import _split
from .linear_hw import tangential_dashpot_bound

P_E_STAR, P_BETA_TERM, P_SQRT_2E, P_GAMMA_T, P_MU = 0, 1, 2, 3, 4


@njit(cache=True, fastmath=FAST)
def hertz_hw(p, xi, n0, n1, n2, v0, v1, v2, m_eff, r_eff, clip):
    """Hertz normal force with EDEM damping, Haff-Werner friction; also the elastic normal force."""
    vn, t0, t1, t2 = _split(n0, n1, n2, v0, v1, v2)
    a = math.sqrt(r_eff * xi)  # contact radius
    sam = p[P_BETA_TERM] * math.sqrt(a * m_eff)
    fn_el = (4.0 / 3.0) * p[P_E_STAR] * a * xi
    fn = fn_el - p[P_SQRT_2E] * sam * vn  # as hertz_mindlin
    if clip and fn < 0.0:
        fn = 0.0
    vt = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    if vt == 0.0 or fn == 0.0:
        return fn, 0.0, 0.0, 0.0, fn_el
    s = -min(m_eff * p[P_GAMMA_T] * vt, p[P_MU] * abs(fn)) / vt
    return fn, s * t0, s * t1, s * t2, fn_el


def _hertz_hw_force(law):
    def hertz_hw_force(p, xi, n0, n1, n2, v0, v1, v2, m_eff, r_eff, clip, hist, k, dt):
        return law(p, xi, n0, n1, n2, v0, v1, v2, m_eff, r_eff, clip)

    return hertz_hw_force


class HertzHW(ContactLaw):
    name = "hertz_hw"
    parameters = (
        Parameter("restitution", 0.5, 0.0, 1.0, lo_open=True, doc="head-on restitution"),
        Parameter("friction", 0.5, doc="Coulomb friction coefficient"),
        Parameter("tangential_damping_rate", None, doc="gamma_T [1/s] of the Haff-Werner friction"),
    )
    columns = ("e_star", "beta_term", "sqrt_2e", "gamma_t", "mu")
    elastic = "hertz"
    dims = (3,)
    bound_kinds = ("rayleigh", "hertz_contact", "tangential_dashpot")
    contact_time_exponent = 0.2

    def _hertz_row(self, p):
        """The row of Hertz-Mindlin with this law's normal constants (its bounds and mappings)."""
        row = np.zeros_like(p)
        row[HERTZ_MINDLIN.column("e_star")] = p[P_E_STAR]
        row[HERTZ_MINDLIN.column("beta_term")] = p[P_BETA_TERM]
        return row

    def row(self, a, b, values, convention):
        for m in (a, b):
            if math.isnan(m.youngs_modulus):
                raise ValueError(f"{m.name}.youngs_modulus: required by hertz_hw")
        e_star, _ = effective_moduli(a, b)
        return {"e_star": e_star, "beta_term": hertz_beta_term(values["restitution"], convention),
                "sqrt_2e": math.sqrt(2.0 * e_star), "gamma_t": values["tangential_damping_rate"],
                "mu": values["friction"]}

    def bounds(self, mat, p, ra, m_eff, r_eff, names, impact_speed, dim, integrator):
        found, t_c = HERTZ_MINDLIN.bounds(mat, self._hertz_row(p), ra, m_eff, r_eff, names,
                                          impact_speed, dim, integrator)
        if p[P_GAMMA_T] > 0:
            found += (tangential_dashpot_bound(float(p[P_GAMMA_T]), dim, integrator),)
        return found, t_c

    def contact_time(self, p, m_eff, r_eff, speed):
        return HERTZ_MINDLIN.contact_time(self._hertz_row(p), m_eff, r_eff, speed)

    def restitution(self, p, m_eff, convention):
        return HERTZ_MINDLIN.restitution(self._hertz_row(p), m_eff, convention)

    def collision_time(self, p, m_eff, r_eff, speed, clipped):
        return HERTZ_MINDLIN.collision_time(self._hertz_row(p), m_eff, r_eff, speed, clipped)


HERTZ_HW = HertzHW(_hertz_hw_force, hertz_hw)
