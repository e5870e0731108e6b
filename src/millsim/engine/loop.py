"""The assembled step loop: one compiled function per physics specification.

``build_chunk_runner(spec)`` returns a numba function that advances the state by ``n_steps`` steps
without returning to Python. The physics options of the spec are frozen into the function as
compile-time constants, and numba prunes the branches of the options that are off *before* typing:
a scene that does not use a term never compiles the kernel for it, and pays nothing for it at run
time. Different specs are cached separately on disk (``cache=True``), so the many short processes of
a sweep compile each variant once.

Each step is two parallel passes plus a short serial part:
1. pairs: every Verlet slot computes its contact force into per-slot arrays (no shared writes);
2. particles, in fixed blocks: gather slot forces in a fixed order, add walls and gravity, finish the
   integrator step, then start the next one (Verlet drift or Gear predictor) and move kinematic-body
   particles to their prescribed pose;
3. serial: reduce body and wall loads over fixed blocks, rebuild the neighbour list when any particle
   moved more than half the skin.
Because no sum depends on how iterations are split among threads, results are bit-identical for any
thread count.
"""

import math

import numpy as np
from numba import njit, prange

from ..breakage.damage import damage_fraction
from . import contact as law
from . import lubrication as lub
from ..breakage.weibull import fracture_probability
from .kinematics import ROTATE, body_pose, wall_contact
from .neighbours import build_verlet, min_image, wrap_periodic
from .rng import hash_uniform

SLOT_WIDTH = 8  # per-slot results, one cache line: force on i, n x F_t, overlap, normal force
# Energy audit terms [J]: contact normal damping, tangential force x centre slip, tangential force x
# rotational slip (+ rolling friction), lubrication normal (squeeze), lubrication tangential.
N_AUDIT = 5
AUDIT_TERMS = ("contact_normal_damping", "contact_tangential_translation",
               "contact_tangential_rotation", "lubrication_normal", "lubrication_tangential")
BLOCK = 256
FAST = law.FAST  # particles per reduction block (fixed, so sums do not depend on the thread count)

# Guard codes written to err[0]; err = [code, step, particle, partner]. With threads the particle
# recorded is whichever got there first; the Python side names a deterministic one.
ERR_OVERLAP, ERR_NONFINITE, ERR_SPEED = 1, 2, 3

# Gear 6-value corrector for velocity-dependent forces (Allen & Tildesley table E.2).
GEAR_C0, GEAR_C1, GEAR_C3, GEAR_C4, GEAR_C5 = 3.0 / 16.0, 251.0 / 360.0, 11.0 / 18.0, 1.0 / 6.0, 1.0 / 60.0


@njit(inline="always", cache=True)
def _verlet_drift(i, dt, x, v, w, acc, alpha):
    """Velocity Verlet drift, leaving the velocities *predicted* to t + dt (v + dt a).

    Forces that depend on velocity (dashpots, friction) then see a second-order estimate of
    v(t + dt) instead of the half-step velocity, which would make the scheme first order for them;
    :func:`_verlet_kick` turns the prediction into the exact Verlet velocity, so for
    velocity-independent forces this is velocity Verlet to the letter.
    """
    for a in range(3):
        x[i, a] += dt * (v[i, a] + 0.5 * dt * acc[i, a])
        v[i, a] += dt * acc[i, a]
        w[i, a] += dt * alpha[i, a]


@njit(inline="always", cache=True)
def _verlet_kick(i, dt, v, w, acc, alpha, a0, a1, a2, b0, b1, b2):
    """Second half kick: v(t+dt) = v(t) + dt (a(t) + a(t+dt)) / 2, from the predicted velocity."""
    v[i, 0] += 0.5 * dt * (a0 - acc[i, 0])
    v[i, 1] += 0.5 * dt * (a1 - acc[i, 1])
    v[i, 2] += 0.5 * dt * (a2 - acc[i, 2])
    w[i, 0] += 0.5 * dt * (b0 - alpha[i, 0])
    w[i, 1] += 0.5 * dt * (b1 - alpha[i, 1])
    w[i, 2] += 0.5 * dt * (b2 - alpha[i, 2])
    acc[i, 0], acc[i, 1], acc[i, 2] = a0, a1, a2
    alpha[i, 0], alpha[i, 1], alpha[i, 2] = b0, b1, b2


@njit(inline="always", cache=True)
def _gear_predict(i, dt, x, v, w, acc, alpha, gear):
    """Taylor predictor of the 6-value Gear scheme for translation and rotation."""
    h2 = dt * dt / 2.0
    h3 = h2 * dt / 3.0
    h4 = h3 * dt / 4.0
    h5 = h4 * dt / 5.0
    for a in range(3):
        b, c, d = gear[i, 0, a], gear[i, 1, a], gear[i, 2, a]
        x[i, a] += dt * v[i, a] + h2 * acc[i, a] + h3 * b + h4 * c + h5 * d
        v[i, a] += dt * acc[i, a] + h2 * b + h3 * c + h4 * d
        acc[i, a] += dt * b + h2 * c + h3 * d
        gear[i, 0, a] = b + dt * c + h2 * d
        gear[i, 1, a] = c + dt * d
        b, c, d = gear[i, 3, a], gear[i, 4, a], gear[i, 5, a]
        w[i, a] += dt * alpha[i, a] + h2 * b + h3 * c + h4 * d
        alpha[i, a] += dt * b + h2 * c + h3 * d
        gear[i, 3, a] = b + dt * c + h2 * d
        gear[i, 4, a] = c + dt * d


@njit(inline="always", cache=True)
def _gear_correct(i, dt, x, v, w, acc, alpha, gear, a0, a1, a2, b0, b1, b2):
    """Corrector of the 6-value Gear scheme, given the evaluated accelerations (a, angular b)."""
    for a in range(3):
        ev = a0 if a == 0 else (a1 if a == 1 else a2)
        dA = ev - acc[i, a]
        x[i, a] += GEAR_C0 * dA * dt * dt / 2.0
        v[i, a] += GEAR_C1 * dA * dt / 2.0
        acc[i, a] = ev
        gear[i, 0, a] += GEAR_C3 * dA * 3.0 / dt
        gear[i, 1, a] += GEAR_C4 * dA * 12.0 / (dt * dt)
        gear[i, 2, a] += GEAR_C5 * dA * 60.0 / (dt * dt * dt)
        ev = b0 if a == 0 else (b1 if a == 1 else b2)
        dA = ev - alpha[i, a]
        w[i, a] += GEAR_C1 * dA * dt / 2.0
        alpha[i, a] = ev
        gear[i, 3, a] += GEAR_C3 * dA * 3.0 / dt
        gear[i, 4, a] += GEAR_C4 * dA * 12.0 / (dt * dt)
        gear[i, 5, a] += GEAR_C5 * dA * 60.0 / (dt * dt * dt)


@njit(inline="always", cache=True)
def _lubricate_pair(o, col_t, col_d, ri, rj, n0, n1, n2, h, v, w, i, j, fluid):
    """Add the pair lubrication of (i, j) to slot record ``o`` when the gap is below h_max.

    Force on i joins the contact force (o[0:3]); the torques on i and j (not opposite for unequal
    radii) go to o[col_t:col_t+6]; the normal and tangential dissipation to o[col_d:col_d+2] when
    col_d >= 0. Cutoffs are fractions of the smaller diameter: fluid = [eta, h_min/d, h_max/d].
    """
    d_min = 2.0 * min(ri, rj)
    if h >= fluid[2] * d_min:
        return
    F0, F1, F2, Ti0, Ti1, Ti2, Tj0, Tj1, Tj2, Dn, Dt = lub.pair_force_torque(
        ri, rj, n0, n1, n2, h, v[i, 0] - v[j, 0], v[i, 1] - v[j, 1], v[i, 2] - v[j, 2],
        w[i, 0], w[i, 1], w[i, 2], w[j, 0], w[j, 1], w[j, 2], fluid[1] * d_min, fluid[0])
    o[0] += F0
    o[1] += F1
    o[2] += F2
    o[col_t], o[col_t + 1], o[col_t + 2] = Ti0, Ti1, Ti2
    o[col_t + 3], o[col_t + 4], o[col_t + 5] = Tj0, Tj1, Tj2
    if col_d >= 0:
        o[col_d] += Dn
        o[col_d + 1] += Dt


@njit(cache=True)
def _room_for(rows, used, needed):
    """``rows`` with room for ``needed`` rows (doubled when it is too small; ``used`` kept)."""
    if needed <= rows.shape[0]:
        return rows
    grown = np.empty((2 * needed, rows.shape[1]))
    grown[:used] = rows[:used]
    return grown


def build_chunk_runner(spec):
    """Compile (or load from cache) the chunk runner for a :class:`~millsim.engine.spec.PhysicsSpec`."""
    # Plain booleans (not comparisons with module attributes) so numba prunes the unused laws
    # before typing them.
    LINEAR_HW = spec.contact_law == "linear_hw"
    LINEAR_HISTORY = spec.contact_law == "linear_history"
    ROLLING = spec.rolling_friction
    GEAR = spec.integrator == "gear"
    CLIP = spec.clip_normal
    GRAVITY = spec.gravity
    WALLS = spec.walls
    BODIES = spec.bodies
    PERIODIC = spec.periodic
    SPRING = law.LAW_HAS_SPRING[spec.contact_law]
    PRESSURE = spec.normal_force_sum
    FRACTURE = spec.fracture == "weibull"
    TAVARES = spec.fracture == "tavares"
    # Contact-event columns after the tangential spring. Weibull (seed 000): largest normal force
    # of the event, twin flag, twin reference overlap (eqs 19-20). Tavares (seed 002): overlap and
    # normal force one step ago (loading work), reference overlap of progeny created inside each
    # other (only overlap beyond it counts).
    C_FMAX = 3 if SPRING else 0
    C_TWIN = C_FMAX + 1
    C_XIP = C_FMAX + 2
    C_PREV, C_FPREV, C_REF = C_FMAX, C_FMAX + 1, C_FMAX + 2
    # Same for wall contacts (wall_hist columns after the tangential spring).
    W_PREV, W_FPREV, W_REF = 3, 4, 5
    LUB = spec.lubrication
    AUDIT = spec.energy_audit
    # Slot record after the 8 base columns: Tavares loading work given to i and to j; lubrication
    # torques on i and on j; energy audit powers (contact normal damping, tangential force on the
    # translational and on the rotational part of the slip, lubrication normal and tangential).
    C_WORK = SLOT_WIDTH
    C_LUB = C_WORK + (2 if TAVARES else 0)
    C_AUD = C_LUB + (6 if LUB else 0)
    SLOT = C_AUD + (N_AUDIT if AUDIT else 0)
    COL_D = C_AUD + 3 if AUDIT else -1

    @njit(parallel=True, cache=True, fastmath=FAST)
    def run_chunk(n_steps, t, dt, P, C, pair_params, walls, wall_hist, bodies, body_members,
                  gravity, box_lo, box_len, skin, dim, max_overlap, v_max,
                  body_load, body_impulse, body_work, wall_impulse, wall_work, counters, err,
                  step0, fracture_params, fractures, n_fractures, breakage, reach, fluid,
                  dissipation):
        n = P.x.shape[0]
        x, v, w, acc, alpha = P.x, P.v, P.w, P.acc, P.alpha
        radius, inv_mass, inv_inertia = P.radius, P.inv_mass, P.inv_inertia
        material, body, x_ref, x_body0, gear = P.material, P.body, P.x_ref, P.x_body0, P.gear
        fn_sum, e_acc, e_frac, break_at_end = P.fn_sum, P.e_acc, P.e_frac, P.break_at_end
        start, nbr, state, rev_start, rev_slot = C.start, C.nbr, C.state, C.rev_start, C.rev_slot
        n_walls = walls.shape[0]
        n_blocks = (n + BLOCK - 1) // BLOCK
        half_skin2 = 0.25 * skin * skin
        v_max2 = v_max * v_max
        rebuild = np.zeros(1, dtype=np.int64)
        wall_part = np.zeros((n_blocks, max(n_walls, 1), 7))
        audit_part = np.zeros((n_blocks if AUDIT else 0, N_AUDIT))

        # Start the first step (Verlet drift / Gear predictor) and place body particles at t + dt.
        for i in prange(n):
            if body[i] < 0:
                if GEAR:
                    _gear_predict(i, dt, x, v, w, acc, alpha, gear)
                else:
                    _verlet_drift(i, dt, x, v, w, acc, alpha)
            elif BODIES:
                p0, p1, p2, u0, u1, u2 = body_pose(bodies[body[i]], x_body0[i], t + dt)
                x[i, 0], x[i, 1], x[i, 2] = p0, p1, p2
                v[i, 0], v[i, 1], v[i, 2] = u0, u1, u2

        steps_done = 0
        # Per-slot results: force on i, n x F_t and the overlap (torque on either body is
        # -(r - xi/2) n x F_t: lever arms that add up to the distance conserve angular momentum),
        # and the rolling torques on i and j when rolling friction is compiled in.
        out = np.empty((nbr.shape[0], SLOT))
        proll = np.empty((nbr.shape[0] if ROLLING else 0, 2, 3))
        # Tavares breakage per particle (flag, direction of its largest contact force).
        brk = np.zeros(n if TAVARES else 0, dtype=np.int8)
        brk_dir = np.zeros((n if TAVARES else 0, 3))
        # Fracture decisions per slot (bit 1: i breaks, bit 2: j breaks), made when an event ends.
        # (np.empty, not np.zeros: numba's parfor pass mishandles np.zeros re-assigned in the step
        # loop; every slot is written in pass 1 before it is read.)
        broke = np.empty(nbr.shape[0] if FRACTURE else 0, dtype=np.int8)
        peak = np.empty(nbr.shape[0] if FRACTURE else 0)
        stop = np.zeros(1, dtype=np.int64)  # a fracture ends the chunk at this step's boundary
        for step in range(n_steps):
            # ---- pass 1: contact forces per Verlet slot --------------------------------------
            for i in prange(n):
                for k in range(start[i], start[i + 1]):
                    j = nbr[k]
                    d0 = x[i, 0] - x[j, 0]
                    d1 = x[i, 1] - x[j, 1]
                    d2 = x[i, 2] - x[j, 2]
                    if PERIODIC:
                        d0 = min_image(d0, 0, box_len)
                        d1 = min_image(d1, 1, box_len)
                        d2 = min_image(d2, 2, box_len)
                    rsum = radius[i] + radius[j]
                    dist2 = d0 * d0 + d1 * d1 + d2 * d2
                    apart = dist2 >= rsum * rsum
                    # Fragments start deeply overlapped by construction: only the overlap beyond
                    # their reference counts (it shrinks as they part); within it they are apart.
                    xi_ref = 0.0
                    if FRACTURE and not apart and state[k, C_TWIN] > 0.0:
                        xi_ref = state[k, C_XIP]
                    if TAVARES and not apart and state[k, C_REF] > 0.0:
                        xi_ref = state[k, C_REF]
                        xi_now = rsum - math.sqrt(dist2)
                        state[k, C_REF] = min(xi_ref, xi_now)
                        apart = xi_now <= xi_ref
                    if apart:
                        if SPRING:
                            state[k, 0] = 0.0
                            state[k, 1] = 0.0
                            state[k, 2] = 0.0
                        if TAVARES:
                            state[k, C_PREV] = 0.0
                            state[k, C_FPREV] = 0.0
                            if dist2 >= rsum * rsum:
                                state[k, C_REF] = 0.0
                        for a in range(SLOT):
                            out[k, a] = 0.0
                        if ROLLING:
                            proll[k, :, :] = 0.0
                        if LUB:
                            dist = math.sqrt(dist2)
                            _lubricate_pair(out[k], C_LUB, COL_D, radius[i], radius[j], d0 / dist,
                                            d1 / dist, d2 / dist, dist - rsum, v, w, i, j, fluid)
                        if FRACTURE:  # (Weibull twins are never "apart" while they overlap)
                            # The contact event ended: one fracture trial per body at its peak force.
                            fmax = state[k, C_FMAX]
                            flag = 0
                            if fmax > 0.0:
                                c_w = fracture_params[0]
                                seed = int(fracture_params[1])
                                if body[i] < 0 and hash_uniform(seed, step0 + step, i, j) < \
                                        fracture_probability(c_w, radius[i], fmax):
                                    flag |= 1
                                if body[j] < 0 and hash_uniform(seed, step0 + step, j, i) < \
                                        fracture_probability(c_w, radius[j], fmax):
                                    flag |= 2
                            broke[k] = flag
                            peak[k] = fmax
                            if flag:
                                stop[0] = 1
                            state[k, C_FMAX] = 0.0
                            state[k, C_TWIN] = 0.0
                            state[k, C_XIP] = 0.0
                        continue
                    dist = math.sqrt(dist2)
                    inv = 1.0 / dist
                    n0, n1, n2 = d0 * inv, d1 * inv, d2 * inv
                    xi = rsum - dist
                    ri, rj = radius[i], radius[j]
                    xi_c = xi - xi_ref  # the overlap the force and the guard see
                    if xi_c > max_overlap * min(ri, rj) and err[0] == 0:
                        err[0], err[1], err[2], err[3] = ERR_OVERLAP, step, i, j
                    # Relative velocity of i's contact point w.r.t. j's: dv - (ai wi + aj wj) x n,
                    # lever arms a = r - xi/2 (the contact point sits mid-overlap).
                    ai = ri - 0.5 * xi
                    aj = rj - 0.5 * xi
                    s0 = ai * w[i, 0] + aj * w[j, 0]
                    s1 = ai * w[i, 1] + aj * w[j, 1]
                    s2 = ai * w[i, 2] + aj * w[j, 2]
                    vr0 = v[i, 0] - v[j, 0] - (s1 * n2 - s2 * n1)
                    vr1 = v[i, 1] - v[j, 1] - (s2 * n0 - s0 * n2)
                    vr2 = v[i, 2] - v[j, 2] - (s0 * n1 - s1 * n0)
                    m_eff = 1.0 / (inv_mass[i] + inv_mass[j])
                    p = pair_params[material[i], material[j]]
                    if FRACTURE and state[k, C_TWIN] > 0.0:
                        # Twin fragments until first separation (seed 000 eqs 19-20): only overlap
                        # beyond the reference (the creation overlap, shrinking as they part)
                        # resists compression; while they part, a small constant force drives them
                        # apart.
                        vn = vr0 * n0 + vr1 * n1 + vr2 * n2
                        ref = state[k, C_XIP]
                        if vn < 0.0:
                            fn = max(p[law.P_K_N] * (xi - ref) - m_eff * p[law.P_GAMMA_N] * vn, 0.0)
                        else:
                            fn = fracture_params[2]
                        state[k, C_XIP] = min(ref, xi)
                        fn_el = fn
                        f0 = 0.0
                        f1 = 0.0
                        f2 = 0.0
                    elif LINEAR_HW:
                        fn, f0, f1, f2 = law.linear_hw(p, xi, n0, n1, n2, vr0, vr1, vr2, m_eff, CLIP)
                        fn_el = p[law.P_K_N] * xi
                    elif LINEAR_HISTORY:
                        fn, f0, f1, f2 = law.linear_history(p, xi, n0, n1, n2, vr0, vr1, vr2, m_eff,
                                                            CLIP, state, k, dt)
                        fn_el = p[law.P_K_N] * xi
                    else:
                        fn, f0, f1, f2, fn_el = law.hertz_mindlin(p, xi_c, n0, n1, n2, vr0, vr1,
                                                                  vr2, m_eff, ri * rj / rsum, CLIP,
                                                                  state, k, dt)
                    o = out[k]
                    o[0] = fn * n0 + f0
                    o[1] = fn * n1 + f1
                    o[2] = fn * n2 + f2
                    o[3] = n1 * f2 - n2 * f1
                    o[4] = n2 * f0 - n0 * f2
                    o[5] = n0 * f1 - n1 * f0
                    o[6] = xi
                    o[7] = fn
                    if LUB or AUDIT:
                        for a in range(C_LUB, SLOT):
                            o[a] = 0.0
                    if AUDIT:
                        # Dissipated power: dashpot part of the normal force, and the tangential
                        # force against the slip of the centres and of the surfaces' rotation.
                        vn = vr0 * n0 + vr1 * n1 + vr2 * n2
                        dv0 = v[i, 0] - v[j, 0]
                        dv1 = v[i, 1] - v[j, 1]
                        dv2 = v[i, 2] - v[j, 2]
                        o[C_AUD] = -(fn - fn_el) * vn
                        o[C_AUD + 1] = -(f0 * dv0 + f1 * dv1 + f2 * dv2)
                        o[C_AUD + 2] = -(f0 * (vr0 - dv0) + f1 * (vr1 - dv1) + f2 * (vr2 - dv2))
                    if LUB:
                        _lubricate_pair(o, C_LUB, COL_D, ri, rj, n0, n1, n2, -xi, v, w, i, j, fluid)
                    if TAVARES:
                        # Loading work (elastic + damping) while the overlap grows, trapezoidal in
                        # the overlap; each body takes the share of eq 4: the other's stiffness
                        # over the sum.
                        dxi = xi_c - state[k, C_PREV]
                        work = 0.5 * (fn + state[k, C_FPREV]) * dxi if dxi > 0.0 else 0.0
                        state[k, C_PREV] = xi_c
                        state[k, C_FPREV] = fn
                        ki = breakage[material[i], 0]
                        kj = breakage[material[j], 0]
                        o[8] = work * kj / (ki + kj)
                        o[9] = work * ki / (ki + kj)
                    if FRACTURE:
                        broke[k] = 0
                        if state[k, C_TWIN] == 0.0 and fn > state[k, C_FMAX]:
                            state[k, C_FMAX] = fn
                    if ROLLING:
                        # EDEM "standard": constant torque opposing each body's own spin.
                        mr = p[law.P_MU_ROLL] * fn_el
                        wi = math.sqrt(w[i, 0] ** 2 + w[i, 1] ** 2 + w[i, 2] ** 2)
                        wj = math.sqrt(w[j, 0] ** 2 + w[j, 1] ** 2 + w[j, 2] ** 2)
                        for a in range(3):
                            proll[k, 0, a] = -mr * ri * w[i, a] / wi if wi > 0.0 else 0.0
                            proll[k, 1, a] = -mr * rj * w[j, a] / wj if wj > 0.0 else 0.0
                        if AUDIT:
                            o[C_AUD + 2] -= (proll[k, 0, 0] * w[i, 0] + proll[k, 0, 1] * w[i, 1]
                                             + proll[k, 0, 2] * w[i, 2] + proll[k, 1, 0] * w[j, 0]
                                             + proll[k, 1, 1] * w[j, 1] + proll[k, 1, 2] * w[j, 2])

            # ---- pass 2: per particle, in fixed blocks ----------------------------------------
            last = step == n_steps - 1 or stop[0] != 0
            for blk in prange(n_blocks):
                for i in range(blk * BLOCK, min(n, (blk + 1) * BLOCK)):
                    F0 = 0.0
                    F1 = 0.0
                    F2 = 0.0
                    C0 = 0.0
                    C1 = 0.0
                    C2 = 0.0
                    R0 = 0.0
                    R1 = 0.0
                    R2 = 0.0
                    FS = 0.0
                    L0 = 0.0  # lubrication torques
                    L1 = 0.0
                    L2 = 0.0
                    EA = 0.0  # loading work absorbed this step (Tavares)
                    FBIG = 0.0  # largest contact normal force and its direction (Tavares)
                    D0 = 0.0
                    D1 = 0.0
                    D2 = 0.0
                    ri = radius[i]
                    for k in range(start[i], start[i + 1]):
                        o = out[k]
                        if PRESSURE:
                            FS += o[7]
                        if TAVARES:
                            EA += o[C_WORK]
                            if o[7] > FBIG:
                                FBIG, D0, D1, D2 = o[7], o[0], o[1], o[2]
                        if LUB:
                            L0 += o[C_LUB]
                            L1 += o[C_LUB + 1]
                            L2 += o[C_LUB + 2]
                        if AUDIT:
                            for a in range(N_AUDIT):
                                audit_part[blk, a] += o[C_AUD + a]
                        F0 += o[0]
                        F1 += o[1]
                        F2 += o[2]
                        arm = ri - 0.5 * o[6]
                        C0 += arm * o[3]
                        C1 += arm * o[4]
                        C2 += arm * o[5]
                        if ROLLING:
                            R0 += proll[k, 0, 0]
                            R1 += proll[k, 0, 1]
                            R2 += proll[k, 0, 2]
                    for q in range(rev_start[i], rev_start[i + 1]):
                        k = rev_slot[q]
                        o = out[k]
                        if PRESSURE:
                            FS += o[7]
                        if TAVARES:
                            EA += o[C_WORK + 1]
                            if o[7] > FBIG:
                                FBIG, D0, D1, D2 = o[7], -o[0], -o[1], -o[2]
                        if LUB:
                            L0 += o[C_LUB + 3]
                            L1 += o[C_LUB + 4]
                            L2 += o[C_LUB + 5]
                        F0 -= o[0]
                        F1 -= o[1]
                        F2 -= o[2]
                        arm = ri - 0.5 * o[6]
                        C0 += arm * o[3]
                        C1 += arm * o[4]
                        C2 += arm * o[5]
                        if ROLLING:
                            R0 += proll[k, 1, 0]
                            R1 += proll[k, 1, 1]
                            R2 += proll[k, 1, 2]
                    T0 = R0 - C0 + L0
                    T1 = R1 - C1 + L1
                    T2 = R2 - C2 + L2
                    if WALLS and body[i] < 0:
                        for iw in range(n_walls):
                            xi, n0, n1, n2, u0, u1, u2 = wall_contact(walls[iw], x[i, 0], x[i, 1],
                                                                      x[i, 2], radius[i])
                            if LUB and -xi < fluid[2] * 2.0 * ri:
                                # Sphere-wall lubrication (also during contact, at h >= h_min); the
                                # wall spins at omega about its axis (0 for planes).
                                om = walls[iw, 8]
                                cp0 = x[i, 0] - walls[iw, 1]
                                cp1 = x[i, 1] - walls[iw, 2]
                                cp2 = x[i, 2] - walls[iw, 3]
                                # the wall's rigid velocity at the sphere's centre
                                uc0 = om * (walls[iw, 5] * cp2 - walls[iw, 6] * cp1)
                                uc1 = om * (walls[iw, 6] * cp0 - walls[iw, 4] * cp2)
                                uc2 = om * (walls[iw, 4] * cp1 - walls[iw, 5] * cp0)
                                # wall_force_torque subtracts a (omega x n) from the slip it is
                                # given to reach the centre: hand it the slip at the surface
                                g0, g1, g2, c0, c1, c2, Dn, Dt = lub.wall_force_torque(
                                    ri, n0, n1, n2, -xi,
                                    v[i, 0] - uc0 + ri * om * (walls[iw, 5] * n2 - walls[iw, 6] * n1),
                                    v[i, 1] - uc1 + ri * om * (walls[iw, 6] * n0 - walls[iw, 4] * n2),
                                    v[i, 2] - uc2 + ri * om * (walls[iw, 4] * n1 - walls[iw, 5] * n0),
                                    w[i, 0], w[i, 1], w[i, 2], om * walls[iw, 4], om * walls[iw, 5],
                                    om * walls[iw, 6], fluid[1] * 2.0 * ri, fluid[0])
                                F0 += g0
                                F1 += g1
                                F2 += g2
                                T0 += c0
                                T1 += c1
                                T2 += c2
                                if AUDIT:
                                    audit_part[blk, 3] += Dn
                                    audit_part[blk, 4] += Dt
                                # Reaction on the wall: force through the sphere's centre plus the
                                # couple, about the wall's point p; power = F . (wall velocity
                                # at the centre) + couple . wall spin.
                                wp = wall_part[blk, iw]
                                wp[0] -= g0
                                wp[1] -= g1
                                wp[2] -= g2
                                wp[3] -= cp1 * g2 - cp2 * g1 + c0
                                wp[4] -= cp2 * g0 - cp0 * g2 + c1
                                wp[5] -= cp0 * g1 - cp1 * g0 + c2
                                wp[6] -= g0 * uc0 + g1 * uc1 + g2 * uc2 + om * (
                                    c0 * walls[iw, 4] + c1 * walls[iw, 5] + c2 * walls[iw, 6])
                            if xi <= 0.0:
                                for c in range(wall_hist.shape[2]):
                                    wall_hist[i, iw, c] = 0.0
                                continue
                            # Progeny created reaching into a wall: only overlap beyond the
                            # creation state counts (the reference shrinks as they part).
                            xw = xi
                            if TAVARES and wall_hist[i, iw, W_REF] > 0.0:
                                xw = xi - wall_hist[i, iw, W_REF]
                                wall_hist[i, iw, W_REF] = min(wall_hist[i, iw, W_REF], xi)
                                if xw <= 0.0:
                                    for c in range(W_REF):
                                        wall_hist[i, iw, c] = 0.0
                                    continue
                            if xw > max_overlap * ri and err[0] == 0:
                                err[0], err[1], err[2], err[3] = ERR_OVERLAP, step, i, -1 - iw
                            ai = ri - 0.5 * xi
                            vr0 = v[i, 0] - u0 - ai * (w[i, 1] * n2 - w[i, 2] * n1)
                            vr1 = v[i, 1] - u1 - ai * (w[i, 2] * n0 - w[i, 0] * n2)
                            vr2 = v[i, 2] - u2 - ai * (w[i, 0] * n1 - w[i, 1] * n0)
                            m_eff = 1.0 / inv_mass[i]
                            p = pair_params[material[i], int(walls[iw, 9])]
                            hist = wall_hist[i]
                            if LINEAR_HW:
                                fn, f0, f1, f2 = law.linear_hw(p, xw, n0, n1, n2, vr0, vr1, vr2,
                                                               m_eff, CLIP)
                                fn_el = p[law.P_K_N] * xw
                            elif LINEAR_HISTORY:
                                fn, f0, f1, f2 = law.linear_history(p, xw, n0, n1, n2, vr0, vr1,
                                                                    vr2, m_eff, CLIP, hist, iw, dt)
                                fn_el = p[law.P_K_N] * xw
                            else:
                                fn, f0, f1, f2, fn_el = law.hertz_mindlin(p, xw, n0, n1, n2, vr0,
                                                                          vr1, vr2, m_eff, ri, CLIP,
                                                                          hist, iw, dt)
                            g0 = fn * n0 + f0
                            g1 = fn * n1 + f1
                            g2 = fn * n2 + f2
                            if AUDIT:
                                dv0 = v[i, 0] - u0
                                dv1 = v[i, 1] - u1
                                dv2 = v[i, 2] - u2
                                audit_part[blk, 0] -= (fn - fn_el) * (vr0 * n0 + vr1 * n1 + vr2 * n2)
                                audit_part[blk, 1] -= f0 * dv0 + f1 * dv1 + f2 * dv2
                                audit_part[blk, 2] -= (f0 * (vr0 - dv0) + f1 * (vr1 - dv1)
                                                       + f2 * (vr2 - dv2))
                            if TAVARES:
                                dxi = xw - hist[iw, W_PREV]
                                if dxi > 0.0:
                                    kp = breakage[material[i], 0]
                                    kw = breakage[int(walls[iw, 9]), 0]
                                    EA += 0.5 * (fn + hist[iw, W_FPREV]) * dxi * kw / (kp + kw)
                                hist[iw, W_PREV] = xw
                                hist[iw, W_FPREV] = fn
                                if fn > FBIG:
                                    FBIG, D0, D1, D2 = fn, g0, g1, g2
                            c0 = -ai * (n1 * f2 - n2 * f1)
                            c1 = -ai * (n2 * f0 - n0 * f2)
                            c2 = -ai * (n0 * f1 - n1 * f0)
                            if ROLLING:
                                wn = math.sqrt(w[i, 0] ** 2 + w[i, 1] ** 2 + w[i, 2] ** 2)
                                if wn > 0.0:
                                    mr = p[law.P_MU_ROLL] * fn_el * ri / wn
                                    c0 -= mr * w[i, 0]
                                    c1 -= mr * w[i, 1]
                                    c2 -= mr * w[i, 2]
                                    if AUDIT:
                                        audit_part[blk, 2] += mr * wn * wn
                            F0 += g0
                            F1 += g1
                            F2 += g2
                            if PRESSURE:
                                FS += fn
                            T0 += c0
                            T1 += c1
                            T2 += c2
                            # Reaction on the wall: force, torque about its point p, power given.
                            cp0 = x[i, 0] - ai * n0 - walls[iw, 1]
                            cp1 = x[i, 1] - ai * n1 - walls[iw, 2]
                            cp2 = x[i, 2] - ai * n2 - walls[iw, 3]
                            wp = wall_part[blk, iw]
                            wp[0] -= g0
                            wp[1] -= g1
                            wp[2] -= g2
                            wp[3] -= cp1 * g2 - cp2 * g1
                            wp[4] -= cp2 * g0 - cp0 * g2
                            wp[5] -= cp0 * g1 - cp1 * g0
                            wp[6] -= g0 * u0 + g1 * u1 + g2 * u2
                    if PRESSURE:
                        fn_sum[i] = FS
                    if TAVARES and body[i] < 0:
                        # Stressing event: absorbed energy summed over contacts (eq 14). Break as
                        # soon as it reaches the fracture energy; when no contact loads any more
                        # the event ends and an unbroken particle is damaged (eqs 5-6). With
                        # break_at_end the decision waits for the end of the event and uses its
                        # whole energy (what the handler does with it is its business).
                        brk[i] = 0
                        if EA > 0.0:
                            e_acc[i] += EA
                            if e_acc[i] * inv_mass[i] >= e_frac[i] and not break_at_end[i]:
                                brk[i] = 1
                                brk_dir[i, 0], brk_dir[i, 1], brk_dir[i, 2] = D0, D1, D2
                                stop[0] = 1
                        elif e_acc[i] > 0.0:
                            specific = e_acc[i] * inv_mass[i]
                            mt = material[i]
                            if break_at_end[i] and specific >= e_frac[i]:
                                brk[i] = 1
                                stop[0] = 1
                            else:
                                if specific >= breakage[mt, 2]:
                                    e_frac[i] *= 1.0 - damage_fraction(specific / e_frac[i],
                                                                       breakage[mt, 1])
                                e_acc[i] = 0.0
                    if body[i] < 0:
                        a0 = F0 * inv_mass[i]
                        a1 = F1 * inv_mass[i]
                        a2 = F2 * inv_mass[i]
                        if GRAVITY:
                            a0 += gravity[0]
                            a1 += gravity[1]
                            a2 += gravity[2]
                        b0 = T0 * inv_inertia[i]
                        b1 = T1 * inv_inertia[i]
                        b2 = T2 * inv_inertia[i]
                        if GEAR:
                            _gear_correct(i, dt, x, v, w, acc, alpha, gear, a0, a1, a2, b0, b1, b2)
                            if not last:
                                _gear_predict(i, dt, x, v, w, acc, alpha, gear)
                        else:
                            _verlet_kick(i, dt, v, w, acc, alpha, a0, a1, a2, b0, b1, b2)
                            if not last:
                                _verlet_drift(i, dt, x, v, w, acc, alpha)
                        sp2 = v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2
                        if not (sp2 <= v_max2) and err[0] == 0:
                            err[0] = ERR_SPEED if sp2 == sp2 else ERR_NONFINITE
                            err[1], err[2], err[3] = step, i, -1
                    else:
                        # Body particles keep the load they received for the body reduction:
                        # the force, and its moment about the body's centre taken here, at the
                        # pose the force was computed at (the particle moves on just below; a
                        # lever arm from the next pose tilted the body torque by rate x dt, a
                        # first-order error in its power).
                        acc[i, 0], acc[i, 1], acc[i, 2] = F0, F1, F2
                        if BODIES:
                            r0 = x[i, 0] - bodies[body[i], 1]
                            r1 = x[i, 1] - bodies[body[i], 2]
                            r2 = x[i, 2] - bodies[body[i], 3]
                            T0 += r1 * F2 - r2 * F1
                            T1 += r2 * F0 - r0 * F2
                            T2 += r0 * F1 - r1 * F0
                        alpha[i, 0], alpha[i, 1], alpha[i, 2] = T0, T1, T2
                        if BODIES and not last:
                            p0, p1, p2, u0, u1, u2 = body_pose(bodies[body[i]], x_body0[i],
                                                               t + (step + 2) * dt)
                            x[i, 0], x[i, 1], x[i, 2] = p0, p1, p2
                            v[i, 0], v[i, 1], v[i, 2] = u0, u1, u2
                    dx0 = x[i, 0] - x_ref[i, 0]
                    dx1 = x[i, 1] - x_ref[i, 1]
                    dx2 = x[i, 2] - x_ref[i, 2]
                    if dx0 * dx0 + dx1 * dx1 + dx2 * dx2 > half_skin2:
                        rebuild[0] = 1

            if TAVARES and stop[0] != 0 and not last:
                # A particle broke in pass 2, after ``last`` was decided, so every particle has
                # already started the next step (Verlet drift / Gear predictor, bodies moved on).
                # Take that back: the chunk ends at the step boundary like any other, with
                # positions and velocities at t + dt, and the next chunk starts the step again.
                # (Without this each breakage advanced every particle by one extra drift and
                # handed the handler predicted velocities v + dt a: an energy error per event.)
                for i in prange(n):
                    if body[i] < 0:
                        if GEAR:
                            _gear_predict(i, -dt, x, v, w, acc, alpha, gear)
                        else:
                            _verlet_drift(i, -dt, x, v, w, acc, alpha)
                    elif BODIES:
                        p0, p1, p2, u0, u1, u2 = body_pose(bodies[body[i]], x_body0[i],
                                                           t + (step + 1) * dt)
                        x[i, 0], x[i, 1], x[i, 2] = p0, p1, p2
                        v[i, 0], v[i, 1], v[i, 2] = u0, u1, u2

            # ---- serial: loads on bodies and walls, list rebuild ------------------------------
            if BODIES:
                body_load[:, :] = 0.0
                for q in range(body_members.shape[0]):
                    i = body_members[q]
                    b = body[i]
                    bl = body_load[b]
                    bl[0] += acc[i, 0]
                    bl[1] += acc[i, 1]
                    bl[2] += acc[i, 2]
                    bl[3] += alpha[i, 0]  # moment about the body's centre (pass 2)
                    bl[4] += alpha[i, 1]
                    bl[5] += alpha[i, 2]
                for b in range(bodies.shape[0]):
                    for c in range(6):
                        body_impulse[b, c] += body_load[b, c] * dt
                    # Power the body puts in: minus the load it receives dotted with its velocity.
                    a0, a1, a2, rate = bodies[b, 4], bodies[b, 5], bodies[b, 6], bodies[b, 7]
                    if int(bodies[b, 0]) == ROTATE:
                        power = -(body_load[b, 3] * a0 + body_load[b, 4] * a1 + body_load[b, 5] * a2) * rate
                    else:
                        power = -(body_load[b, 0] * a0 + body_load[b, 1] * a1 + body_load[b, 2] * a2) * rate
                    body_work[b] += power * dt
            if AUDIT:
                # Trapezoidal in time: the powers are evaluated at the end of each step, so a
                # plain sum (right-endpoint rule) runs half a step of dissipation ahead of the
                # state, an O(dt) error wherever the audit is read mid-contact (it cancels only
                # once the contacts have ended). dissipation[N_AUDIT:] keeps the last step's
                # powers (0 at the start); NaN (particles added or removed since) means unknown,
                # and that step uses its own power.
                for a in range(N_AUDIT):
                    power = 0.0
                    for blk in range(n_blocks):
                        power += audit_part[blk, a]
                        audit_part[blk, a] = 0.0
                    prev = dissipation[N_AUDIT + a]
                    if prev != prev:
                        prev = power
                    dissipation[a] += 0.5 * (prev + power) * dt
                    dissipation[N_AUDIT + a] = power
            if WALLS:
                for iw in range(n_walls):
                    for blk in range(n_blocks):
                        for c in range(6):
                            wall_impulse[iw, c] += wall_part[blk, iw, c] * dt
                        wall_work[iw] -= wall_part[blk, iw, 6] * dt
                wall_part[:, :, :] = 0.0
            if TAVARES and stop[0] != 0:
                # Breakage rows in particle order: [particle, specific energy absorbed, step,
                # direction of the largest contact force (3)].
                needed = n_fractures[0]
                for i in range(n):
                    needed += brk[i]
                fractures = _room_for(fractures, n_fractures[0], needed)
                for i in range(n):
                    if brk[i]:
                        row = fractures[n_fractures[0]]
                        row[0] = i
                        row[1] = e_acc[i] * inv_mass[i]
                        row[2] = step0 + step
                        row[3], row[4], row[5] = brk_dir[i, 0], brk_dir[i, 1], brk_dir[i, 2]
                        n_fractures[0] += 1
                        brk[i] = 0
                        if break_at_end[i]:
                            e_acc[i] = 0.0  # the event has ended: reported once
            if FRACTURE and stop[0] != 0:
                # Collect this step's fracture decisions in slot order (deterministic); the buffer
                # grows so that no decision is ever dropped.
                needed = n_fractures[0]
                for k in range(broke.shape[0]):
                    needed += (broke[k] & 1) + ((broke[k] >> 1) & 1)
                fractures = _room_for(fractures, n_fractures[0], needed)
                for i in range(n):
                    for k in range(start[i], start[i + 1]):
                        if broke[k] == 0:
                            continue
                        j = nbr[k]
                        for side in range(2):
                            if broke[k] & (1 << side):
                                me, other = (i, j) if side == 0 else (j, i)
                                row = fractures[n_fractures[0]]
                                row[0] = me
                                row[1] = other
                                row[2] = peak[k]
                                row[3] = step0 + step
                                n_fractures[0] += 1
                        broke[k] = 0
            steps_done = step + 1
            if err[0] != 0 or stop[0] != 0:
                break
            if rebuild[0] != 0 and not last:
                if PERIODIC:
                    wrap_periodic(x, body, box_lo, box_len)
                start, nbr, state, rev_start, rev_slot = build_verlet(
                    x, radius, body, skin + reach, dim, box_lo, box_len, start, nbr, state)
                x_ref[:, :] = x
                rebuild[0] = 0
                out = np.empty((nbr.shape[0], SLOT))
                proll = np.empty((nbr.shape[0] if ROLLING else 0, 2, 3))
                broke = np.empty(nbr.shape[0] if FRACTURE else 0, dtype=np.int8)
                peak = np.empty(nbr.shape[0] if FRACTURE else 0)
                counters[0] += 1
        counters[1] += steps_done
        return steps_done, start, nbr, state, rev_start, rev_slot, fractures

    return run_chunk
