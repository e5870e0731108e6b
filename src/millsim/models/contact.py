"""Contact laws: pure per-contact functions compiled into the step loop, and their time-step bounds.

Every law receives the contact geometry and kinematics of one contact and returns the normal force
magnitude (never attractive unless the spec's convention is ``unclipped``, where the Coulomb limit
takes |F_n| as EDEM and LIGGGHTS do) and the
tangential force vector acting on body ``i``. The caller turns these into forces and torques on both
bodies, so the same law serves particle-particle and particle-wall contacts (for a wall, m_eff = m_i
and r_eff = r_i).

Conventions (shared with the rest of the engine):
- ``n`` is the unit normal pointing from body j (or the wall) to body i.
- ``vrel`` is the velocity of i's material point at the contact minus j's, so the normal overlap rate
  is ``xi_dot = -vrel . n``.
- ``hist`` is the contact's tangential spring (3 values), updated in place; laws without a spring
  ignore it.

The laws are separate compiled functions (LLVM inlines them): a step loop whose spec does not use
a law never types or compiles it, which the tests check. Each law is reached by the loop through a
:class:`ContactLaw` (its uniform ``force`` kernel, its state columns and its time-step bounds), the
one object the engine needs to know about a law: the same evaluation serves pairs and walls.

Parameter rows (``p``) hold SI values, built by :mod:`millsim.models.materials`:
- ``LINEAR_HW`` (Buchholtz et al. 2000, Haff-Werner friction): k_n [N/m], gamma_n [1/s],
  gamma_t [1/s], mu.
- ``LINEAR_HISTORY`` (the LabStar LS1 paper): k_n [N/m], k_t [N/m], zeta_n, zeta_t (damping ratios),
  mu.
- ``HERTZ_MINDLIN`` (Tavares et al. 2021, EDEM no-slip form): E* [Pa], G* [Pa], 2 sqrt(5/6) |beta|,
  mu, mu_r, and sqrt(2 E*), sqrt(8 G*) precomputed so that a contact costs two square roots.
"""

import math
from dataclasses import dataclass

from numba import njit

from ..engine.integrators import DAMPING_LIMIT, GEAR_OMEGA_DT_LIMIT
from ..engine.jit_options import FAST
from ..engine.models import stable_identity
from ..engine.timestep import (
    RAYLEIGH_LIMIT,
    RAYLEIGH_RECOMMENDED,
    STEPS_PER_CONTACT_LIMIT,
    STEPS_PER_CONTACT_RECOMMENDED,
    StepBound,
)

# Column layout of a parameter row (same length for every law so one table serves all).
P_K_N, P_GAMMA_N, P_GAMMA_T, P_MU_HW = 0, 1, 2, 3
P_K_T, P_ZETA_N, P_ZETA_T, P_MU_LIN = 1, 2, 3, 4
P_E_STAR, P_G_STAR, P_BETA_TERM, P_MU_HM, P_MU_ROLL, P_SQRT_2E, P_SQRT_8G = 0, 1, 2, 3, 4, 5, 6
N_PARAMS = 8

TWO_SQRT_5_6 = 2.0 * math.sqrt(5.0 / 6.0)



@njit(inline="always", cache=True, fastmath=FAST)
def _split(n0, n1, n2, v0, v1, v2):
    """Normal speed and tangential velocity components of vrel."""
    vn = v0 * n0 + v1 * n1 + v2 * n2
    return vn, v0 - vn * n0, v1 - vn * n1, v2 - vn * n2


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


@njit(inline="always", cache=True, fastmath=FAST)
def _spring_friction(kt, ct, mu_fn, t0, t1, t2, n0, n1, n2, hist, k, dt):
    """Tangential spring + dashpot with Coulomb limit; returns the tangential force on i.

    The stored spring is first projected on the current tangent plane (keeping its length) so that it
    follows the rotating contact, then advanced by v_t dt. While sliding, the trial force is scaled to
    the Coulomb limit and the spring reset to carry it alone (MUSEN convention).
    """
    h0 = hist[k, 0]
    h1 = hist[k, 1]
    h2 = hist[k, 2]
    hn = h0 * n0 + h1 * n1 + h2 * n2
    if hn != 0.0:
        h0 -= hn * n0
        h1 -= hn * n1
        h2 -= hn * n2
        new = h0 * h0 + h1 * h1 + h2 * h2
        if hn * hn < 0.01 * new:
            # Restore the length after a small rotation of the contact plane: sqrt(1 + hn^2/new)
            # to second order. A spring (nearly) along the normal is round-off and is dropped.
            scale = 1.0 + 0.5 * hn * hn / new
            h0 *= scale
            h1 *= scale
            h2 *= scale
    h0 += t0 * dt
    h1 += t1 * dt
    h2 += t2 * dt
    f0 = -kt * h0 - ct * t0
    f1 = -kt * h1 - ct * t1
    f2 = -kt * h2 - ct * t2
    f2sum = f0 * f0 + f1 * f1 + f2 * f2
    if f2sum > mu_fn * mu_fn:
        scale = mu_fn / math.sqrt(f2sum)
        f0 *= scale
        f1 *= scale
        f2 *= scale
        h0, h1, h2 = -f0 / kt, -f1 / kt, -f2 / kt
    hist[k, 0] = h0
    hist[k, 1] = h1
    hist[k, 2] = h2
    return f0, f1, f2


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


# ---- the uniform kernel the step loop calls: (fn, F_t on i (3), elastic normal force) -----------
# Each kernel in two builds: the law called as a compiled function (LLVM inlines it where its
# heuristics choose: the slot-record pass and the wall contacts keep their rounding), and the law
# inlined by numba into every caller (the colour sums' pass, where LLVM left it out of line and
# the call took a third of the time: docs/results/engine_speed.md, "Colour sums").
def _kernel(make, law, name, inlined=False):
    if inlined:
        law = stable_identity(njit(inline="always", cache=True, fastmath=FAST)(law.py_func),
                              f"contact.{name}.law_inlined")
        name += ".inlined"
    return stable_identity(njit(inline="always", cache=True, fastmath=FAST)(make(law)),
                           f"contact.{name}")


def _linear_hw_force(law):
    def linear_hw_force(p, xi, n0, n1, n2, v0, v1, v2, m_eff, r_eff, clip, hist, k, dt):
        fn, f0, f1, f2 = law(p, xi, n0, n1, n2, v0, v1, v2, m_eff, clip)
        return fn, f0, f1, f2, p[P_K_N] * xi

    return linear_hw_force


def _linear_history_force(law):
    def linear_history_force(p, xi, n0, n1, n2, v0, v1, v2, m_eff, r_eff, clip, hist, k, dt):
        fn, f0, f1, f2 = law(p, xi, n0, n1, n2, v0, v1, v2, m_eff, clip, hist, k, dt)
        return fn, f0, f1, f2, p[P_K_N] * xi

    return linear_history_force


def _hertz_mindlin_force(law):
    def hertz_mindlin_force(p, xi, n0, n1, n2, v0, v1, v2, m_eff, r_eff, clip, hist, k, dt):
        return law(p, xi, n0, n1, n2, v0, v1, v2, m_eff, r_eff, clip, hist, k, dt)

    return hertz_mindlin_force


# ---- time-step bounds ----------------------------------------------------------------------------
# Contacts with immovable partners (wall disks, lifters) that can hold one particle at once.
DASHPOT_CONTACTS = 3


def rayleigh_time(radius, density, shear_modulus, poisson_ratio):
    return math.pi * radius * math.sqrt(density / shear_modulus) / (0.1631 * poisson_ratio + 0.8766)


def hertz_contact_time(m_eff, r_eff, e_star, speed):
    return 2.87 * (m_eff**2 / (r_eff * e_star**2 * speed)) ** 0.2


def linear_contact_time(stiffness, m_eff, damping_rate):
    """Collision time of a linear spring-dashpot, damping rate gamma (force m_eff gamma xi_dot)."""
    w0 = math.sqrt(stiffness / m_eff)
    beta = 0.5 * damping_rate
    w = math.sqrt(max(w0 * w0 - beta * beta, 0.25 * w0 * w0))
    return math.pi / w, w0


def linear_collision_time(w0, beta, clipped):
    """Contact time of a linear spring-dashpot (damping rate 2 beta): it ends at zero overlap
    (unclipped) or at zero force (clipped, Schwager & Poeschel 2007), also overdamped."""
    if beta < w0:
        w = math.sqrt(w0 * w0 - beta * beta)
        return (math.pi - (0.0 if not clipped else math.atan2(2 * beta * w, w * w - beta * beta))) / w
    if not clipped:
        return math.inf  # an overdamped unclipped contact never reaches zero overlap again
    if beta == w0:
        return 2.0 / w0
    root = math.sqrt(beta * beta - w0 * w0)
    l1, l2 = beta - root, beta + root
    return 2.0 * math.log(l2 / l1) / (l2 - l1)


def tangential_dashpot_bound(gamma_t, dim, integrator):
    """Step bound of the Haff-Werner tangential force (``linear_hw``) below its Coulomb limit.

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


@dataclass(frozen=True)
class ContactLaw:
    """One contact law as the engine sees it.

    name: ``linear_hw``, ``linear_history`` or ``hertz_mindlin``; force: the compiled kernel
    (p, xi, n, vrel, m_eff, r_eff, clip, hist, k, dt) -> (fn, F_t (3), elastic fn);
    spring_columns: per-contact state it keeps (the tangential spring); rolling_column: the
    parameter-row column of the rolling-friction coefficient (-1: the law has none);
    inlined_force: the same kernel with the law inlined into its caller (colour sums).
    """

    name: str
    force: object
    spring_columns: int
    rolling_column: int = -1
    inlined_force: object = None

    def pair_bounds(self, materials, params, a, b, ra, ma, rb, mb, partner, impact_speed, dim,
                    integrator):
        """Step bounds of the contact of the smallest particles of materials a and b (mb = inf: a
        wall or kinematic body; params: the table's parameter rows); returns (bounds, Hertz
        contact time or inf)."""
        m_eff = 1.0 / (1.0 / ma + (0.0 if math.isinf(mb) else 1.0 / mb))
        r_eff = ra if math.isinf(rb) else ra * rb / (ra + rb)
        names = f"{materials[a].name}-{materials[b].name} {partner} contact"
        p = params[a, b]
        if self.name == "hertz_mindlin":
            mat = materials[a]
            t_r = rayleigh_time(ra, mat.density, mat.shear_modulus, mat.poisson_ratio)
            t_c = hertz_contact_time(m_eff, r_eff, p[P_E_STAR], impact_speed)
            return (StepBound("rayleigh", f"the Rayleigh time {t_r:.4g} s of the smallest {mat.name} "
                              f"particle (r = {ra:.4g} m)", RAYLEIGH_LIMIT * t_r,
                              RAYLEIGH_RECOMMENDED * t_r),
                    StepBound("hertz_contact", f"the Hertz contact time {t_c:.4g} s of the {names} "
                              f"at {impact_speed:g} m/s", t_c / STEPS_PER_CONTACT_LIMIT,
                              t_c / STEPS_PER_CONTACT_RECOMMENDED)), t_c
        bounds = []
        kn = p[P_K_N]
        if self.name == "linear_hw":
            gamma = p[P_GAMMA_N]
            if p[P_GAMMA_T] > 0:
                bounds.append(tangential_dashpot_bound(float(p[P_GAMMA_T]), dim, integrator))
        else:
            gamma = 2.0 * p[P_ZETA_N] * math.sqrt(kn / m_eff)
        t_c, w0 = linear_contact_time(kn, m_eff, gamma)
        limit = t_c / STEPS_PER_CONTACT_LIMIT
        what = f"the linear collision time {t_c:.4g} s of the {names} (m_eff = {m_eff:.4g} kg)"
        if integrator == "gear":
            limit = min(limit, GEAR_OMEGA_DT_LIMIT / w0)
            what += f" and Gear stability w0 dt <= {GEAR_OMEGA_DT_LIMIT}"
        bounds.append(StepBound("linear_contact", what, limit, t_c / STEPS_PER_CONTACT_RECOMMENDED))
        return tuple(bounds), math.inf

    def stiffness_and_damping(self, p, m_eff):
        """(k_n [N/m], normal damping rate [1/s]) of a linear law for a contact of mass m_eff;
        (0, 0) for Hertz (its own contact bounds hold), used by the lubrication bound."""
        if self.name == "linear_hw":
            return float(p[P_K_N]), float(p[P_GAMMA_N])
        if self.name == "linear_history":
            k_n = float(p[P_K_N])
            return k_n, 2.0 * float(p[P_ZETA_N]) * math.sqrt(k_n / m_eff)
        return 0.0, 0.0


def _law(name, make, law, spring_columns, rolling_column=-1):
    return ContactLaw(name, _kernel(make, law, name), spring_columns, rolling_column,
                      _kernel(make, law, name, inlined=True))


LAWS = {
    "linear_hw": _law("linear_hw", _linear_hw_force, linear_hw, 0),
    "linear_history": _law("linear_history", _linear_history_force, linear_history, 3),
    "hertz_mindlin": _law("hertz_mindlin", _hertz_mindlin_force, hertz_mindlin, 3, P_MU_ROLL),
}
