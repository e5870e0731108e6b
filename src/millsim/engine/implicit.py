"""Linearly implicit pairwise resistance (the implicit lubrication scheme): rows, and the passes of
the conjugate-gradient solve the step loop runs once per step.

Why and how (``docs/lubrication.md``, "Implicit scheme"): a pair resistance of the Jeffrey-Onishi
form dissipates

    D = k_n g_n^2 + k_s |g_s|^2 + k_r |g_r|^2,   with the rows of the pair's velocities
    g_n = n.(v_i - v_j)                               (squeeze)
    g_s = P(v_i - v_j) + b_i (w_i x n) + b_j (w_j x n)  (slip; P = I - n n)
    g_r = (w_i - w_j) x n                             (rolling / pumping)

so its generalised force is -J^T K J V with J these 1 + 3 + 3 rows (the two tangential ones are
vectors in the tangent plane). A wall is the same row with the wall as partner j (its velocity and
spin at the sphere, infinite mass, b_j = -b_i). The loop integrates the resistance over each kick
of the leapfrog (``lub_solver`` in implicit_solve.py), v- -> v+ of length tau, with v_f = v- + tau a the
velocity the other forces alone would give: each row's impulse is
lam = tau k (theta J v+ + (1 - theta) J v-), theta fitted to the row's own relaxation
(``fitted_theta``), so

    v+ = v_f - M^-1 J^T lam,   (C + W) lam = J v_f + (1 - theta)/theta J v-,
    C = diag(1 / (tau k theta)),   W = J M^-1 J^T.

This impulse system is symmetric positive definite; it is solved by conjugate gradients
preconditioned with each row's own 7 x 7 block (exact for an isolated pair), started from the last
step's impulses or from 0. For any number of iterations momentum is exact (every update is an
impulse J^T lam applied equal and opposite to the pair; the angular balance is the lubrication
law's own, lever a_i + a_j). No energy injected is proved for backward Euler (theta = 1 in every
row: any CG iterate started at an objective <= 0 is a Galerkin projection, so the kinetic energy
after the impulse is at most that of v_f, plus the work of moving walls and bodies, whose
velocities enter J v_f) and, for the exact solve, for any theta >= 1/2 common to all rows; for the
fitted per-row theta it is checked, not proved (tests/test_lubrication_implicit.py).

Records (one per Verlet slot in ``Scratch.lub_slots``, one per particle and wall in
``Scratch.lub_rows``), ``RW_*`` offsets; the 7-vectors are ordered (normal, slip x, y, z, roll x,
y, z). They are kept apart from the slot record of the contacts and as narrow as the solve allows
(q = (C + W) p is recomputed rather than stored): the passes are bound by memory traffic.
"""

import math

from numba import njit

RW_ACT = 0  # 1: the row exists this step (gap below h_max), 0: none
RW_N = 1  # unit normal from j (or the wall) to i (3)
RW_K = 4  # k_n [N s/m], k_s [N s/m], k_r [N m s]; after setup the compliances 1/(tau k)
RW_B = 7  # b_i, b_j [m]: slip lever coefficients (Y11B/Y11A, Y21B/Y11A; wall: YB/YA, -YB/YA)
RW_D = 9  # preconditioner: 1/(c_n + W_nn), inverse of the 2 x 2 tangential block (3)
RW_LAM = 13  # impulses (7) [N s, N s (3), N m s (3)]
RW_RES = 20  # residual r = J v_f - (C + W) lam (7)
RW_Z = 27  # preconditioned residual D^-1 r (7)
RW_DIR = 34  # search direction (7)
RW_JM = 41  # J v at the start of the kick (7)
RW_PHI = 48  # (1 - theta)/theta of the normal, slip and roll rows (3)
RW_WIDTH = 51  # a pair's record
RW_VJ = 51  # walls: the partner's velocity (3) and spin (3), the wall's rigid motion at the sphere
RW_WALL_WIDTH = 57
NR = 7
# Scratch.lub_particle columns: the other loads (force, torque), the free velocity (v, w),
# u = M^-1 J^T p (translation, rotation), and the velocity at the kick's start v- (v, w): one record
# per partner for the set-up instead of five arrays
LP_FORCE, LP_VF, LP_U, LP_VM = 0, 6, 12, 18
LP_WIDTH = 24
# Scratch.lub_partner columns (one record per Verlet slot, written by p1_own): the pair's share of
# J^T p on the partner (-F_i, T_j) and the row's p.C p
LPP_CPP = 6
LPP_WIDTH = 7


@njit(inline="always", cache=True)
def row_write(o, n0, n1, n2, kn, ks, kr, bi, bj):
    """A row record from its normal, resistances and slip levers (a wall's record then gets the
    wall's rigid motion at RW_VJ)."""
    o[RW_ACT] = 1.0
    o[RW_N], o[RW_N + 1], o[RW_N + 2] = n0, n1, n2
    o[RW_K], o[RW_K + 1], o[RW_K + 2] = kn, ks, kr
    o[RW_B], o[RW_B + 1] = bi, bj


@njit(inline="always", cache=True)
def fitted_theta(z):
    """theta of the theta-method that decays v' = -(z/tau) v exactly over tau (exponential
    fitting, Liniger & Willoughby 1970): 1/(1 - e^-z) - 1/z, from 1/2 (z -> 0: trapezoidal) to
    1 (z -> infinity: backward Euler). Series below z = 0.1 (the difference cancels there); above
    z = 40, e^-z < 5e-18 is below half an ulp of 1, so expm1(-z) is exactly -1 and is not called
    (most rows of a dense wet bed are that stiff: the set-up pass then skips its most costly
    call, bit for bit)."""
    if z < 0.1:
        z2 = z * z
        return 0.5 + z * (1.0 / 12.0 - z2 * (1.0 / 720.0 - z2 / 30240.0))
    if z > 40.0:
        return 1.0 - 1.0 / z
    return -1.0 / math.expm1(-z) - 1.0 / z


@njit(inline="always", cache=True)
def row_setup(o, tau, mi, ii, mj, ij):
    """The implicit weights and compliances of the row, and the inverse of its block of C + W
    (inverse masses mi, mj and inverse inertias ii, ij; 0 for kinematic partners and walls).

    Each row's force acts at theta v+ + (1 - theta) v- (the kick's end and start), theta fitted
    to the row's own relaxation z = tau k W_rr, so C = 1/(tau k theta) and the right-hand side
    gains (1 - theta)/theta J v- (RW_PHI). A tangential resistance of 0 (its log clamped) leaves
    those rows out: their preconditioner is 0, so they stay 0."""
    kn, ks, kr = o[RW_K], o[RW_K + 1], o[RW_K + 2]
    bi, bj = o[RW_B], o[RW_B + 1]
    wn = mi + mj
    th = fitted_theta(tau * kn * wn)
    cn = 1.0 / (tau * kn * th)
    o[RW_K], o[RW_PHI] = cn, (1.0 - th) / th
    o[RW_D] = 1.0 / (cn + wn)
    t00 = t01 = t11 = 0.0
    cs = cr = phs = phr = 0.0
    if ks > 0.0:
        ws = mi + mj + bi * bi * ii + bj * bj * ij
        th = fitted_theta(tau * ks * ws)
        cs, phs = 1.0 / (tau * ks * th), (1.0 - th) / th
        a = cs + ws
        if kr > 0.0:
            wr = ii + ij
            th = fitted_theta(tau * kr * wr)
            cr, phr = 1.0 / (tau * kr * th), (1.0 - th) / th
            b = bi * ii - bj * ij
            d = cr + wr
            det = a * d - b * b
            t00, t01, t11 = d / det, -b / det, a / det
        else:
            t00 = 1.0 / a
    o[RW_K + 1], o[RW_K + 2] = cs, cr
    o[RW_PHI + 1], o[RW_PHI + 2] = phs, phr
    o[RW_D + 1], o[RW_D + 2], o[RW_D + 3] = t00, t01, t11


@njit(inline="always", cache=True)
def row_jv(o, vi0, vi1, vi2, wi0, wi1, wi2, vj0, vj1, vj2, wj0, wj1, wj2):
    """The 7 row velocities J V of (v_i, w_i, v_j, w_j)."""
    n0, n1, n2 = o[RW_N], o[RW_N + 1], o[RW_N + 2]
    bi, bj = o[RW_B], o[RW_B + 1]
    d0, d1, d2 = vi0 - vj0, vi1 - vj1, vi2 - vj2
    vn = d0 * n0 + d1 * n1 + d2 * n2
    s0 = wi1 * n2 - wi2 * n1  # w_i x n
    s1 = wi2 * n0 - wi0 * n2
    s2 = wi0 * n1 - wi1 * n0
    t0 = wj1 * n2 - wj2 * n1  # w_j x n
    t1 = wj2 * n0 - wj0 * n2
    t2 = wj0 * n1 - wj1 * n0
    return (vn,
            d0 - vn * n0 + bi * s0 + bj * t0, d1 - vn * n1 + bi * s1 + bj * t1,
            d2 - vn * n2 + bi * s2 + bj * t2,
            s0 - t0, s1 - t1, s2 - t2)


@njit(inline="always", cache=True)
def row_jt(o, l0, l1, l2, l3, l4, l5, l6):
    """J^T of the row impulses (l0 normal, l1-3 slip, l4-6 roll): (F_i, T_i, T_j); F_j = -F_i."""
    n0, n1, n2 = o[RW_N], o[RW_N + 1], o[RW_N + 2]
    bi, bj = o[RW_B], o[RW_B + 1]
    m0 = n1 * l3 - n2 * l2  # n x slip
    m1 = n2 * l1 - n0 * l3
    m2 = n0 * l2 - n1 * l1
    r0 = n1 * l6 - n2 * l5  # n x roll
    r1 = n2 * l4 - n0 * l6
    r2 = n0 * l5 - n1 * l4
    return (l0 * n0 + l1, l0 * n1 + l2, l0 * n2 + l3,
            bi * m0 + r0, bi * m1 + r1, bi * m2 + r2,
            bj * m0 - r0, bj * m1 - r1, bj * m2 - r2)


@njit(inline="always", cache=True)
def row_precondition(o):
    """z = D^-1 r stored; returns r.z."""
    dn, t00, t01, t11 = o[RW_D], o[RW_D + 1], o[RW_D + 2], o[RW_D + 3]
    rho = dn * o[RW_RES] * o[RW_RES]
    o[RW_Z] = dn * o[RW_RES]
    for a in range(1, 4):  # slip a, roll a + 3 (one 2 x 2 block per direction)
        rs, rr = o[RW_RES + a], o[RW_RES + a + 3]
        zs, zr = t00 * rs + t01 * rr, t01 * rs + t11 * rr
        o[RW_Z + a], o[RW_Z + a + 3] = zs, zr
        rho += rs * zs + rr * zr
    return rho


@njit(inline="always", cache=True)
def row_absent(o):
    """No row this step; its impulses are forgotten (a later row starts cold)."""
    if o[RW_ACT] != 0.0:
        for k in range(NR):
            o[RW_LAM + k] = 0.0
    o[RW_ACT] = 0.0


@njit(inline="always", cache=True)
def row_begin(o, warm, f0, f1, f2, f3, f4, f5, f6, j0, j1, j2, j3, j4, j5, j6):
    """Start the solve at the row: b = J v_f + (1 - theta)/theta J v- (f0..f6 = J v_f, J v- in
    RW_JM); lam kept from the last step (``warm``; J u = (j0..j6) is J M^-1 J^T of those
    impulses) or 0, r = b - (C + W) lam, z = D^-1 r, and b kept in the direction's place until
    the first iteration (which multiplies it by beta = 0). Returns (r.z, b.D^-1 b, lam.(b + r)):
    the last is -2 f(lam), f the solve's objective."""
    cn, cs, cr = o[RW_K], o[RW_K + 1], o[RW_K + 2]
    pn, ps, pr = o[RW_PHI], o[RW_PHI + 1], o[RW_PHI + 2]
    b0 = f0 + pn * o[RW_JM]
    b1, b2, b3 = f1 + ps * o[RW_JM + 1], f2 + ps * o[RW_JM + 2], f3 + ps * o[RW_JM + 3]
    b4, b5, b6 = f4 + pr * o[RW_JM + 4], f5 + pr * o[RW_JM + 5], f6 + pr * o[RW_JM + 6]
    b = (b0, b1, b2, b3, b4, b5, b6)
    ju = (j0, j1, j2, j3, j4, j5, j6)
    fch = 0.0
    for k in range(NR):
        c = cn if k == 0 else (cs if k < 4 else cr)
        o[RW_DIR + k] = b[k]
        if warm:
            lam = o[RW_LAM + k]
            r = b[k] - c * lam - ju[k]
            fch += lam * (b[k] + r)
            o[RW_RES + k] = r
        else:
            o[RW_LAM + k] = 0.0
            o[RW_RES + k] = b[k]
    dn, t00, t01, t11 = o[RW_D], o[RW_D + 1], o[RW_D + 2], o[RW_D + 3]
    bb = (dn * b0 * b0 + t00 * (b1 * b1 + b2 * b2 + b3 * b3)
          + 2.0 * t01 * (b1 * b4 + b2 * b5 + b3 * b6) + t11 * (b4 * b4 + b5 * b5 + b6 * b6))
    return row_precondition(o), bb, fch


@njit(inline="always", cache=True)
def row_restart(o):
    """Back to lam = 0, r = b (kept in the direction's place by row_begin); returns r.z."""
    for k in range(NR):
        o[RW_LAM + k] = 0.0
        o[RW_RES + k] = o[RW_DIR + k]
    return row_precondition(o)


@njit(inline="always", cache=True)
def row_combine(o, a, beta):
    """o[a:a+7] + beta * (the stored direction)."""
    return (o[a] + beta * o[RW_DIR], o[a + 1] + beta * o[RW_DIR + 1],
            o[a + 2] + beta * o[RW_DIR + 2], o[a + 3] + beta * o[RW_DIR + 3],
            o[a + 4] + beta * o[RW_DIR + 4], o[a + 5] + beta * o[RW_DIR + 5],
            o[a + 6] + beta * o[RW_DIR + 6])


@njit(inline="always", cache=True)
def row_cpp(o, p0, p1, p2, p3, p4, p5, p6):
    """p.C p of the row."""
    return (o[RW_K] * p0 * p0 + o[RW_K + 1] * (p1 * p1 + p2 * p2 + p3 * p3)
            + o[RW_K + 2] * (p4 * p4 + p5 * p5 + p6 * p6))


@njit(inline="always", cache=True)
def row_advance(o, alpha, j0, j1, j2, j3, j4, j5, j6):
    """lam += alpha p, r -= alpha (C p + J u) with the direction p stored by the first pass and
    J u = (j0..j6), z = D^-1 r; returns the new r.z."""
    cn, cs, cr = o[RW_K], o[RW_K + 1], o[RW_K + 2]
    ju = (j0, j1, j2, j3, j4, j5, j6)
    for k in range(NR):
        c = cn if k == 0 else (cs if k < 4 else cr)
        p = o[RW_DIR + k]
        o[RW_LAM + k] += alpha * p
        o[RW_RES + k] -= alpha * (c * p + ju[k])
    return row_precondition(o)


@njit(inline="always", cache=True)
def row_impulse(o):
    """J^T lam of the row: (F_i, T_i, T_j) impulses."""
    return row_jt(o, o[RW_LAM], o[RW_LAM + 1], o[RW_LAM + 2], o[RW_LAM + 3], o[RW_LAM + 4],
                  o[RW_LAM + 5], o[RW_LAM + 6])


@njit(inline="always", cache=True)
def row_power(o, tau):
    """Power of the row's force over the kick, normal and tangential [W]: lam/tau times J v at
    the mean of the kick's start and end velocities. For a step that is the step's own velocity
    (leapfrog), so the loop's trapezoid sums the work lam.J v exactly, step by step; for the
    half kick of the start state (prime) it is the work of that half kick. After the solve
    J v_end = r + C lam - (1 - theta)/theta J v_start (the residual's definition)."""
    cn, cs, cr = o[RW_K], o[RW_K + 1], o[RW_K + 2]
    pn, ps, pr = o[RW_PHI], o[RW_PHI + 1], o[RW_PHI + 2]
    pwn = pwt = 0.0
    for k in range(NR):
        c = cn if k == 0 else (cs if k < 4 else cr)
        ph = pn if k == 0 else (ps if k < 4 else pr)
        lam = o[RW_LAM + k]
        jm = o[RW_JM + k]
        jv = 0.5 * (jm + o[RW_RES + k] + c * lam - ph * jm)
        if k == 0:
            pwn = lam * jv / tau
        else:
            pwt += lam * jv / tau
    return pwn, pwt


@njit(inline="always", cache=True)
def pair_ju(o, LP, i, j):
    """J u of a pair row, u = M^-1 J^T p of both particles (Scratch.lub_particle)."""
    return row_jv(o, LP[i, LP_U], LP[i, LP_U + 1], LP[i, LP_U + 2], LP[i, LP_U + 3],
                  LP[i, LP_U + 4], LP[i, LP_U + 5], LP[j, LP_U], LP[j, LP_U + 1],
                  LP[j, LP_U + 2], LP[j, LP_U + 3], LP[j, LP_U + 4], LP[j, LP_U + 5])


# ---- the passes (factories: the spec's options become the closure's constants) -----------------
def lub_kernels(spec, layout, block):
    """Block kernels of the solve: (setup_particles, p1_own, p1_partner, setup_slots, restart,
    p3).

    Each works on the particles ``block`` * blk ... and their own slots (i of the pair), so every
    record has one writer and every partial sum one block: the result does not depend on the
    thread count.
    """
    setup_particles, setup_slots = _setup_kernels(spec, block)
    p1_own, p1_partner = _product_kernels(spec, block)
    restart, p3 = _update_kernels(spec, block)
    return setup_particles, p1_own, p1_partner, setup_slots, restart, p3


def _setup_kernels(spec, block):
    """The start of a solve: free velocities, wall rows, right-hand side and first residual."""
    GRAVITY, WALLS = spec.gravity, spec.walls

    def setup_particles(blk, back, tau, P, R, S):
        """Free velocity v_f = v_base + tau a (a: the other loads; v_base = v - back acc); the wall
        rows' compliances and preconditioner."""
        v, w, acc, alpha = P.v, P.w, P.acc, P.alpha
        LP, WR = S.lub_particle, S.lub_rows
        for i in range(blk * block, min(v.shape[0], (blk + 1) * block)):
            if P.body[i] >= 0:  # prescribed: the kick does not change it
                for a in range(3):
                    LP[i, LP_VF + a] = v[i, a]
                    LP[i, LP_VF + 3 + a] = w[i, a]
                    LP[i, LP_VM + a] = v[i, a]
                    LP[i, LP_VM + 3 + a] = w[i, a]
                continue
            vb0 = v[i, 0] - back * acc[i, 0]
            vb1 = v[i, 1] - back * acc[i, 1]
            vb2 = v[i, 2] - back * acc[i, 2]
            wb0 = w[i, 0] - back * alpha[i, 0]
            wb1 = w[i, 1] - back * alpha[i, 1]
            wb2 = w[i, 2] - back * alpha[i, 2]
            LP[i, LP_VM], LP[i, LP_VM + 1], LP[i, LP_VM + 2] = vb0, vb1, vb2
            LP[i, LP_VM + 3], LP[i, LP_VM + 4], LP[i, LP_VM + 5] = wb0, wb1, wb2
            im, ii = P.inv_mass[i], P.inv_inertia[i]
            a0, a1, a2 = LP[i, LP_FORCE] * im, LP[i, LP_FORCE + 1] * im, LP[i, LP_FORCE + 2] * im
            if GRAVITY:
                a0 += R.gravity[0]
                a1 += R.gravity[1]
                a2 += R.gravity[2]
            LP[i, LP_VF], LP[i, LP_VF + 1] = vb0 + tau * a0, vb1 + tau * a1
            LP[i, LP_VF + 2] = vb2 + tau * a2
            LP[i, LP_VF + 3] = wb0 + tau * LP[i, LP_FORCE + 3] * ii
            LP[i, LP_VF + 4] = wb1 + tau * LP[i, LP_FORCE + 4] * ii
            LP[i, LP_VF + 5] = wb2 + tau * LP[i, LP_FORCE + 5] * ii
            if WALLS:
                for iw in range(WR.shape[1]):
                    o = WR[i, iw]
                    if o[RW_ACT] == 0.0:
                        continue
                    row_setup(o, tau, im, ii, 0.0, 0.0)
                    jm = row_jv(o, vb0, vb1, vb2, wb0, wb1, wb2, o[RW_VJ], o[RW_VJ + 1],
                                o[RW_VJ + 2], o[RW_VJ + 3], o[RW_VJ + 4], o[RW_VJ + 5])
                    for k in range(NR):
                        o[RW_JM + k] = jm[k]

    def setup_slots(blk, back, tau, warm, P, C, S):
        """Start the solve at every row of the block (pairs it owns, its particles' walls):
        b = J v_f, r = b - (C + W) lam (lam kept from the last step when ``warm``; u = M^-1 J^T lam
        from p1), z; partials lam.(b + r), r.z and b.D^-1 b into cg_part[blk, 0:3]."""
        body = P.body
        start, nbr, rows, LP, WR = C.start, C.nbr, S.lub_slots, S.lub_particle, S.lub_rows
        rho = bb = fch = 0.0
        for i in range(blk * block, min(body.shape[0], (blk + 1) * block)):
            for k in range(start[i], start[i + 1]):
                o = rows[k]
                if o[RW_ACT] == 0.0:
                    continue
                j = nbr[k]
                row_setup(o, tau, P.inv_mass[i], P.inv_inertia[i], P.inv_mass[j],
                          P.inv_inertia[j])
                b = row_jv(o, LP[i, LP_VF], LP[i, LP_VF + 1], LP[i, LP_VF + 2],
                           LP[i, LP_VF + 3], LP[i, LP_VF + 4], LP[i, LP_VF + 5],
                           LP[j, LP_VF], LP[j, LP_VF + 1], LP[j, LP_VF + 2],
                           LP[j, LP_VF + 3], LP[j, LP_VF + 4], LP[j, LP_VF + 5])
                jm = row_jv(o, LP[i, LP_VM], LP[i, LP_VM + 1], LP[i, LP_VM + 2],
                            LP[i, LP_VM + 3], LP[i, LP_VM + 4], LP[i, LP_VM + 5],
                            LP[j, LP_VM], LP[j, LP_VM + 1], LP[j, LP_VM + 2],
                            LP[j, LP_VM + 3], LP[j, LP_VM + 4], LP[j, LP_VM + 5])
                for q in range(NR):
                    o[RW_JM + q] = jm[q]
                ju = pair_ju(o, LP, i, j)
                r = row_begin(o, warm, b[0], b[1], b[2], b[3], b[4], b[5], b[6],
                              ju[0], ju[1], ju[2], ju[3], ju[4], ju[5], ju[6])
                rho += r[0]
                bb += r[1]
                fch += r[2]
            if WALLS and body[i] < 0:
                for iw in range(WR.shape[1]):
                    o = WR[i, iw]
                    if o[RW_ACT] == 0.0:
                        continue
                    b = row_jv(o, LP[i, LP_VF], LP[i, LP_VF + 1], LP[i, LP_VF + 2],
                               LP[i, LP_VF + 3], LP[i, LP_VF + 4], LP[i, LP_VF + 5],
                               o[RW_VJ], o[RW_VJ + 1], o[RW_VJ + 2], o[RW_VJ + 3], o[RW_VJ + 4],
                               o[RW_VJ + 5])
                    ju = row_jv(o, LP[i, LP_U], LP[i, LP_U + 1], LP[i, LP_U + 2],
                                LP[i, LP_U + 3], LP[i, LP_U + 4], LP[i, LP_U + 5],
                                0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
                    r = row_begin(o, warm, b[0], b[1], b[2], b[3], b[4], b[5], b[6],
                                  ju[0], ju[1], ju[2], ju[3], ju[4], ju[5], ju[6])
                    rho += r[0]
                    bb += r[1]
                    fch += r[2]
        S.cg_part[blk, 0] = fch
        S.cg_part[blk, 1] = rho
        S.cg_part[blk, 2] = bb

    return setup_particles, setup_slots


def _product_kernels(spec, block):
    """u = M^-1 J^T p in two halves (own rows, then partner shares and walls) and p.(C + W) p."""
    WALLS = spec.walls

    def p1_own(blk, beta, a, P, C, S):
        """First half of u = M^-1 J^T p, for p = o[a:a+7] + beta (stored direction) of every row:
        the new direction z + beta p (a = RW_Z: stored in its place for the second half and p3),
        or the impulses kept from the last step (a = RW_LAM, beta = 0). Sums J^T p of the rows a
        particle owns into its u columns and writes each pair's share on the partner
        (S.lub_partner: -F_i, T_j, and the row's p.C p; zero where no row), so the second half
        reads one narrow record per slot instead of the row's wide one (at a scattered place for
        the partner's share)."""
        start, rows, partner, LP = C.start, S.lub_slots, S.lub_partner, S.lub_particle
        store = a == RW_Z
        for i in range(blk * block, min(P.x.shape[0], (blk + 1) * block)):
            F0 = F1 = F2 = T0 = T1 = T2 = 0.0
            for k in range(start[i], start[i + 1]):
                o = rows[k]
                if o[RW_ACT] == 0.0:
                    for c in range(LPP_WIDTH):
                        partner[k, c] = 0.0
                    continue
                p = row_combine(o, a, beta)
                if store:
                    for c in range(NR):
                        o[RW_DIR + c] = p[c]
                f = row_jt(o, p[0], p[1], p[2], p[3], p[4], p[5], p[6])
                F0 += f[0]
                F1 += f[1]
                F2 += f[2]
                T0 += f[3]
                T1 += f[4]
                T2 += f[5]
                partner[k, 0], partner[k, 1], partner[k, 2] = f[0], f[1], f[2]
                partner[k, 3], partner[k, 4], partner[k, 5] = f[6], f[7], f[8]
                partner[k, LPP_CPP] = row_cpp(o, p[0], p[1], p[2], p[3], p[4], p[5], p[6])
            if P.body[i] >= 0:
                continue  # infinite mass: its u stays 0 (partners read it)
            LP[i, LP_U], LP[i, LP_U + 1], LP[i, LP_U + 2] = F0, F1, F2
            LP[i, LP_U + 3], LP[i, LP_U + 4], LP[i, LP_U + 5] = T0, T1, T2

    def p1_partner(blk, beta, a, P, C, S):
        """Second half: the partner shares and the wall rows added, u = M^-1 J^T p per free
        particle; the block's part of p.(C + W) p = sum of p.C p over its own rows (from
        p1_own's records: 0 where no row) + sum of (J^T p).u over its particles into
        cg_part[blk, 0]."""
        start, rev_start, rev_slot = C.start, C.rev_start, C.rev_slot
        partner, LP, WR = S.lub_partner, S.lub_particle, S.lub_rows
        pq = 0.0
        for i in range(blk * block, min(P.x.shape[0], (blk + 1) * block)):
            for k in range(start[i], start[i + 1]):
                pq += partner[k, LPP_CPP]
            if P.body[i] >= 0:
                continue  # infinite mass: u = 0 (never written), no part in W
            F0, F1, F2 = LP[i, LP_U], LP[i, LP_U + 1], LP[i, LP_U + 2]
            T0, T1, T2 = LP[i, LP_U + 3], LP[i, LP_U + 4], LP[i, LP_U + 5]
            for q in range(rev_start[i], rev_start[i + 1]):
                s = partner[rev_slot[q]]
                F0 -= s[0]
                F1 -= s[1]
                F2 -= s[2]
                T0 += s[3]
                T1 += s[4]
                T2 += s[5]
            if WALLS:
                for iw in range(WR.shape[1]):
                    o = WR[i, iw]
                    if o[RW_ACT] != 0.0:
                        p = row_combine(o, a, beta)
                        if a == RW_Z:
                            for c in range(NR):
                                o[RW_DIR + c] = p[c]
                        pq += row_cpp(o, p[0], p[1], p[2], p[3], p[4], p[5], p[6])
                        f = row_jt(o, p[0], p[1], p[2], p[3], p[4], p[5], p[6])
                        F0 += f[0]
                        F1 += f[1]
                        F2 += f[2]
                        T0 += f[3]
                        T1 += f[4]
                        T2 += f[5]
            im, ii = P.inv_mass[i], P.inv_inertia[i]
            u0, u1, u2, s0, s1, s2 = F0 * im, F1 * im, F2 * im, T0 * ii, T1 * ii, T2 * ii
            LP[i, LP_U], LP[i, LP_U + 1], LP[i, LP_U + 2] = u0, u1, u2
            LP[i, LP_U + 3], LP[i, LP_U + 4], LP[i, LP_U + 5] = s0, s1, s2
            pq += F0 * u0 + F1 * u1 + F2 * u2 + T0 * s0 + T1 * s1 + T2 * s2
        S.cg_part[blk, 0] = pq

    return p1_own, p1_partner


def _update_kernels(spec, block):
    """A CG update of the rows (p3) and the restart from zero impulses."""
    WALLS = spec.walls

    def restart(blk, P, C, S):
        """Every row of the block back to lam = 0 (the kept impulses would not lower the
        objective); partial r.z into cg_part[blk, 1]."""
        start, rows, WR = C.start, S.lub_slots, S.lub_rows
        rho = 0.0
        for i in range(blk * block, min(P.x.shape[0], (blk + 1) * block)):
            for k in range(start[i], start[i + 1]):
                if rows[k, RW_ACT] != 0.0:
                    rho += row_restart(rows[k])
            if WALLS and P.body[i] < 0:
                for iw in range(WR.shape[1]):
                    if WR[i, iw, RW_ACT] != 0.0:
                        rho += row_restart(WR[i, iw])
        S.cg_part[blk, 1] = rho

    def p3(blk, alpha, P, C, S):
        """lam += alpha p, r -= alpha q on the block's rows (p stored by p1_own / p1_partner);
        partial r.D^-1 r into cg_part[blk, 1]."""
        start, nbr, rows, LP, WR = C.start, C.nbr, S.lub_slots, S.lub_particle, S.lub_rows
        rho = 0.0
        for i in range(blk * block, min(P.x.shape[0], (blk + 1) * block)):
            for k in range(start[i], start[i + 1]):
                o = rows[k]
                if o[RW_ACT] != 0.0:
                    ju = pair_ju(o, LP, i, nbr[k])
                    rho += row_advance(o, alpha, ju[0], ju[1], ju[2], ju[3], ju[4], ju[5], ju[6])
            if WALLS and P.body[i] < 0:
                for iw in range(WR.shape[1]):
                    o = WR[i, iw]
                    if o[RW_ACT] != 0.0:
                        ju = row_jv(o, LP[i, LP_U], LP[i, LP_U + 1], LP[i, LP_U + 2],
                                    LP[i, LP_U + 3], LP[i, LP_U + 4], LP[i, LP_U + 5],
                                    0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
                        rho += row_advance(o, alpha, ju[0], ju[1], ju[2], ju[3], ju[4], ju[5],
                                           ju[6])
        S.cg_part[blk, 1] = rho

    return restart, p3
