"""``hertz_mindlin``: Hertz-Mindlin no-slip with viscoelastic damping from the restitution
coefficient (Tavares et al. 2021, EDEM form), with rolling friction.

Row: E* [Pa], G* [Pa], 2 sqrt(5/6) |beta|, mu, mu_r, and sqrt(2 E*), sqrt(8 G*) precomputed so that
a contact costs two square roots. Needs the Young's modulus of both materials.
"""

import math
from functools import cache

from numba import njit
from scipy.optimize import brentq

from ...engine.integrators import DAMPING_LIMIT
from ...engine.jit_options import FAST
from ...engine.timestep import (
    RAYLEIGH_LIMIT,
    RAYLEIGH_RECOMMENDED,
    STEPS_PER_CONTACT_LIMIT,
    STEPS_PER_CONTACT_RECOMMENDED,
    StepBound,
    with_dashpot,
)
from .base import ContactLaw, Parameter
from .kernels import _split, _spring_friction

P_E_STAR, P_G_STAR, P_BETA_TERM, P_MU_HM, P_MU_ROLL, P_SQRT_2E, P_SQRT_8G = 0, 1, 2, 3, 4, 5, 6

TWO_SQRT_5_6 = 2.0 * math.sqrt(5.0 / 6.0)
HERTZ_TIME_FACTOR = 2.9433  # t_c = 2 (xi_max / v) int_0^1 dx / sqrt(1 - x^(5/2))


@njit(cache=True, fastmath=FAST)
def hertz_mindlin(p, xi, n0, n1, n2, v0, v1, v2, m_eff, r_eff, clip, hist, k, dt):
    """Hertz-Mindlin no-slip with viscoelastic damping from the restitution coefficient (EDEM form).

    Returns also the elastic normal force, which sets the rolling-friction torque.
    """
    vn, t0, t1, t2 = _split(n0, n1, n2, v0, v1, v2)
    a = math.sqrt(r_eff * xi)  # contact radius
    sam = p[P_BETA_TERM] * math.sqrt(a * m_eff)
    fn_el = (4.0 / 3.0) * p[P_E_STAR] * a * xi
    fn = fn_el - p[P_SQRT_2E] * sam * vn  # damping 2 sqrt(5/6) |beta| sqrt(S_n m*)
    if clip and fn < 0.0:
        fn = 0.0
    st = 8.0 * p[P_G_STAR] * a
    ct = p[P_SQRT_8G] * sam
    f0, f1, f2 = _spring_friction(st, ct, p[P_MU_HM] * abs(fn), t0, t1, t2, n0, n1, n2, hist, k, dt)
    return fn, f0, f1, f2, fn_el


def _hertz_mindlin_force(law):
    def hertz_mindlin_force(p, xi, n0, n1, n2, v0, v1, v2, m_eff, r_eff, clip, hist, k, dt):
        return law(p, xi, n0, n1, n2, v0, v1, v2, m_eff, r_eff, clip, hist, k, dt)

    return hertz_mindlin_force


def rayleigh_time(radius, density, shear_modulus, poisson_ratio):
    return math.pi * radius * math.sqrt(density / shear_modulus) / (0.1631 * poisson_ratio + 0.8766)


def hertz_contact_time(m_eff, r_eff, e_star, speed):
    return 2.87 * (m_eff**2 / (r_eff * e_star**2 * speed)) ** 0.2


def hertz_peak_overlap(m_eff, r_eff, e_star, speed):
    """Largest overlap of an elastic Hertz collision at ``speed`` (energy balance); a damped one
    stays below it."""
    return (15 * m_eff * speed * speed / (16 * e_star * math.sqrt(r_eff))) ** 0.4


def hertz_peak_damping_rate(m_eff, r_eff, e_star, beta_term, speed):
    """Fastest relaxation of the normal speed by the EDEM dashpot beta_term sqrt(S_n m*): the rate
    beta_term sqrt(S_n / m*) grows with the stiffness S_n = 2 E* sqrt(r xi), so it peaks at the
    largest overlap (the elastic one bounds it)."""
    s_n = 2.0 * e_star * math.sqrt(r_eff * hertz_peak_overlap(m_eff, r_eff, e_star, speed))
    return beta_term * math.sqrt(s_n / m_eff)


def effective_moduli(a, b):
    """E* and G* of a Hertz-Mindlin contact of materials a and b (G* as in EDEM/MUSEN)."""
    e_star = 1.0 / ((1 - a.poisson_ratio**2) / a.youngs_modulus + (1 - b.poisson_ratio**2) / b.youngs_modulus)
    g_star = 1.0 / ((2 - a.poisson_ratio) / a.shear_modulus + (2 - b.poisson_ratio) / b.shear_modulus)
    return e_star, g_star


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


def hertz_reference(m_eff, r_eff, e_star, beta_term, speed, clip):
    """Restitution and contact time of the damped Hertz normal ODE (damping beta_term sqrt(S_n
    m_eff)), solved by scipy at rtol 1e-11 in SI units, the contact ending at zero force
    (clip) or at zero overlap."""
    from scipy.integrate import solve_ivp

    def force(xi, xi_dot):
        xi = max(xi, 0.0)
        sn = 2.0 * e_star * math.sqrt(r_eff * xi)
        return (2.0 / 3.0) * sn * xi + beta_term * math.sqrt(sn * m_eff) * xi_dot

    def rhs(_, y):
        f = force(y[0], y[1])
        return [y[1], -(max(f, 0.0) if clip else f) / m_eff]

    end = (lambda _, y: force(y[0], y[1])) if clip else (lambda _, y: y[0])
    end.terminal, end.direction = True, -1
    # Start just inside contact so the end event does not fire at t = 0.
    t_guess = 3.0 * (m_eff**2 / (r_eff * e_star**2 * speed)) ** 0.2
    sol = solve_ivp(rhs, (0.0, 10 * t_guess), [speed * 1e-9 * t_guess, speed], events=end,
                    rtol=1e-11, atol=1e-16 * speed * t_guess, max_step=t_guess / 2000)
    y_end = sol.y_events[0][0]
    return -y_end[1] / speed, float(sol.t_events[0][0])


class HertzMindlin(ContactLaw):
    name = "hertz_mindlin"
    parameters = (
        Parameter("restitution", 0.5, 0.0, 1.0, lo_open=True, doc="head-on restitution"),
        Parameter("friction", 0.5, doc="Coulomb friction coefficient"),
        Parameter("rolling_friction", 0.0, doc="rolling friction coefficient"),
    )
    columns = ("e_star", "g_star", "beta_term", "mu", "mu_roll", "sqrt_2e", "sqrt_8g")
    spring_columns = 3
    rolling_column = P_MU_ROLL
    elastic = "hertz"
    dims = (3,)
    bound_kinds = ("rayleigh", "hertz_contact")
    contact_time_exponent = 0.2

    def row(self, a, b, values, convention):
        for m in (a, b):
            if math.isnan(m.youngs_modulus):
                raise ValueError(f"{m.name}.youngs_modulus: required by hertz_mindlin")
        e_star, g_star = effective_moduli(a, b)
        return {"e_star": e_star, "g_star": g_star,
                "beta_term": hertz_beta_term(values["restitution"], convention),
                "mu": values["friction"], "mu_roll": values["rolling_friction"],
                "sqrt_2e": math.sqrt(2.0 * e_star), "sqrt_8g": math.sqrt(8.0 * g_star)}

    def bounds(self, mat, p, ra, m_eff, r_eff, names, impact_speed, dim, integrator):
        t_r = rayleigh_time(ra, mat.density, mat.shear_modulus, mat.poisson_ratio)
        t_c = self.contact_time(p, m_eff, r_eff, impact_speed)
        what = f"the Hertz contact time {t_c:.4g} s of the {names} at {impact_speed:g} m/s"
        rate = hertz_peak_damping_rate(m_eff, r_eff, float(p[P_E_STAR]), float(p[P_BETA_TERM]),
                                       impact_speed)
        limit, recommended, binds = with_dashpot(t_c / STEPS_PER_CONTACT_LIMIT,
                                                 t_c / STEPS_PER_CONTACT_RECOMMENDED, rate,
                                                 integrator)
        if binds:
            what += (f" and its dashpot, relaxing the normal speed at up to {rate:.4g} 1/s "
                     f"(rate x dt <= {DAMPING_LIMIT[integrator]:g})")
        return (StepBound("rayleigh", f"the Rayleigh time {t_r:.4g} s of the smallest {mat.name} "
                          f"particle (r = {ra:.4g} m)", RAYLEIGH_LIMIT * t_r,
                          RAYLEIGH_RECOMMENDED * t_r),
                StepBound("hertz_contact", what, limit, recommended)), t_c

    def contact_time(self, p, m_eff, r_eff, speed):
        return hertz_contact_time(m_eff, r_eff, p[P_E_STAR], speed)

    def restitution(self, p, m_eff, convention):
        return hertz_restitution(float(p[P_BETA_TERM]), convention == "clipped")

    def collision_time(self, p, m_eff, r_eff, speed, clipped):
        e_star, beta_term = float(p[P_E_STAR]), float(p[P_BETA_TERM])
        if beta_term == 0.0:  # elastic: closed form
            return HERTZ_TIME_FACTOR * hertz_peak_overlap(m_eff, r_eff, e_star, speed) / speed
        return hertz_reference(m_eff, r_eff, e_star, beta_term, speed, clipped)[1]


HERTZ_MINDLIN = HertzMindlin(_hertz_mindlin_force, hertz_mindlin)
