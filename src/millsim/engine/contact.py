"""Contact laws: pure per-contact functions compiled into the step loop.

Every law receives the contact geometry and kinematics of one contact and returns the normal force
magnitude (never attractive unless the caller asks for the unclipped textbook variant) and the
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
a law never types or compiles it, which the tests check.

Parameter rows (``p``) hold SI values, built by :mod:`millsim.engine.materials`:
- ``LINEAR_HW`` (seed 000, Haff-Werner friction): k_n [N/m], gamma_n [1/s], gamma_t [1/s], mu.
- ``LINEAR_HISTORY`` (seed 004): k_n [N/m], k_t [N/m], zeta_n, zeta_t (damping ratios), mu.
- ``HERTZ_MINDLIN`` (seed 002, EDEM no-slip form): E* [Pa], G* [Pa], 2 sqrt(5/6) |beta|, mu, mu_r,
  and sqrt(2 E*), sqrt(8 G*) precomputed so that a contact costs two square roots.
"""

import math

from numba import njit

LINEAR_HW = 0
LINEAR_HISTORY = 1
HERTZ_MINDLIN = 2

LAW_IDS = {"linear_hw": LINEAR_HW, "linear_history": LINEAR_HISTORY, "hertz_mindlin": HERTZ_MINDLIN}
LAW_HAS_SPRING = {"linear_hw": False, "linear_history": True, "hertz_mindlin": True}

# Column layout of a parameter row (same length for every law so one table serves all).
P_K_N, P_GAMMA_N, P_GAMMA_T, P_MU_HW = 0, 1, 2, 3
P_K_T, P_ZETA_N, P_ZETA_T, P_MU_LIN = 1, 2, 3, 4
P_E_STAR, P_G_STAR, P_BETA_TERM, P_MU_HM, P_MU_ROLL, P_SQRT_2E, P_SQRT_8G = 0, 1, 2, 3, 4, 5, 6
N_PARAMS = 8

TWO_SQRT_5_6 = 2.0 * math.sqrt(5.0 / 6.0)

# Fast-math without the no-NaN/no-inf assumptions, so that the engine's NaN guard still sees NaN.
FAST = {"contract", "arcp", "afn", "nsz", "reassoc"}


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
    if vt == 0.0 or fn <= 0.0:
        return fn, 0.0, 0.0, 0.0
    ft = min(m_eff * p[P_GAMMA_T] * vt, p[P_MU_HW] * fn)
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
    f0, f1, f2 = _spring_friction(kt, ct, p[P_MU_LIN] * fn, t0, t1, t2, n0, n1, n2, hist, k, dt)
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
    f0, f1, f2 = _spring_friction(st, ct, p[P_MU_HM] * fn, t0, t1, t2, n0, n1, n2, hist, k, dt)
    return fn, f0, f1, f2, fn_el
