"""Pairwise lubrication kernels (models/lubrication.py) against limits, symmetries and exact solutions.

Convention everywhere: n points from j (or the wall) to i, vij = v_i - v_j, h = r - a_i - a_j.
These are the per-pair functions called directly; the same physics inside the compiled loop (its
cutoffs for unequal pairs, its integrators and the stability limit) is in
tests/test_lubrication_engine.py.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from millsim.engine.oscillator_stability import stability_dt
from millsim.models.lubrication import (
    check_lubrication_params,
    lubrication_dt_limit,
    pair_force_torque,
    pair_resistances,
    wall_force_torque,
    wall_resistances,
)

PI = math.pi
ETA = 1.0e-3
A = 0.9e-3  # 1.8 mm beads
RHO = 4000.0
BETAS = (0.5, 1.0, 2.0, 3.0)


def x11a_jo84(ai, aj, h_eff, eta=ETA):
    """X11A of Jeffrey & Onishi (1984), leading terms (lubrication.md 2.1), coded here."""
    b, xi = aj / ai, 2 * h_eff / (ai + aj)
    return 6 * PI * eta * ai * (2 * b**2 / ((1 + b)**3 * xi)
                                + b * (1 + 7 * b + b**2) / (5 * (1 + b)**3) * math.log(1 / xi))


def x_wall(a, h_eff, eta=ETA):
    """Sphere-plane squeeze resistance 6 pi eta a (a/h + ln(a/h)/5) (lubrication.md 2.5)."""
    return 6 * PI * eta * a * (a / h_eff + math.log(a / h_eff) / 5)


def assert_squeeze_dissipation(dn, x, n, v):
    """D_n = X (n.v)^2 up to rounding. n.v is a 3-term sum whose rounding error is below
    4 eps |v| in any summation order or with FMA (numpy/BLAS versions differ there, and so does
    the fastmath kernel), so |D_n - X (n.v)^2| <= X (2 |n.v| + d) d with d = 4 eps |v|. A purely
    tangential v gives n.v ~ 1e-17 |v|: comparing relatively (or with atol = 0) fails on rounding."""
    vn = float(np.dot(n, v))
    d = 4 * np.finfo(float).eps * np.linalg.norm(v)
    assert abs(dn - x * vn**2) <= 1e-12 * x * vn**2 + x * (2 * abs(vn) + d) * d


def pair(ai, aj, n, h, vij, wi, wj, h_min=0.0, eta=ETA):
    """(F_i, T_i, T_j, D_n, D_t) as arrays."""
    r = pair_force_torque(ai, aj, n[0], n[1], n[2], h, vij[0], vij[1], vij[2], wi[0], wi[1], wi[2],
                          wj[0], wj[1], wj[2], h_min, eta)
    return np.array(r[0:3]), np.array(r[3:6]), np.array(r[6:9]), r[9], r[10]


def wall(a, n, h, vc, wi, ww=(0.0, 0.0, 0.0), h_min=0.0, eta=ETA):
    """(F, T, D_n, D_t) as arrays."""
    r = wall_force_torque(a, n[0], n[1], n[2], h, vc[0], vc[1], vc[2], wi[0], wi[1], wi[2],
                          ww[0], ww[1], ww[2], h_min, eta)
    return np.array(r[0:3]), np.array(r[3:6]), r[6], r[7]


def unit(rng):
    n = rng.normal(size=3)
    return n / np.linalg.norm(n)


def random_case(rng, ai, aj):
    """Random normal, gap inside (h_min, h_max) of the smaller bead, velocities of order 1 m/s."""
    d = 2.0 * min(ai, aj)
    h = rng.uniform(0.001 * d, 0.05 * d)
    return unit(rng), h, rng.normal(size=3), rng.normal(size=3) / ai, rng.normal(size=3) / aj


# ------------------------------------------------------------------------------------------------
# scalars
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("xi", [2e-3, 1e-2, 1e-1])
def test_equal_sphere_limits(xi):
    """beta = 1: X11A = 6 pi eta a (1/(4 xi) + 9/40 L), Y11A = pi eta a L, Y11B = Y21B = -pi eta a^2 L,
    Y11C = Y22C = (8/5) pi eta a^3 L, Y12C = (2/5) pi eta a^3 L, with xi = h/a and L = ln(1/xi)."""
    L = math.log(1.0 / xi)
    got = pair_resistances(A, A, xi * A, 0.0, ETA)
    ref = (6 * PI * ETA * A * (1 / (4 * xi) + 9 / 40 * L), PI * ETA * A * L, -PI * ETA * A**2 * L,
           -PI * ETA * A**2 * L, 1.6 * PI * ETA * A**3 * L, 0.4 * PI * ETA * A**3 * L,
           1.6 * PI * ETA * A**3 * L)
    np.testing.assert_allclose(got, ref, rtol=1e-12)


@pytest.mark.parametrize("beta", BETAS)
def test_unequal_scalars_swap_symmetry(beta):
    """Seen from j (beta -> 1/beta, a_i <-> a_j): X11A, Y11A, Y12C unchanged, Y11B <-> Y21B,
    Y11C <-> Y22C; B-terms negative, the rest positive; and the exact identities behind momentum
    balance: Y11B + Y21B = -(a_i+a_j) Y11A, Y11C + Y12C = -(a_i+a_j) Y11B, Y12C + Y22C = -(a_i+a_j) Y21B."""
    ai, aj = A, beta * A
    h = 0.01 * A
    x, ya, yb, yb21, yc, yc12, yc22 = pair_resistances(ai, aj, h, 0.0, ETA)
    xs, yas, ybs, yb21s, ycs, yc12s, yc22s = pair_resistances(aj, ai, h, 0.0, ETA)
    np.testing.assert_allclose([xs, yas, ybs, yb21s, ycs, yc12s, yc22s],
                               [x, ya, yb21, yb, yc22, yc12, yc], rtol=1e-12)
    assert yb < 0 and yb21 < 0 and min(x, ya, yc, yc12, yc22) > 0
    s = ai + aj
    np.testing.assert_allclose(yb + yb21, -s * ya, rtol=1e-12)
    np.testing.assert_allclose(yc + yc12, -s * yb, rtol=1e-12)
    np.testing.assert_allclose(yc12 + yc22, -s * yb21, rtol=1e-12)
    # The leading coefficients written out independently (lubrication.md 2.1, JO84 g-functions).
    b, xi = beta, 2 * h / (ai + aj)
    L = math.log(1 / xi)
    np.testing.assert_allclose(
        [x, ya, yb, yb21, yc, yc12],
        [6 * PI * ETA * ai * (2 * b**2 / (1 + b)**3 / xi + b * (1 + 7 * b + b**2) / (5 * (1 + b)**3) * L),
         6 * PI * ETA * ai * 4 * b * (2 + b + 2 * b**2) / (15 * (1 + b)**3) * L,
         -4 * PI * ETA * ai**2 * b * (4 + b) / (5 * (1 + b)**2) * L,
         -4 * PI * ETA * aj**2 * (1 + 4 * b) / (5 * (1 + b)**2) * L,
         8 * PI * ETA * ai**3 * 2 * b / (5 * (1 + b)) * L,
         8 * PI * ETA * ai**3 * b**2 / (10 * (1 + b)) * L], rtol=1e-12)


def test_inner_clip_also_in_overlap_and_log_clamp():
    """Below h_min (also overlapping) the scalars are those at h_min: the JO84 values at h_min
    coded here; beyond xi = 1 the logs are clamped at 0 and only the 1/xi squeeze term is left."""
    h_min = 0.002 * A
    # a pair of radii A and 2A and the wall, at and below h_min (same h_eff: rounding only)
    pair_at_min = pair_resistances(A, 2 * A, h_min, h_min, ETA)
    wall_at_min = wall_resistances(A, h_min, h_min, ETA)
    np.testing.assert_allclose(pair_at_min[0], x11a_jo84(A, 2 * A, h_min), rtol=1e-12)
    np.testing.assert_allclose(wall_at_min[0], x_wall(A, h_min), rtol=1e-12)
    for h in (0.5 * h_min, 0.0, -0.01 * A):
        np.testing.assert_allclose(pair_resistances(A, 2 * A, h, h_min, ETA), pair_at_min,
                                   rtol=1e-14)
        np.testing.assert_allclose(wall_resistances(A, h, h_min, ETA), wall_at_min, rtol=1e-14)
    # xi >= 1: the log terms are clamped to 0, the squeeze term stays.
    x, ya, yb, yb21, yc, yc12, yc22 = pair_resistances(A, A, 1.5 * A, 0.0, ETA)
    np.testing.assert_allclose([ya, yb / A, yb21 / A, yc / A**2, yc12 / A**2, yc22 / A**2], 0.0,
                               atol=1e-15 * x)
    np.testing.assert_allclose(x, 6 * PI * ETA * A / (4 * 1.5), rtol=1e-12)
    xw, yaw, ybw, ycw = wall_resistances(A, 1.5 * A, 0.0, ETA)
    np.testing.assert_allclose([yaw, ybw / A, ycw / A**2], 0.0, atol=1e-15 * xw)
    np.testing.assert_allclose(xw, 6 * PI * ETA * A / 1.5, rtol=1e-12)
    # The forces of a pair held apart are still dissipative and finite at the clamp.
    F, Ti, Tj, dn, dt_ = pair(A, A, np.array([0, 0, 1.0]), 1.5 * A, np.array([0.3, 0, -1.0]),
                              np.array([0, 5.0, 0]), np.zeros(3))
    f = 6 * PI * ETA * A / (4 * 1.5)
    assert dn > 0 and abs(dt_) <= 1e-15 * dn
    np.testing.assert_allclose(np.r_[Ti, Tj], 0.0, atol=1e-15 * f * A)
    np.testing.assert_allclose(F, [0, 0, f], rtol=1e-12, atol=1e-15 * f)


# ------------------------------------------------------------------------------------------------
# forces: symmetries, momentum, energy
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("beta", BETAS)
def test_pair_seen_from_j(beta):
    """Swap i and j (n -> -n, vij -> -vij): the force on j is -F_i and both torques agree."""
    rng = np.random.default_rng(int(10 * beta))
    ai, aj = A, beta * A
    for _ in range(50):
        n, h, vij, wi, wj = random_case(rng, ai, aj)
        Fi, Ti, Tj, dn, dt_ = pair(ai, aj, n, h, vij, wi, wj)
        Fj, Tj2, Ti2, dn2, dt2 = pair(aj, ai, -n, h, -vij, wj, wi)
        scale = np.abs(Fi).max()
        np.testing.assert_allclose(Fj, -Fi, rtol=1e-10, atol=1e-12 * scale)
        np.testing.assert_allclose(Tj2, Tj, rtol=1e-10, atol=1e-12 * scale * A)
        np.testing.assert_allclose(Ti2, Ti, rtol=1e-10, atol=1e-12 * scale * A)
        np.testing.assert_allclose([dn2, dt2], [dn, dt_], rtol=1e-9)
        # the torque on j is not -T_i
        assert np.abs(Ti + Tj).max() > 1e-3 * np.abs(Ti).max()


@pytest.mark.parametrize("beta", BETAS)
def test_angular_momentum_balance(beta):
    """T_i + T_j + (a_i + a_j) n x F_i = 0 (lever from j to i, h neglected as in the leading terms)."""
    rng = np.random.default_rng(100 + int(10 * beta))
    ai, aj = A, beta * A
    for _ in range(50):
        n, h, vij, wi, wj = random_case(rng, ai, aj)
        Fi, Ti, Tj, _, _ = pair(ai, aj, n, h, vij, wi, wj)
        res = Ti + Tj + (ai + aj) * np.cross(n, Fi)
        assert np.abs(res).max() <= 1e-11 * (np.abs(Ti).max() + np.abs(Tj).max() + A * np.abs(Fi).max())


@pytest.mark.parametrize("beta", BETAS)
def test_rigid_motion_is_free(beta):
    """The pair turning as one rigid body (w_i = w_j = W, v_ij = W x (a_i + a_j) n) and a twist about n
    (no singular term) give no force, no torque and no dissipation."""
    rng = np.random.default_rng(7)
    ai, aj = A, beta * A
    for _ in range(20):
        n = unit(rng)
        W = rng.normal(size=3) / A
        Fi, Ti, Tj, dn, dt_ = pair(ai, aj, n, 0.01 * A, np.cross(W, (ai + aj) * n), W, W)
        ref, ref_t = pair(ai, aj, n, 0.01 * A, np.cross(W, (ai + aj) * n), W, -W)[0:2]
        assert np.abs(Fi).max() <= 1e-12 * np.abs(ref).max()
        assert max(np.abs(Ti).max(), np.abs(Tj).max()) <= 1e-12 * A * np.abs(ref).max()
        assert dn + dt_ <= 1e-12 * np.abs(ref).max() * A * np.abs(W).max()
        Fi, Ti, Tj, dn, dt_ = pair(ai, aj, n, 0.01 * A, np.zeros(3), 3 * n / A, -2 * n / A)
        assert np.abs(Fi).max() <= 1e-14 * np.abs(ref).max()
        assert max(np.abs(Ti).max(), np.abs(Tj).max()) <= 1e-12 * np.abs(ref_t).max()
        assert abs(dn) <= 1e-28 * np.abs(ref).max() / A and dt_ <= 1e-28 * np.abs(ref).max() / A


def pair_matrix(ai, aj, n, h, h_min=0.0, eta=ETA):
    """12x12 resistance matrix R, generalized forces = -R U, U = (v_i, w_i, v_j, w_j)."""
    R = np.zeros((12, 12))
    for k in range(12):
        U = np.zeros(12)
        U[k] = 1.0
        Fi, Ti, Tj, _, _ = pair(ai, aj, n, h, U[0:3] - U[6:9], U[3:6], U[9:12], h_min, eta)
        R[:, k] = -np.concatenate([Fi, Ti, -Fi, Tj])
    return R


@pytest.mark.parametrize("beta", BETAS)
@pytest.mark.parametrize("xi", [2e-3, 1e-2, 1e-1])
def test_resistance_matrix_symmetric_psd(beta, xi):
    ai, aj = A, beta * A
    n = np.array([0.3, -0.5, 0.81])
    n /= np.linalg.norm(n)
    R = pair_matrix(ai, aj, n, xi * (ai + aj) / 2)
    # compare in the scaled velocities (v, a w) so that all entries have the same units
    S = np.diag([1, 1, 1, 1 / ai, 1 / ai, 1 / ai, 1, 1, 1, 1 / aj, 1 / aj, 1 / aj])
    Rs = S @ R @ S
    np.testing.assert_allclose(Rs, Rs.T, rtol=0, atol=1e-12 * np.abs(Rs).max())
    ev = np.linalg.eigvalsh(0.5 * (Rs + Rs.T))
    assert ev.min() > -1e-12 * ev.max()
    # rank 5: the squeeze mode, and per tangential direction sliding and rolling/pumping; null: the
    # common translation (3), the twists about n (2, no singular term), the rigid rotations about
    # the two tangential axes (2)
    assert np.sum(ev > 1e-9 * ev.max()) == 5


@pytest.mark.parametrize("beta", BETAS)
def test_dissipation_split(beta):
    """D_n = X11A v_n^2, D_t >= 0, D_n + D_t = -(F_i.v_ij + T_i.w_i + T_j.w_j) = U.R.U."""
    rng = np.random.default_rng(200 + int(10 * beta))
    ai, aj = A, beta * A
    h_min = 0.002 * min(ai, aj)
    for _ in range(100):
        n, h, vij, wi, wj = random_case(rng, ai, aj)
        if rng.uniform() < 0.3:  # pure tangential/rotational motion, and the clipped range
            vij -= np.dot(vij, n) * n
            h = rng.uniform(-h_min, h_min)
        Fi, Ti, Tj, dn, dt_ = pair(ai, aj, n, h, vij, wi, wj, h_min)
        power = -(Fi @ vij + Ti @ wi + Tj @ wj)
        scale = np.abs(Fi).max() * np.abs(vij).max() + np.abs(Ti).max() * np.abs(wi).max() \
            + np.abs(Tj).max() * np.abs(wj).max()
        assert dn >= 0.0 and dt_ >= 0.0
        assert_squeeze_dissipation(dn, x11a_jo84(ai, aj, max(h, h_min)), n, vij)
        assert abs(dn + dt_ - power) <= 1e-12 * scale
        # the tangential part is what the tangential force and the torques dissipate
        Ft = Fi - np.dot(Fi, n) * n
        assert abs(dt_ + (Ft @ vij + Ti @ wi + Tj @ wj)) <= 1e-12 * scale


# ------------------------------------------------------------------------------------------------
# wall
# ------------------------------------------------------------------------------------------------

def test_wall_is_the_large_sphere_limit():
    """A sphere against a sphere of radius 1e6 a (beta -> infinity) moving rigidly (centre velocity
    v_j, spin W) acts like a wall with surface velocity u(x_c) = v_j + W x a_j n at the closest point
    and angular velocity W. The pair log is ln((a_i + a_j)/2h), the wall log ln(a/h): they differ
    by a constant ln((1 + beta)/2), so compare differences between two gaps."""
    rng = np.random.default_rng(3)
    a, aj = A, 1e6 * A
    h1, h2 = 0.002 * A, 0.05 * A
    # scalars: X, YA, YB, YC
    p1, p2 = pair_resistances(a, aj, h1, 0.0, ETA), pair_resistances(a, aj, h2, 0.0, ETA)
    w1, w2 = wall_resistances(a, h1, 0.0, ETA), wall_resistances(a, h2, 0.0, ETA)
    np.testing.assert_allclose([p1[k] - p2[k] for k in (0, 1, 2, 4)],
                               [w1[k] - w2[k] for k in range(4)], rtol=1e-5)
    for ww_on in (0.0, 1.0):
        for _ in range(10):
            n = unit(rng)
            # surface velocity uc at the closest point of order 1, so that the O(1) terms are
            # tested, also those of the wall spin W (a W x n, w_i - W)
            vi, uc, wi = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3) / a
            W = ww_on * rng.normal(size=3) / a
            vj = uc - np.cross(W, aj * n)
            vc = vi - uc
            dp = [np.subtract(x, y) for x, y in zip(pair(a, aj, n, h1, vi - vj, wi, W),
                                                   pair(a, aj, n, h2, vi - vj, wi, W))]
            dw = [np.subtract(x, y) for x, y in zip(wall(a, n, h1, vc, wi, W), wall(a, n, h2, vc, wi, W))]
            scale = np.abs(dw[0]).max()
            np.testing.assert_allclose(dp[0], dw[0], rtol=0, atol=2e-5 * scale)
            np.testing.assert_allclose(dp[1], dw[1], rtol=0, atol=2e-5 * scale * a)
            np.testing.assert_allclose([dp[3], dp[4]], [dw[2], dw[3]], rtol=2e-5,
                                       atol=2e-5 * scale * np.abs(vc).max())


def test_wall_frame_and_dissipation():
    rng = np.random.default_rng(4)
    h_min = 0.002 * A
    for _ in range(50):
        n, h = unit(rng), rng.uniform(-h_min, 0.1 * A)
        vc, wi, ww = rng.normal(size=3), rng.normal(size=3) / A, rng.normal(size=3) / A
        F, T, dn, dt_ = wall(A, n, h, vc, wi, ww, h_min)
        vs, ws = vc - A * np.cross(ww, n), wi - ww
        scale = np.abs(F).max() * np.abs(vs).max() + np.abs(T).max() * np.abs(ws).max()
        assert dn >= 0 and dt_ >= 0
        assert abs(dn + dt_ + F @ vs + T @ ws) <= 1e-12 * scale
        assert_squeeze_dissipation(dn, x_wall(A, max(h, h_min)), n, vc)
        # co-moving with the wall: nothing
        F0, T0, dn0, dt0 = wall(A, n, h, A * np.cross(ww, n), ww, ww, h_min)
        assert np.abs(F0).max() < 1e-12 * np.abs(F).max()
        assert np.abs(T0).max() < 1e-12 * A * np.abs(F).max()
        assert dn0 + dt0 < 1e-20 * scale
        # spin about the normal (a disc face turning in its plane) changes nothing
        F1, T1, _, _ = wall(A, n, h, vc, wi, 2.0 * n / A, h_min)
        F2, T2, _, _ = wall(A, n, h, vc, wi, np.zeros(3), h_min)
        np.testing.assert_allclose(F1, F2, rtol=1e-12, atol=1e-14 * np.abs(F2).max())
        np.testing.assert_allclose(T1, T2, rtol=1e-10, atol=1e-12 * np.abs(T2).max())
    # fixed wall, sphere moving along +x just above the plane z = 0, no spin: drag along -x and a
    # torque that rolls it forward (about +y): T = YB (v x n) = YB (x x z) = -YB y, YB < 0
    F, T, _, _ = wall(A, np.array([0, 0, 1.0]), 0.01 * A, np.array([1.0, 0, 0]), np.zeros(3))
    assert F[0] < 0 and abs(F[1]) <= 1e-15 * abs(F[0]) and abs(F[2]) <= 1e-15 * abs(F[0])
    assert T[1] > 0
    # X_w is about 4 times the equal-sphere X11A at the same gap (lubrication.md 2.5)
    ratio = wall_resistances(A, 0.002 * A, 0, ETA)[0] / pair_resistances(A, A, 0.002 * A, 0, ETA)[0]
    assert 3.9 < ratio < 4.0


# ------------------------------------------------------------------------------------------------
# dynamics: squeeze film under a constant load
# ------------------------------------------------------------------------------------------------

def test_squeeze_under_constant_force_follows_the_analytic_solution():
    """Two equal spheres (mass m, reduced mass mu = m/2) pushed together by a constant force F0.

    Relative motion along n: mu dv/dt = -X(h) v - F0, v = dh/dt, with
    X(h) = 6 pi eta a [a/(4h) + (9/40) ln(a/h)] for h >= h_min and X(h_min) below (clip).
    With G(h) = int X dh = 6 pi eta a [(a/4) ln h + (9/40)(h ln(a/h) + h)] (h >= h_min) and
    G(h) = G(h_min) + X(h_min)(h - h_min) below, the ODE integrates once exactly:

        mu v(t) + G(h(t)) + F0 t = mu v0 + G(h0)                                    (1)

    Overdamped (quasi-static) limit mu -> 0: dh/dt = -F0/X(h), so

        t(h) = [G(h0) - G(h)] / F0,                                                 (2)

    i.e. t = (6 pi eta a/F0) [(a/4) ln(h0/h) + (9/40)(h0 ln(a/h0) + h0 - h ln(a/h) - h)] above
    h_min, then linear in h at the clipped rate F0/X(h_min), through contact (h < 0).
    At first order in mu, (1) - (2) gives the inertial lag of the real gap behind (2):
    G(h) - G(h_qs) = mu (v0 - v)  =>  h - h_qs = mu (v0 + F0/X(h_qs)) / X(h_qs).
    The force comes from the kernel; (1) checks it exactly, (2) plus the lag to 1e-3 of the lag.
    """
    eta, a = 10.0, A
    m = 4 / 3 * PI * a**3 * RHO
    mu = m / 2
    h_min, h0, F0 = 0.002 * a, 0.1 * a, 1e-4
    c = 6 * PI * eta * a

    def X(h):
        he = max(h, h_min)
        return c * (a / (4 * he) + 9 / 40 * math.log(a / he))

    def G(h):
        he = max(h, h_min)
        g = c * (a / 4 * math.log(he) + 9 / 40 * (he * math.log(a / he) + he))
        return g + (X(h_min) * (h - h_min) if h < h_min else 0.0)

    def rhs(t, y):
        h, v = y
        # i above j on z, so n = +z and v_ij . n = dh/dt; F_i.n from the kernel
        fn = pair_force_torque(a, a, 0.0, 0.0, 1.0, h, 0.0, 0.0, v, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                               h_min, eta)[2]
        return [v, (fn - F0) / mu]

    t_end = (G(h0) - G(-h_min)) / F0
    v0 = -F0 / X(h0)
    sol = solve_ivp(rhs, (0.0, t_end), [h0, v0], method="Radau", rtol=1e-10, atol=[1e-14, 1e-12],
                    dense_output=True)
    assert sol.success
    inv0 = mu * v0 + G(h0)
    for t, h, v in zip(sol.t, sol.y[0], sol.y[1]):
        assert abs(mu * v + G(h) + F0 * t - inv0) <= 1e-7 * F0 * t_end
    # overdamped solution (2): the gap at the analytic times, above the clip, below it, in overlap
    for h in (0.05 * a, 0.01 * a, 0.004 * a, h_min, 0.0, -0.5 * h_min):
        t = (G(h0) - G(h)) / F0
        lag = mu * (v0 + F0 / X(h)) / X(h)
        assert abs(sol.sol(t)[0] - h - lag) <= 1e-3 * abs(lag) + 1e-9 * h_min
        assert abs(lag) < 1e-3 * h_min  # quasi-static to 0.1 % of h_min
    assert sol.y[0, -1] < 0.0  # the lubrication force stays finite through contact


# ------------------------------------------------------------------------------------------------
# time step
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("eta,x11a,dt_fcc,dt_wall", [
    (0.001, 2.14e-3, 1.4e-3, 9.5e-4),
    (0.01, 2.14e-2, 1.4e-4, 9.5e-5),
    (0.1, 0.214, 1.4e-5, 9.5e-6),
    (1.0, 2.14, 1.4e-6, 9.5e-7),
])
def test_dt_limit_reproduces_the_reference_table(eta, x11a, dt_fcc, dt_wall):
    """lubrication.md 4.4: 1.8 mm beads, rho 4000, h_min = 0.001 d; 2/lambda with the half-step
    Verlet. This engine's Verlet (velocity v + dt a in the force) is stable to g dt <= 1 only."""
    m = 4 / 3 * PI * A**3 * RHO
    h_min = 0.001 * 2 * A
    lim = lubrication_dt_limit(eta, h_min, A, m, 0.0, 0.0, integrator="verlet_half_step")
    np.testing.assert_allclose(lim.X11A_hmin / (6 * PI * eta * A), 126.4, rtol=1e-3)
    np.testing.assert_allclose(lim.X_w / (6 * PI * eta * A), 501.2, rtol=1e-3)
    np.testing.assert_allclose(lim.X11A_hmin, x11a, rtol=5e-3)
    np.testing.assert_allclose(m / (4 * lim.X11A_hmin), dt_fcc, rtol=2e-2)
    np.testing.assert_allclose(lim.dt_stable, dt_wall, rtol=5e-3)
    np.testing.assert_allclose(lim.lambda_c, (8 * lim.X11A_hmin + lim.X_w) / m, rtol=1e-12)
    engine = lubrication_dt_limit(eta, h_min, A, m, 0.0, 0.0)
    np.testing.assert_allclose(engine.dt_stable, 0.5 * dt_wall, rtol=5e-3)
    # the rule of thumb m h_min/(6 pi eta a^2) is the FCC limit m/(4 X11A) to 1.2 % (log term)
    np.testing.assert_allclose(m * h_min / (6 * PI * eta * A**2), m / (4 * lim.X11A_hmin), rtol=1.2e-2)
    msg = engine.message(1.0)
    for part in (f"eta = {eta:g} Pa s", "h_min = 1.8e-06 m", f"m_min = {m:.4g} kg", "lambda_c",
                 "larger h_min"):
        assert part in msg


def test_dt_limit_reports_its_lambdas_and_refuses_above():
    """lambda_c = (8 X11A(h_min) + X_w(h_min))/m + gamma_n and lambda_k = 2 k_n/m
    (lubrication.md 4.3-4.5, coded here); the contact part only lowers the limit; check() passes
    a step below dt_stable and refuses one above, naming the limit. Whether dt_stable is where the
    compiled integrators turn unstable: tests/test_lubrication_engine.py (run in the engine)."""
    m = 4 / 3 * PI * A**3 * RHO
    h_min, eta, gamma_n = 0.002 * A, 0.1, 50.0
    for integrator in ("verlet", "verlet_half_step", "gear"):
        for k_n in (0.0, 1e3, 1e5):
            lim = lubrication_dt_limit(eta, h_min, A, m, k_n, gamma_n, integrator=integrator)
            np.testing.assert_allclose(lim.lambda_k, 2 * k_n / m, rtol=1e-12)
            np.testing.assert_allclose(
                lim.lambda_c, (8 * x11a_jo84(A, A, h_min, eta) + x_wall(A, h_min, eta)) / m + gamma_n,
                rtol=1e-12)
            assert lim.dt_lubrication_only >= lim.dt_stable
            assert lim.check(0.99 * lim.dt_stable) == pytest.approx(0.99 * lim.dt_stable, rel=1e-15)
            with pytest.raises(ValueError, match="exceeds the stability limit"):
                lim.check(1.01 * lim.dt_stable)


def test_stability_dt_closed_forms():
    """Closed forms of the two Verlet variants on x'' = -lk x - lc x' (lubrication.md 4.2):
    pure damping g dt <= 1 (this engine's Verlet: the force sees v + dt a, eigenvalue -1 at
    g dt = 1) and <= 2 (half-step Verlet); a pure spring w dt <= 2 for both. The Gear value has no
    closed form: it is checked against the compiled Gear corrector in
    tests/test_lubrication_engine.py and against the textbook Gear step in
    tests/test_integrators.py."""
    np.testing.assert_allclose(stability_dt(1.0, 0.0, "verlet"), 1.0, rtol=1e-15)
    np.testing.assert_allclose(stability_dt(1.0, 0.0, "verlet_half_step"), 2.0, rtol=1e-15)
    np.testing.assert_allclose(stability_dt(0.0, 4.0, "verlet"), 1.0, rtol=1e-15)
    np.testing.assert_allclose(stability_dt(0.0, 4.0, "verlet_half_step"), 1.0, rtol=1e-15)
    with pytest.raises(ValueError, match="integrator"):
        stability_dt(1.0, 0.0, "euler")



def _touching_pairs(pos, box, cut):
    """(i, j, d, |d|) of the periodic pairs closer than ``cut`` (d = minimum image x_i - x_j)."""
    for i in range(len(pos)):
        for j in range(i + 1, len(pos)):
            d = pos[i] - pos[j]
            d -= box * np.round(d / box)
            r = np.linalg.norm(d)
            if r < cut:
                yield i, j, d, r

def test_fcc_bound_covers_the_full_model():
    """Periodic FCC of equal beads, every gap at h_min, full lubrication (squeeze, shear, B and C
    terms, rotations with I = 2/5 m a^2). The squeeze part alone has its largest rate at exactly
    8 X11A(h_min)/m (lubrication.md 4.3); the tangential terms add < 1 % at xi = 0.002 (a PSD sum
    only raises eigenvalues), and the wall term of the reported lambda_c covers that."""
    eta, h_min = 0.1, 0.002 * A
    m = 4 / 3 * PI * A**3 * RHO
    inertia = 0.4 * m * A**2
    s = 2 * A + h_min
    lat = s * math.sqrt(2)
    nc = 2
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]]) * lat
    pos = np.array([basis[b] + lat * np.array([i, j, k]) for i in range(nc) for j in range(nc)
                    for k in range(nc) for b in range(4)])
    N, box = len(pos), nc * lat
    R = np.zeros((6 * N, 6 * N))
    npairs = 0
    for i, j, d, r in _touching_pairs(pos, box, 1.01 * s):
        npairs += 1
        B = pair_matrix(A, A, d / r, r - 2 * A, h_min, eta)
        idx = np.r_[6 * i:6 * i + 6, 6 * j:6 * j + 6]
        R[np.ix_(idx, idx)] += B
    assert npairs == 6 * N
    w = 1 / np.sqrt(np.tile([m] * 3 + [inertia] * 3, N))
    lam = np.linalg.eigvalsh(w[:, None] * R * w[None, :]).max()
    x11a = x11a_jo84(A, A, h_min, eta)
    assert 8 * x11a / m * (1 - 1e-9) <= lam <= 1.01 * 8 * x11a / m
    assert lubrication_dt_limit(eta, h_min, A, m, 0.0, 0.0).lambda_c >= lam
    # squeeze only: exactly 8 X11A/m
    squeeze = np.zeros((3 * N, 3 * N))
    for i, j, d, r in _touching_pairs(pos, box, 1.01 * s):
        B = x11a * np.outer(d, d) / r**2
        for p, q, sgn in ((i, i, 1), (j, j, 1), (i, j, -1), (j, i, -1)):
            squeeze[3 * p:3 * p + 3, 3 * q:3 * q + 3] += sgn * B
    np.testing.assert_allclose(np.linalg.eigvalsh(squeeze / m).max(), 8 * x11a / m, rtol=1e-9)


# ------------------------------------------------------------------------------------------------
# parameters
# ------------------------------------------------------------------------------------------------

def test_good_parameters():
    np.testing.assert_allclose(check_lubrication_params(0.01, 0.001, 0.05), (0.002, 0.1))
    np.testing.assert_allclose(check_lubrication_params(0.0, 1.8e-6, 90e-6, A), (0.002, 0.1))


@pytest.mark.parametrize("args,match", [
    ((-1e-3, 0.001, 0.05), "eta"),
    ((1e-3, 0.0, 0.05), "h_min"),
    ((1e-3, -0.001, 0.05), "h_min"),
    ((1e-3, 0.05, 0.05), "h_min.*smaller than the outer cutoff"),
    ((1e-3, 0.06, 0.05), "h_min"),
    ((1e-3, 0.001, 0.5), "h_max.*xi"),
    ((1e-3, 1e-6, 1e-3, A), "h_max.*xi"),
    ((float("nan"), 0.001, 0.05), "eta"),
    (("water", 0.001, 0.05), "eta.*number"),
    ((1e-3, 0.001, 0.05, 0.0), "a_min"),
])
def test_bad_parameters_raise(args, match):
    with pytest.raises(ValueError, match=match):
        check_lubrication_params(*args)


@pytest.mark.parametrize("kw,match", [({"eta": -1.0}, "eta"), ({"h_min": 0.0}, "h_min"),
                                      ({"h_min": 2 * A}, "h_min"), ({"m_min": 0.0}, "m_min"),
                                      ({"k_n": -1.0}, "k_n"), ({"integrator": "euler"}, "integrator")])
def test_dt_limit_bad_input(kw, match):
    args = {"eta": 0.1, "h_min": 0.002 * A, "a_min": A, "m_min": 1e-5, "k_n": 1e4, "gamma_n": 0.0}
    args.update(kw)
    with pytest.raises(ValueError, match=match):
        lubrication_dt_limit(**args)
