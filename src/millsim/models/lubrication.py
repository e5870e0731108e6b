"""Pairwise lubrication: leading singular Jeffrey-Onishi terms, as pure per-pair functions.

The liquid appears only through the near-field lubrication between close surfaces (Ness & Sun type
model). Formulas, sources and checks: ``/work/shared/reference/lubrication.md`` sections 2-4; what
is implemented is summarised in ``docs/lubrication.md``.

The engine reaches it through :class:`Lubrication` (a fluid model: the pair and wall hooks of
the step loop and the explicit-integration time-step bound). Two integration schemes
(``docs/lubrication.md``): ``explicit`` (the forces join the contact forces; the step must resolve
the squeeze relaxation time at h_min) and ``implicit`` (the hooks write resistance rows that the
loop integrates backward-Euler over each kick, :mod:`millsim.engine.implicit`; no step bound).

Conventions (shared with :mod:`millsim.models.contact`):

- ``n`` is the unit normal pointing FROM body j (or the wall) TO body i.
- ``h`` is the surface gap r - a_i - a_j (negative while overlapping).
- ``vij = v_i - v_j`` (centre velocities); ``wi``, ``wj`` angular velocities.
- beta = a_j / a_i, xi = 2 h_eff / (a_i + a_j), L = max(ln(1/xi), 0), h_eff = max(h, h_min).
- The scalars are dimensional (eta included). Y11B and Y21B keep the Jeffrey-Onishi sign (< 0).

Cutoffs: the scalars are evaluated at ``h_eff = max(h, h_min)``, also while overlapping, so
lubrication keeps acting in parallel with the contact spring-dashpot at its saturated value. The
outer cutoff is the caller's: call these functions only for ``h < h_max``; beyond, the force is zero
(it jumps there, which only removes dissipation). Neighbour search reach: a_i + a_j + h_max + skin.

The force functions also return the dissipated power split into a normal (squeeze, X11A) part and a
tangential part (everything else: shear, B-coupling, rolling/pumping). Both are written as sums of
squares, so each is >= 0 whatever the rounding, and their sum equals -(F_i.v_ij + T_i.w_i + T_j.w_j)
to rounding (the identities Y11B + Y21B = -(a_i + a_j) Y11A, Y11C + Y12C = -(a_i + a_j) Y11B and
Y12C + Y22C = -(a_i + a_j) Y21B hold exactly).
"""

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..engine.implicit import RW_VJ, row_absent, row_write
from ..engine.jit_options import FAST
from ..engine.kinematics import W_AX, W_OMEGA, W_PX
from ..engine.models import FluidKernels, ParticleModel, stable_identity
from ..engine.oscillator_stability import INTEGRATORS, stability_dt
from ..engine.timestep import StepBound, TimeStepError

PI = math.pi

SCHEMES = ("explicit", "implicit", "auto")
# scheme "auto": implicit where the explicit scheme's recommended step is more than this factor
# below the contacts' one, else explicit. Per simulated time an implicit step costs 4-8x a dry step
# on the quick slice and 13x on the full LS1 at 1 Pa s; an explicit step with lubrication ~2x, on
# top of its step ratio (full LS1, one thread, 2026-11-26: 0.1 Pa s explicit 6.6x dry at ratio 3.1,
# 0.3 Pa s explicit 19x at ratio 8.9, 1 Pa s implicit 13x; docs/lubrication.md)
AUTO_STEP_RATIO = 5.0
IMPLICIT_ADVICE = "Lubrication(scheme='implicit'); scene parameter lubrication_scheme=implicit"
# implicit scheme: relative tolerance on the preconditioned residual of the solve, and the most
# iterations of one solve. On the quick stirred-mill slice 1e-3 changed the lubrication
# dissipation of 400 steps by 1.2e-4 (1 Pa s) and 2.9e-4 (10 Pa s) against 1e-7, at 3.2 and 6.1
# iterations per step (1e-2: 2e-5 and 1.2e-3 at 1.9 and 2.8; bench/lubrication_tolerance.py).
TOLERANCE, MAX_ITERATIONS = 1e-3, 100
# recommended dt = SAFETY * dt_stable. lubrication.md 4.5 suggests 0.5; the accuracy study
# (docs/results/accuracy.md) measured the quick slice's net power at 0.1 Pa s 4.4 +- 1.6 % high
# at 0.5 x and within 1.2 +- 1.6 % at 0.25 x the limit.
SAFETY = 0.25


# --------------------------------------------------------------------------------------------------
# Scalar resistances
# --------------------------------------------------------------------------------------------------

@njit(cache=True, fastmath=FAST)
def pair_resistances(ai, aj, h, h_min, eta):
    """Leading singular JO84 scalars of an unequal pair at h_eff = max(h, h_min).

    Returns (X11A, Y11A, Y11B, Y21B, Y11C, Y12C, Y22C): X, YA in N s/m, YB in N s, YC in N m s.
    Y11B, Y21B < 0 (JO84 sign). Y21C = Y12C. The log is clamped at >= 0 (xi >= 1 leaves the squeeze
    term only).
    """
    b = aj / ai
    bp = 1.0 + b
    h_eff = max(h_min, h)
    xi = 2.0 * h_eff / (ai + aj)
    L = -math.log(xi)
    L = max(L, 0.0)
    c_a = 6.0 * PI * eta * ai
    c_b = 4.0 * PI * eta * ai * ai
    c_c = 8.0 * PI * eta * ai * ai * ai
    bp2 = bp * bp
    bp3 = bp2 * bp
    x11a = c_a * (2.0 * b * b / (bp3 * xi) + b * (1.0 + 7.0 * b + b * b) / (5.0 * bp3) * L)
    y11a = c_a * (4.0 * b * (2.0 + b + 2.0 * b * b) / (15.0 * bp3)) * L
    y11b = -c_b * (b * (4.0 + b) / (5.0 * bp2)) * L
    y21b = -c_b * (b * b * (1.0 + 4.0 * b) / (5.0 * bp2)) * L
    y11c = c_c * (2.0 * b / (5.0 * bp)) * L
    y12c = c_c * (b * b / (10.0 * bp)) * L
    y22c = 8.0 * PI * eta * aj * aj * aj * (2.0 / (5.0 * bp)) * L
    return x11a, y11a, y11b, y21b, y11c, y12c, y22c


@njit(cache=True, fastmath=FAST)
def wall_resistances(a, h, h_min, eta):
    """Sphere-plane limit (beta -> infinity) at h_eff = max(h, h_min), log ln(a/h_eff) clamped >= 0.

    Returns (X_w, YA_w, YB_w, YC_w):
    X_w = 6 pi eta a (a/h + ln(a/h)/5), YA_w = 6 pi eta a (8/15) ln, YB_w = -4 pi eta a^2 (1/5) ln,
    YC_w = 8 pi eta a^3 (2/5) ln.
    """
    h_eff = max(h_min, h)
    L = math.log(a / h_eff)
    L = max(L, 0.0)
    c_a = 6.0 * PI * eta * a
    x_w = c_a * (a / h_eff + 0.2 * L)
    ya_w = c_a * (8.0 / 15.0) * L
    yb_w = -4.0 * PI * eta * a * a * 0.2 * L
    yc_w = 8.0 * PI * eta * a * a * a * 0.4 * L
    return x_w, ya_w, yb_w, yc_w


# --------------------------------------------------------------------------------------------------
# Forces, torques, dissipation
# --------------------------------------------------------------------------------------------------

@njit(cache=True, fastmath=FAST)
def pair_force_torque(ai, aj, n0, n1, n2, h, vij0, vij1, vij2, wi0, wi1, wi2, wj0, wj1, wj2,
                      h_min, eta):
    """Lubrication force and torques of one pair (call only for h < h_max).

    Returns (Fi0, Fi1, Fi2, Ti0, Ti1, Ti2, Tj0, Tj1, Tj2, D_n, D_t):
    force on i (the force on j is -F_i), torque on i, torque on j (NOT -T_i), and the dissipated
    power [W] of the normal squeeze mode D_n = X11A (n.v_ij)^2 and of all tangential/rotational modes
    D_t; both >= 0 and D_n + D_t = -(F_i.v_ij + T_i.w_i + T_j.w_j).

        F_i = -X11A (n.v_ij) n - Y11A P.v_ij - Y11B (w_i x n) - Y21B (w_j x n)
        T_i =  Y11B (v_ij x n) - P.(Y11C w_i + Y12C w_j)
        T_j =  Y21B (v_ij x n) - P.(Y12C w_i + Y22C w_j)
    """
    x11a, y11a, y11b, y21b, y11c, y12c, y22c = pair_resistances(ai, aj, h, h_min, eta)
    vn = vij0 * n0 + vij1 * n1 + vij2 * n2
    u0 = vij0 - vn * n0  # P.v_ij
    u1 = vij1 - vn * n1
    u2 = vij2 - vn * n2
    s0 = wi1 * n2 - wi2 * n1  # w_i x n
    s1 = wi2 * n0 - wi0 * n2
    s2 = wi0 * n1 - wi1 * n0
    t0 = wj1 * n2 - wj2 * n1  # w_j x n
    t1 = wj2 * n0 - wj0 * n2
    t2 = wj0 * n1 - wj1 * n0
    win = wi0 * n0 + wi1 * n1 + wi2 * n2
    wjn = wj0 * n0 + wj1 * n1 + wj2 * n2
    p0 = y11c * (wi0 - win * n0) + y12c * (wj0 - wjn * n0)  # P.(Y11C w_i + Y12C w_j)
    p1 = y11c * (wi1 - win * n1) + y12c * (wj1 - wjn * n1)
    p2 = y11c * (wi2 - win * n2) + y12c * (wj2 - wjn * n2)
    q0 = y12c * (wi0 - win * n0) + y22c * (wj0 - wjn * n0)  # P.(Y12C w_i + Y22C w_j)
    q1 = y12c * (wi1 - win * n1) + y22c * (wj1 - wjn * n1)
    q2 = y12c * (wi2 - win * n2) + y22c * (wj2 - wjn * n2)
    c0 = u1 * n2 - u2 * n1  # v_ij x n = (P.v_ij) x n
    c1 = u2 * n0 - u0 * n2
    c2 = u0 * n1 - u1 * n0
    f0 = -x11a * vn * n0 - y11a * u0 - y11b * s0 - y21b * t0
    f1 = -x11a * vn * n1 - y11a * u1 - y11b * s1 - y21b * t1
    f2 = -x11a * vn * n2 - y11a * u2 - y11b * s2 - y21b * t2
    # Dissipation. The tangential quadratic form on (u, s, t) is [[YA, YB, YB21], [YB, YC, YC12],
    # [YB21, YC12, YC22]] (x) I_2; it is singular along the rigid rotation (a_i + a_j, 1, 1), so
    # D_t = Y11A |u + (Y11B s + Y21B t)/Y11A|^2 + sigma |s - t|^2, sigma = Y11C - Y11B^2/Y11A >= 0.
    d_n = x11a * vn * vn
    d_t = 0.0
    if y11a > 0.0:
        g0 = u0 + (y11b * s0 + y21b * t0) / y11a
        g1 = u1 + (y11b * s1 + y21b * t1) / y11a
        g2 = u2 + (y11b * s2 + y21b * t2) / y11a
        sigma = y11c - y11b * y11b / y11a
        sigma = max(sigma, 0.0)
        e0, e1, e2 = s0 - t0, s1 - t1, s2 - t2
        d_t = y11a * (g0 * g0 + g1 * g1 + g2 * g2) + sigma * (e0 * e0 + e1 * e1 + e2 * e2)
    return (f0, f1, f2,
            y11b * c0 - p0, y11b * c1 - p1, y11b * c2 - p2,
            y21b * c0 - q0, y21b * c1 - q1, y21b * c2 - q2,
            d_n, d_t)


@njit(cache=True, fastmath=FAST)
def wall_force_torque(a, n0, n1, n2, h, vc0, vc1, vc2, wi0, wi1, wi2, ww0, ww1, ww2, h_min, eta):
    """Sphere-wall lubrication (call only for h < h_max); n points from the wall to the sphere.

    vc = v_i - u_wall(closest point) (the surface velocity returned by ``wall_contact``); ww is the
    wall's angular velocity (zero for fixed walls; omega * axis for a rotating cylinder). The law is
    the fixed-wall law applied in the wall's frame, which is the beta -> infinity limit of
    :func:`pair_force_torque` with lever a (h neglected, as in the pair law):

        v* = vc - a (ww x n),   w* = w_i - ww
        F  = -X_w (n.v*) n - YA_w P.v* - YB_w (w* x n)
        T  =  YB_w (v* x n) - YC_w P.w*

    With ww = 0 this is lubrication.md 2.5 with omega_wall = 0. For a wall rotating about its own
    normal (a disc face) ww x n = 0 and P.ww = 0, so ww changes nothing there.

    Returns (F0, F1, F2, T0, T1, T2, D_n, D_t): force and torque on the sphere; dissipation
    D_n = X_w (n.v*)^2 and D_t = YA_w |P.v* + (YB_w/YA_w)(w* x n)|^2 + (YC_w - YB_w^2/YA_w)|w* x n|^2,
    both >= 0, D_n + D_t = -(F.v* + T.w*). The power the wall puts in is D_n + D_t plus the work done
    on the sphere.
    """
    x_w, ya, yb, yc = wall_resistances(a, h, h_min, eta)
    v0 = vc0 - a * (ww1 * n2 - ww2 * n1)
    v1 = vc1 - a * (ww2 * n0 - ww0 * n2)
    v2 = vc2 - a * (ww0 * n1 - ww1 * n0)
    w0, w1, w2 = wi0 - ww0, wi1 - ww1, wi2 - ww2
    vn = v0 * n0 + v1 * n1 + v2 * n2
    u0, u1, u2 = v0 - vn * n0, v1 - vn * n1, v2 - vn * n2
    s0 = w1 * n2 - w2 * n1
    s1 = w2 * n0 - w0 * n2
    s2 = w0 * n1 - w1 * n0
    wn = w0 * n0 + w1 * n1 + w2 * n2
    c0 = u1 * n2 - u2 * n1
    c1 = u2 * n0 - u0 * n2
    c2 = u0 * n1 - u1 * n0
    d_n = x_w * vn * vn
    d_t = 0.0
    if ya > 0.0:
        r = yb / ya
        g0, g1, g2 = u0 + r * s0, u1 + r * s1, u2 + r * s2
        sigma = yc - yb * r
        sigma = max(sigma, 0.0)
        d_t = ya * (g0 * g0 + g1 * g1 + g2 * g2) + sigma * (s0 * s0 + s1 * s1 + s2 * s2)
    return (-x_w * vn * n0 - ya * u0 - yb * s0,
            -x_w * vn * n1 - ya * u1 - yb * s1,
            -x_w * vn * n2 - ya * u2 - yb * s2,
            yb * c0 - yc * (w0 - wn * n0),
            yb * c1 - yc * (w1 - wn * n1),
            yb * c2 - yc * (w2 - wn * n2),
            d_n, d_t)


@njit(cache=True, fastmath=FAST)
def pair_rows(ai, aj, h, h_min, eta):
    """The pair law as the implicit scheme's rows (engine.implicit): (k_n, k_s, k_r, b_i, b_j).

    D = X11A g_n^2 + Y11A |g_s|^2 + sigma |g_r|^2 with g_s = P.v_ij + b_i (w_i x n) + b_j (w_j x n),
    b_i = Y11B/Y11A, b_j = Y21B/Y11A, g_r = (w_i - w_j) x n and sigma = Y11C - Y11B^2/Y11A: the
    dissipation of :func:`pair_force_torque` written as a sum of squares, so J^T K J is its
    resistance matrix (Y12C and Y22C follow from the identities of the module text).
    """
    x11a, y11a, y11b, y21b, y11c, _, _ = pair_resistances(ai, aj, h, h_min, eta)
    if not y11a > 0.0:  # log clamped: the squeeze term only
        return x11a, 0.0, 0.0, 0.0, 0.0
    bi = y11b / y11a
    return x11a, y11a, max(y11c - y11b * bi, 0.0), bi, y21b / y11a


@njit(cache=True, fastmath=FAST)
def wall_rows(a, h, h_min, eta):
    """The sphere-wall law as rows: (k_n, k_s, k_r, b) = (X_w, YA_w, YC_w - YB_w^2/YA_w, YB_w/YA_w),
    the wall being the pair's partner j with b_j = -b (its velocity and spin subtracted)."""
    x_w, ya, yb, yc = wall_resistances(a, h, h_min, eta)
    if not ya > 0.0:
        return x_w, 0.0, 0.0, 0.0
    b = yb / ya
    return x_w, ya, max(yc - yb * b, 0.0), b


# --------------------------------------------------------------------------------------------------
# Parameters and time step (plain Python)
# --------------------------------------------------------------------------------------------------

def check_lubrication_params(eta, h_min, h_max, a_min=0.5):
    """Validate the lubrication parameters; raise ValueError naming the offending one.

    h_min, h_max and a_min share one length unit. With the default a_min = 0.5 the gaps are read as
    fractions of the (smallest) bead diameter d (a = d/2); pass a_min in metres with gaps in metres.
    The largest dimensionless gap xi_max = h_max / a_min (equal smallest beads; unequal pairs and the
    wall have smaller xi or ln(a/h) >= 0 under the same condition) must stay below 1, or the log terms
    would change sign. Returns (xi_min, xi_max).
    """
    vals = {}
    for key, val in (("eta", eta), ("h_min", h_min), ("h_max", h_max), ("a_min", a_min)):
        try:
            vals[key] = float(val)
        except (TypeError, ValueError):
            raise ValueError(f"lubrication.{key}: must be a number, got {val!r}") from None
        if not math.isfinite(vals[key]):
            raise ValueError(f"lubrication.{key}: must be finite, got {val!r}")
    eta, h_min, h_max, a_min = vals["eta"], vals["h_min"], vals["h_max"], vals["a_min"]
    if eta < 0.0:
        raise ValueError(f"lubrication.eta: viscosity must be >= 0 Pa s, got {eta:g}")
    if a_min <= 0.0:
        raise ValueError(f"lubrication.a_min: smallest radius must be > 0, got {a_min:g}")
    if h_min <= 0.0:
        raise ValueError(f"lubrication.h_min: inner cutoff must be > 0 (the squeeze force diverges "
                         f"as 1/h), got {h_min:g}")
    if h_min >= h_max:
        raise ValueError(f"lubrication.h_min: inner cutoff {h_min:g} must be smaller than the outer "
                         f"cutoff h_max = {h_max:g}")
    xi_max = h_max / a_min
    if xi_max >= 1.0:
        raise ValueError(f"lubrication.h_max: outer cutoff {h_max:g} gives xi = h_max/a_min = "
                         f"{xi_max:g} >= 1 for the smallest beads (a_min = {a_min:g}), where the "
                         f"log terms change sign; use h_max < a_min (typically 0.05 d)")
    return h_min / a_min, xi_max


def check_scheme(scheme, tolerance=TOLERANCE, max_iterations=MAX_ITERATIONS):
    """Validate the integration scheme and the implicit solve's settings; raise ValueError naming
    the offending key."""
    if scheme not in SCHEMES:
        raise ValueError(f"lubrication.scheme: must be one of {list(SCHEMES)}, got {scheme!r}")
    try:
        tolerance = float(tolerance)
    except (TypeError, ValueError):
        raise ValueError(f"lubrication.tolerance: must be a number, got {tolerance!r}") from None
    if not (math.isfinite(tolerance) and 0.0 < tolerance < 1.0):
        raise ValueError(f"lubrication.tolerance: relative residual of the implicit solve must be "
                         f"in (0, 1), got {tolerance!r}")
    if isinstance(max_iterations, bool) or not isinstance(max_iterations, (int, np.integer)) \
            or max_iterations < 1:
        raise ValueError(f"lubrication.max_iterations: must be an integer >= 1, got "
                         f"{max_iterations!r}")


@dataclass(frozen=True)
class LubricationStepLimit:
    """Stability bound of explicit integration with lubrication (lubrication.md 4.3-4.5).

    dt_stable [s]; lambda_c [1/s] = (8 X11A(h_min) + X_w(h_min))/m_min + gamma_n (worst FCC packing
    at h_min against a wall, plus the contact dashpot); lambda_k [1/s^2] = 2 k_n/m_min;
    X11A_hmin, X_w [N s/m] of the smallest beads at h_min.
    """

    dt_stable: float
    lambda_c: float
    lambda_k: float
    X11A_hmin: float
    X_w: float
    eta: float
    h_min: float
    a_min: float
    m_min: float
    integrator: str

    @property
    def dt_recommended(self):
        """SAFETY * dt_stable (with the half-step Verlet this also keeps the squeeze mode from
        oscillating, g dt <= 1)."""
        return SAFETY * self.dt_stable

    @property
    def dt_lubrication_only(self):
        """The bound without the contact spring and dashpot."""
        return stability_dt((8.0 * self.X11A_hmin + self.X_w) / self.m_min, 0.0, self.integrator)

    def describe(self):
        return (f"lubrication (eta = {self.eta:g} Pa s, h_min = {self.h_min:.4g} m, smallest bead "
                f"a = {self.a_min:.4g} m, m_min = {self.m_min:.4g} kg: X11A(h_min) = "
                f"{self.X11A_hmin:.4g} N s/m, X_wall(h_min) = {self.X_w:.4g} N s/m, damping rate "
                f"lambda_c = {self.lambda_c:.4g} 1/s, contact lambda_k = {self.lambda_k:.4g} 1/s^2, "
                f"{self.integrator} stable for dt <= {self.dt_stable:.4g} s)")

    def message(self, dt):
        """Refusal text for a requested dt above dt_stable."""
        return (f"dt: {dt:.4g} s exceeds the stability limit {self.dt_stable:.4g} s of "
                f"{self.describe()}; use dt <= {self.dt_recommended:.4g} s, or a larger h_min "
                f"(dt_stable grows about linearly with h_min), or a lower viscosity, or the "
                f"implicit scheme ({IMPLICIT_ADVICE})")

    def check(self, dt):
        """Return dt if dt <= dt_stable, else raise timestep.TimeStepError with :meth:`message`."""
        if not dt > 0:
            raise TimeStepError(f"dt: must be > 0, got {dt}")
        if dt > self.dt_stable:
            raise TimeStepError(self.message(dt))
        return dt

    def step_bound(self):
        """The bound as a :class:`~millsim.engine.timestep.StepBound` (to add to a TimeStepReport)."""
        return StepBound("lubrication", self.describe(), self.dt_stable, self.dt_recommended,
                         advice=", or a larger h_min (dt_stable grows about linearly with h_min), "
                                f"or a lower viscosity, or the implicit scheme ({IMPLICIT_ADVICE})")


def lubrication_dt_limit(eta, h_min, a_min, m_min, k_n, gamma_n, integrator="verlet"):
    """Worst-case explicit stability bound with lubrication (lubrication.md 4.3 and 4.5).

    Args:
        eta: viscosity [Pa s]; h_min: inner cutoff [m]; a_min, m_min: radius [m] and mass [kg] of
            the smallest bead.
        k_n: contact normal stiffness [N/m] (0: lubrication and dashpot only).
        gamma_n: contact normal damping RATE [1/s] (force m_eff gamma_n v_n, as ``linear_hw``; for
            a damping ratio zeta pass 2 zeta sqrt(k_n/m_eff)); 0 for none.
        integrator: ``verlet`` (this engine, default), ``verlet_half_step`` or ``gear``; see
            :func:`stability_dt`.

    lambda_c = (8 X11A(h_min) + X_w(h_min))/m_min + gamma_n, lambda_k = 2 k_n/m_min.
    The FCC bound 8 X11A/m is exact for a monodisperse packing with every gap at h_min; for
    polydisperse beds (small beads between large ones, X11A -> X_w) it is not a bound.
    """
    for key, val, positive in (("eta", eta, False), ("h_min", h_min, True), ("a_min", a_min, True),
                               ("m_min", m_min, True), ("k_n", k_n, False),
                               ("gamma_n", gamma_n, False)):
        if not (math.isfinite(val) and (val > 0.0 if positive else val >= 0.0)):
            raise ValueError(f"lubrication_dt_limit.{key}: must be finite and "
                             f"{'> 0' if positive else '>= 0'}, got {val!r}")
    if h_min >= a_min:
        raise ValueError(f"lubrication_dt_limit.h_min: {h_min:g} m must be below the smallest "
                         f"radius a_min = {a_min:g} m")
    x11a = float(pair_resistances(a_min, a_min, h_min, h_min, eta)[0])
    x_w = float(wall_resistances(a_min, h_min, h_min, eta)[0])
    lambda_c = (8.0 * x11a + x_w) / m_min + gamma_n
    lambda_k = 2.0 * k_n / m_min
    if lambda_c + lambda_k > 0.0:
        dt = stability_dt(lambda_c, lambda_k, integrator)
    else:
        if integrator not in INTEGRATORS:
            raise ValueError(f"integrator: {integrator!r} is not one of {INTEGRATORS}")
        dt = math.inf
    return LubricationStepLimit(dt, lambda_c, lambda_k, x11a, x_w, float(eta), float(h_min),
                                float(a_min), float(m_min), integrator)


# --------------------------------------------------------------------------------------------------
# The fluid model the engine runs
# --------------------------------------------------------------------------------------------------
# params: viscosity [Pa s], cutoffs as fractions of the smaller diameter, and the implicit solve's
# tolerance and iteration limit (read by the loop as fp[3], fp[4])
ETA, H_MIN, H_MAX, TOL, MAX_IT = 0, 1, 2, 3, 4


def _pair_fluid(fp, o, col_t, col_d, ri, rj, n0, n1, n2, h, v, w, i, j):
    """Add the pair lubrication of (i, j) to slot record ``o`` when the gap is below h_max.

    Force on i joins the contact force (o[0:3]); the torques on i and j (not opposite for unequal
    radii) go to o[col_t:col_t+6]; the normal and tangential dissipation to o[col_d:col_d+2] when
    col_d >= 0. Cutoffs are fractions of the smaller diameter of the pair.
    """
    d_min = 2.0 * min(ri, rj)
    if h >= fp[H_MAX] * d_min:
        return
    F0, F1, F2, Ti0, Ti1, Ti2, Tj0, Tj1, Tj2, Dn, Dt = pair_force_torque(
        ri, rj, n0, n1, n2, h, v[i, 0] - v[j, 0], v[i, 1] - v[j, 1], v[i, 2] - v[j, 2],
        w[i, 0], w[i, 1], w[i, 2], w[j, 0], w[j, 1], w[j, 2], fp[H_MIN] * d_min, fp[ETA])
    o[0] += F0
    o[1] += F1
    o[2] += F2
    o[col_t], o[col_t + 1], o[col_t + 2] = Ti0, Ti1, Ti2
    o[col_t + 3], o[col_t + 4], o[col_t + 5] = Tj0, Tj1, Tj2
    if col_d >= 0:
        o[col_d] += Dn
        o[col_d + 1] += Dt


def _wall_fluid(fp, wall, x, v, w, i, ri, n0, n1, n2, xi):
    """Sphere-wall lubrication of particle i (also during contact, at h >= h_min); the wall spins
    at omega about its axis (0 for planes). Returns (active, force (3), couple (3), dissipation
    normal and tangential, lever from the wall's point to the sphere's centre (3), power the wall
    puts in)."""
    if not -xi < fp[H_MAX] * 2.0 * ri:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    om = wall[W_OMEGA]
    cp0 = x[i, 0] - wall[W_PX]
    cp1 = x[i, 1] - wall[W_PX + 1]
    cp2 = x[i, 2] - wall[W_PX + 2]
    # the wall's rigid velocity at the sphere's centre
    uc0 = om * (wall[W_AX + 1] * cp2 - wall[W_AX + 2] * cp1)
    uc1 = om * (wall[W_AX + 2] * cp0 - wall[W_AX] * cp2)
    uc2 = om * (wall[W_AX] * cp1 - wall[W_AX + 1] * cp0)
    # wall_force_torque subtracts a (omega x n) from the slip it is given to reach the centre:
    # hand it the slip at the surface
    g0, g1, g2, c0, c1, c2, Dn, Dt = wall_force_torque(
        ri, n0, n1, n2, -xi,
        v[i, 0] - uc0 + ri * om * (wall[W_AX + 1] * n2 - wall[W_AX + 2] * n1),
        v[i, 1] - uc1 + ri * om * (wall[W_AX + 2] * n0 - wall[W_AX] * n2),
        v[i, 2] - uc2 + ri * om * (wall[W_AX] * n1 - wall[W_AX + 1] * n0),
        w[i, 0], w[i, 1], w[i, 2], om * wall[W_AX], om * wall[W_AX + 1], om * wall[W_AX + 2],
        fp[H_MIN] * 2.0 * ri, fp[ETA])
    # power = F . (wall velocity at the centre) + couple . wall spin
    power = g0 * uc0 + g1 * uc1 + g2 * uc2 + om * (c0 * wall[W_AX] + c1 * wall[W_AX + 1] + c2 * wall[W_AX + 2])
    return True, g0, g1, g2, c0, c1, c2, Dn, Dt, cp0, cp1, cp2, power


def _kernel(fn):
    return stable_identity(njit(inline="always", cache=True, fastmath=FAST)(fn),
                           f"lubrication.{fn.__name__}")


def _pair_rows(fp, o, col_t, col_d, ri, rj, n0, n1, n2, h, v, w, i, j):
    """Implicit scheme: ``o`` is the pair's row record (engine.implicit; col_t, col_d unused):
    written, or marked absent (RW_ACT = 0) from h_max on. Cutoffs of the smaller diameter."""
    d_min = 2.0 * min(ri, rj)
    if h >= fp[H_MAX] * d_min or not fp[ETA] > 0.0:
        row_absent(o)
        return
    kn, ks, kr, bi, bj = pair_rows(ri, rj, h, fp[H_MIN] * d_min, fp[ETA])
    row_write(o, n0, n1, n2, kn, ks, kr, bi, bj)


def _wall_rows(fp, wall, x, i, ri, n0, n1, n2, xi, rec):
    """Implicit scheme: the row of particle i at a wall, with the wall's rigid velocity at the
    sphere's centre and its spin as the partner's motion (the explicit law's frame)."""
    if not (-xi < fp[H_MAX] * 2.0 * ri and fp[ETA] > 0.0):
        row_absent(rec)
        return
    om = wall[W_OMEGA]
    cp0 = x[i, 0] - wall[W_PX]
    cp1 = x[i, 1] - wall[W_PX + 1]
    cp2 = x[i, 2] - wall[W_PX + 2]
    kn, ks, kr, b = wall_rows(ri, -xi, fp[H_MIN] * 2.0 * ri, fp[ETA])
    row_write(rec, n0, n1, n2, kn, ks, kr, b, -b)
    rec[RW_VJ] = om * (wall[W_AX + 1] * cp2 - wall[W_AX + 2] * cp1)
    rec[RW_VJ + 1] = om * (wall[W_AX + 2] * cp0 - wall[W_AX] * cp2)
    rec[RW_VJ + 2] = om * (wall[W_AX] * cp1 - wall[W_AX + 1] * cp0)
    rec[RW_VJ + 3], rec[RW_VJ + 4], rec[RW_VJ + 5] = om * wall[W_AX], om * wall[W_AX + 1], om * wall[W_AX + 2]


def _no_wall_rows(fp, wall, x, i, ri, n0, n1, n2, xi, rec):
    pass


def _no_wall_fluid(fp, wall, x, v, w, i, ri, n0, n1, n2, xi):
    return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0


KERNELS = FluidKernels(_kernel(_pair_fluid), _kernel(_wall_fluid), _kernel(_no_wall_rows))
IMPLICIT_KERNELS = FluidKernels(_kernel(_pair_rows), _kernel(_no_wall_fluid), _kernel(_wall_rows))


class Lubrication(ParticleModel):
    """Pairwise lubrication (the LabStar LS1 paper) as a fluid model of the engine.

    Args:
        eta: viscosity [Pa s] (0: the hooks run but add nothing; a dry scene passes no fluid).
        h_min, h_max: inner and outer gap cutoffs as fractions of the smaller diameter of a pair
            (sphere-wall: of the sphere's diameter).
        scheme: ``explicit`` (forces with the contacts; the step resolves the squeeze relaxation
            time, :meth:`step_bounds`), ``implicit`` (backward-Euler impulses solved each step,
            engine.implicit; no step bound; Verlet only) or ``auto`` (the Simulation picks the
            cheaper of the two for its particles, :meth:`resolve`).
        tolerance, max_iterations: the implicit solve stops when the preconditioned residual
            r.D^-1 r is below tolerance^2 of its start, or after max_iterations.
    """

    kind = "fluid"
    # (class defaults also serve checkpoints written before the implicit scheme existed)
    scheme, tolerance, max_iterations = "explicit", TOLERANCE, MAX_ITERATIONS

    def __init__(self, eta=0.0, h_min=0.001, h_max=0.05, scheme="explicit", tolerance=TOLERANCE,
                 max_iterations=MAX_ITERATIONS):
        check_lubrication_params(eta, h_min, h_max)
        check_scheme(scheme, tolerance, max_iterations)
        self.eta, self.h_min, self.h_max = float(eta), float(h_min), float(h_max)
        self.scheme, self.tolerance, self.max_iterations = scheme, float(tolerance), max_iterations

    @property
    def implicit(self):
        return self.scheme == "implicit"

    def resolve(self, contact_step, smallest):
        """This model with scheme ``auto`` replaced by the one it stands for (itself otherwise):
        implicit where the explicit scheme's recommended step is more than AUTO_STEP_RATIO below
        ``contact_step``, the contacts' recommended step, else explicit (also with an integrator
        other than Verlet, which the implicit scheme does not have). ``smallest``: as for
        :meth:`step_bounds`."""
        if self.scheme != "auto":
            return self
        explicit = Lubrication(self.eta, self.h_min, self.h_max, "explicit", self.tolerance,
                               self.max_iterations)
        bounds = explicit.step_bounds(smallest)
        stiff = bounds and contact_step > AUTO_STEP_RATIO * bounds[0].recommended
        scheme = "implicit" if stiff and smallest[4] == "verlet" else "explicit"
        return Lubrication(self.eta, self.h_min, self.h_max, scheme, self.tolerance,
                           self.max_iterations)

    @property
    def name(self):  # part of the compiled loop's identity
        return "lubrication_implicit" if self.implicit else "lubrication"

    @property
    def kernels(self):
        return IMPLICIT_KERNELS if self.implicit else KERNELS

    def params(self):
        return np.array([self.eta, self.h_min, self.h_max, self.tolerance, self.max_iterations],
                        dtype=float)

    def reach(self, max_radius):
        """How far beyond contact pairs interact: the neighbour list must hold those pairs."""
        return self.h_max * 2.0 * max_radius

    def step_bounds(self, smallest):
        """Explicit stability with lubrication, from the smallest free particle (lubrication.md
        4): ``smallest`` = (radius, mass, k_n, gamma_n, integrator); none when eta = 0 or with the
        implicit scheme (unconditionally stable: the contacts set the step)."""
        if self.eta <= 0 or self.implicit:
            return ()
        a_min, m_min, k_n, gamma_n, integrator = smallest
        return (lubrication_dt_limit(self.eta, self.h_min * 2.0 * a_min, a_min, m_min, k_n,
                                     gamma_n, integrator).step_bound(),)
