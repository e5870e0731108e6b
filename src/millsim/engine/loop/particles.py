"""The particle pass: gather a particle's slot records, finish its integrator step and start the
next (with implicit lubrication, after the solve: ``lub_finish_kernel``), place kinematic-body
particles. The kernels are factories: the spec's options become the closure's constants, and
:class:`~millsim.engine.loop.runner._Parts` compiles what they return."""

from numba import njit

from ..implicit import LP_FORCE, RW_ACT, RW_VJ, row_impulse, row_power
from ..integrators import gear_correct, gear_predict, verlet_drift, verlet_kick
from ..kinematics import B_AX, B_CX, B_KIND, B_RAMP, ROTATE, W_PX, body_pose
from .layout import BLOCK, ERR_NONFINITE, ERR_SPEED, ROLLING_AUDIT, SLOT_AUDIT, SLOT_BASE
from .spectra import PAIR, spectra_book
from .wall_pass import fluid_wall_reaction


@njit(cache=True)
def moved_beyond(x, x_ref, half_skin2):
    """Whether a particle has moved more than half the skin since the list was built."""
    for i in range(x.shape[0]):
        d0 = x[i, 0] - x_ref[i, 0]
        d1 = x[i, 1] - x_ref[i, 1]
        d2 = x[i, 2] - x_ref[i, 2]
        if d0 * d0 + d1 * d1 + d2 * d2 > half_skin2:
            return True
    return False



def start_block_kernel(spec):
    GEAR, BODIES = spec.integrator == "gear", spec.bodies

    def start_block(blk, t_next, dt, P, B):
        """Start the step of the block's particles (Verlet drift / Gear predictor; dt < 0 takes
        one back), or place body particles at their pose at t_next."""
        x, v = P.x, P.v
        for i in range(blk * BLOCK, min(x.shape[0], (blk + 1) * BLOCK)):
            if P.body[i] < 0:
                if GEAR:
                    gear_predict(i, dt, x, v, P.w, P.acc, P.alpha, P.gear)
                else:
                    verlet_drift(i, dt, x, v, P.w, P.acc, P.alpha)
            elif BODIES:
                place_body_particle(i, B.table[P.body[i]], x, v, P.w, P.x_body0, t_next)

    return start_block



def particle_block_kernel(spec, brk, layout, gather, walls, finish):
    """Particle pass for one block: gather, walls, breakage decision, integrate (with implicit
    lubrication: keep the loads for the solve; ``lub_finish_kernel`` integrates)."""
    WALLS, PRESSURE, IMPLICIT = spec.walls, spec.normal_force_sum, layout.implicit
    # Rolling friction's power at the spin after the kick (implicit lubrication: at the spin the
    # torque saw, first order where spins flip). Every rolling torque on i points along -w_p/|w_p|
    # (w_p the spin the contacts saw), and verlet's kinetic energy at half steps changes by
    # exactly dt T.w over a step (T the torque, w the spin after the kick), so the booking
    # c |w_p| becomes c (w_p . w) / |w_p|: a spin flipping about zero under a torque of constant
    # size (EDEM's) does no work on it, while at w_p it read as dissipation of c |w_p| each step,
    # an O(dt) excess (2.9 % of the 3D mill's drive work at the recommended step).
    ROLL_BOOK = spec.rolling_friction and layout.audit and not IMPLICIT
    decide = brk.particle_decide

    def particle_block(blk, step, last, t_pose, dt, P, C, W, B, R, err, S, bs, fp, half_skin2):
        prime = dt == 0.0  # the start state's forces: nothing advances (see advance)
        x, x_ref, w = P.x, P.x_ref, P.w
        stop, rebuild, lub = S.stop, S.rebuild, S.lub_particle
        for i in range(blk * BLOCK, min(x.shape[0], (blk + 1) * BLOCK)):
            booked = S.audit_part[blk, ROLLING_AUDIT] if ROLL_BOOK else 0.0
            F0, F1, F2, T0, T1, T2, FS, acc = gather(i, P, C, S, blk, bs)
            if WALLS and P.body[i] < 0:
                F0, F1, F2, T0, T1, T2, FS, acc = walls(i, step, dt, P, W, R, err, S, blk, bs, fp,
                                                        F0, F1, F2, T0, T1, T2, FS, acc)
            if PRESSURE:
                P.fn_sum[i] = FS
            if P.body[i] < 0 and not prime:
                decide(bs, i, acc, P.inv_mass[i], P.material[i], stop)
            if IMPLICIT:
                lub[i, LP_FORCE], lub[i, LP_FORCE + 1], lub[i, LP_FORCE + 2] = F0, F1, F2
                lub[i, LP_FORCE + 3], lub[i, LP_FORCE + 4], lub[i, LP_FORCE + 5] = T0, T1, T2
                continue
            p0, p1, p2 = w[i, 0], w[i, 1], w[i, 2]
            s0, s1, s2 = finish(i, step, last, t_pose, dt, P, B, R, err, F0, F1, F2, T0, T1, T2,
                                prime)
            if ROLL_BOOK:
                rolled = S.audit_part[blk, ROLLING_AUDIT] - booked
                pp = p0 * p0 + p1 * p1 + p2 * p2
                if rolled != 0.0 and pp > 0.0:
                    S.audit_part[blk, ROLLING_AUDIT] = booked + rolled * (
                        p0 * s0 + p1 * s1 + p2 * s2) / pp
            dx0 = x[i, 0] - x_ref[i, 0]
            dx1 = x[i, 1] - x_ref[i, 1]
            dx2 = x[i, 2] - x_ref[i, 2]
            if dx0 * dx0 + dx1 * dx1 + dx2 * dx2 > half_skin2:
                rebuild[0] = 1

    return particle_block


def gather_kernel(spec, brk, layout):
    """Sum the slot records of particle i in a fixed order: its own slots, then those where it is
    the partner (forces, torques with their lever arms, rolling and lubrication torques)."""
    ROLLING, AUDIT, PRESSURE = spec.rolling_friction, layout.audit, spec.normal_force_sum
    FLUID = layout.fluid and not layout.implicit  # explicit lubrication torques in the record
    COL_BRK, COL_T, COL_AUD = SLOT_BASE, layout.slot_fluid, layout.slot_audit
    SPECTRA, COL_SP = layout.spectra, layout.slot_spectra
    share = brk.slot_share

    if spec.force_sum == "colour":
        def colour_sums(i, P, C, S, blk, bs):
            """The sums the colour pass left (then zeroed for the next step's)."""
            f = S.force
            F0, F1, F2, T0, T1, T2, FS = f[i, 0], f[i, 1], f[i, 2], f[i, 3], f[i, 4], f[i, 5], f[i, 6]
            for c in range(7):
                f[i, c] = 0.0
            return F0, F1, F2, T0, T1, T2, FS, (0.0, 0.0, 0.0, 0.0, 0.0)

        return colour_sums

    def gather(i, P, C, S, blk, bs):
        start, rev_start, rev_slot = C.start, C.rev_start, C.rev_slot
        out, proll, audit_part = S.out, S.proll, S.audit_part
        F0 = F1 = F2 = 0.0
        C0 = C1 = C2 = 0.0  # arm x (n x F_t), summed; the torque is its negative
        R0 = R1 = R2 = 0.0  # rolling torques
        L0 = L1 = L2 = 0.0  # lubrication torques
        FS = 0.0
        acc = (0.0, 0.0, 0.0, 0.0, 0.0)  # breakage: work, largest normal force, its direction
        ri = P.radius[i]
        for k in range(start[i], start[i + 1]):
            o = out[k]
            if PRESSURE:
                FS += o[7]
            acc = share(bs, acc, o, COL_BRK, 0)
            if FLUID:
                L0 += o[COL_T]
                L1 += o[COL_T + 1]
                L2 += o[COL_T + 2]
            if AUDIT:
                for a in range(SLOT_AUDIT):
                    audit_part[blk, a] += o[COL_AUD + a]
            if SPECTRA and o[COL_SP] != 0.0:  # the pair's collision ended in this step
                ma, mb = P.material[i], P.material[C.nbr[k]]
                spectra_book(S.spectra_counts, S.spectra_energy, S.spectra_bins, blk, PAIR,
                             min(ma, mb), max(ma, mb), o[COL_SP + 1], o[COL_SP + 2])
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
                if AUDIT:  # at the spin the torque saw; particle_block moves it to the kick's
                    audit_part[blk, ROLLING_AUDIT] -= (proll[k, 0, 0] * P.w[i, 0]
                                                       + proll[k, 0, 1] * P.w[i, 1]
                                                       + proll[k, 0, 2] * P.w[i, 2])
        for q in range(rev_start[i], rev_start[i + 1]):
            k = rev_slot[q]
            o = out[k]
            if PRESSURE:
                FS += o[7]
            acc = share(bs, acc, o, COL_BRK, 1)
            if FLUID:
                L0 += o[COL_T + 3]
                L1 += o[COL_T + 4]
                L2 += o[COL_T + 5]
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
                if AUDIT:
                    audit_part[blk, ROLLING_AUDIT] -= (proll[k, 1, 0] * P.w[i, 0]
                                                       + proll[k, 1, 1] * P.w[i, 1]
                                                       + proll[k, 1, 2] * P.w[i, 2])
        return F0, F1, F2, R0 - C0 + L0, R1 - C1 + L1, R2 - C2 + L2, FS, acc

    return gather



def lub_finish_kernel(spec, layout, finish):
    """With implicit lubrication, the rest of the particle pass for one block: the loads kept by
    the particle pass plus the solved impulses over the kick (pair rows equal and opposite, wall
    rows with their reaction on the wall), the audit of the rows' power, then the integrator and
    the skin check."""
    WALLS, AUDIT = spec.walls, layout.audit

    def lub_finish_block(blk, step, last, t_pose, dt, tau, P, C, W, B, R, err, S, half_skin2):
        prime = dt == 0.0  # the start state's loads: nothing advances (see advance)
        x, x_ref, body = P.x, P.x_ref, P.body
        start, rev_start, rev_slot, out = C.start, C.rev_start, C.rev_slot, S.lub_slots
        lub, rows, wall_part, audit_part = S.lub_particle, S.lub_rows, S.wall_part, S.audit_part
        inv = 1.0 / tau  # impulse over the kick -> force
        for i in range(blk * BLOCK, min(x.shape[0], (blk + 1) * BLOCK)):
            F0, F1, F2 = lub[i, LP_FORCE], lub[i, LP_FORCE + 1], lub[i, LP_FORCE + 2]
            T0, T1, T2 = lub[i, LP_FORCE + 3], lub[i, LP_FORCE + 4], lub[i, LP_FORCE + 5]
            for k in range(start[i], start[i + 1]):
                o = out[k]
                if o[RW_ACT] == 0.0:
                    continue
                f = row_impulse(o)  # the impulse on i is -J^T lam
                F0 -= f[0] * inv
                F1 -= f[1] * inv
                F2 -= f[2] * inv
                T0 -= f[3] * inv
                T1 -= f[4] * inv
                T2 -= f[5] * inv
                if AUDIT:
                    pn, pt = row_power(o, tau)
                    audit_part[blk, 3] += pn
                    audit_part[blk, 4] += pt
            for q in range(rev_start[i], rev_start[i + 1]):
                o = out[rev_slot[q]]
                if o[RW_ACT] == 0.0:
                    continue
                f = row_impulse(o)
                F0 += f[0] * inv
                F1 += f[1] * inv
                F2 += f[2] * inv
                T0 -= f[6] * inv
                T1 -= f[7] * inv
                T2 -= f[8] * inv
            if WALLS and body[i] < 0:
                for iw in range(rows.shape[1]):
                    o = rows[i, iw]
                    if o[RW_ACT] == 0.0:
                        continue
                    f = row_impulse(o)
                    g0, g1, g2 = -f[0] * inv, -f[1] * inv, -f[2] * inv
                    c0, c1, c2 = -f[3] * inv, -f[4] * inv, -f[5] * inv
                    F0 += g0
                    F1 += g1
                    F2 += g2
                    T0 += c0
                    T1 += c1
                    T2 += c2
                    # reaction on the wall: force through the sphere's centre plus the couple,
                    # about the wall's point, and the power the wall gives (its rigid motion)
                    wall = W.table[iw]
                    cp0, cp1, cp2 = (x[i, 0] - wall[W_PX], x[i, 1] - wall[W_PX + 1],
                                     x[i, 2] - wall[W_PX + 2])
                    fluid_wall_reaction(
                        wall_part[blk, iw], g0, g1, g2, c0, c1, c2, cp0, cp1, cp2,
                        g0 * o[RW_VJ] + g1 * o[RW_VJ + 1] + g2 * o[RW_VJ + 2]
                        + c0 * o[RW_VJ + 3] + c1 * o[RW_VJ + 4] + c2 * o[RW_VJ + 5])
                    if AUDIT:
                        pn, pt = row_power(o, tau)
                        audit_part[blk, 3] += pn
                        audit_part[blk, 4] += pt
            finish(i, step, last, t_pose, dt, P, B, R, err, F0, F1, F2, T0, T1, T2, prime)
            dx0 = x[i, 0] - x_ref[i, 0]
            dx1 = x[i, 1] - x_ref[i, 1]
            dx2 = x[i, 2] - x_ref[i, 2]
            if dx0 * dx0 + dx1 * dx1 + dx2 * dx2 > half_skin2:
                S.rebuild[0] = 1

    return lub_finish_block



def finish_kernel(spec):
    """Finish the step of particle i from its force and torque (free particles), or keep the load
    a body particle received for the body reduction; then start the next step."""
    GEAR, GRAVITY, BODIES = spec.integrator == "gear", spec.gravity, spec.bodies

    def finish(i, step, last, t_pose, dt, P, B, R, err, F0, F1, F2, T0, T1, T2, prime):
        """Returns the particle's spin at the end of this step (before the next step's start)."""
        x, v, w, acc, alpha = P.x, P.v, P.w, P.acc, P.alpha
        if P.body[i] < 0:
            a0 = F0 * P.inv_mass[i]
            a1 = F1 * P.inv_mass[i]
            a2 = F2 * P.inv_mass[i]
            if GRAVITY:
                a0 += R.gravity[0]
                a1 += R.gravity[1]
                a2 += R.gravity[2]
            b0 = T0 * P.inv_inertia[i]
            b1 = T1 * P.inv_inertia[i]
            b2 = T2 * P.inv_inertia[i]
            if prime:  # the start state's accelerations, nothing advances
                acc[i, 0], acc[i, 1], acc[i, 2] = a0, a1, a2
                alpha[i, 0], alpha[i, 1], alpha[i, 2] = b0, b1, b2
                return w[i, 0], w[i, 1], w[i, 2]
            if GEAR:
                gear_correct(i, dt, x, v, w, acc, alpha, P.gear, a0, a1, a2, b0, b1, b2)
                s0, s1, s2 = w[i, 0], w[i, 1], w[i, 2]
                if not last:
                    gear_predict(i, dt, x, v, w, acc, alpha, P.gear)
            else:
                verlet_kick(i, dt, v, w, acc, alpha, a0, a1, a2, b0, b1, b2)
                s0, s1, s2 = w[i, 0], w[i, 1], w[i, 2]
                if not last:
                    verlet_drift(i, dt, x, v, w, acc, alpha)
            sp2 = v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2
            if not (sp2 <= R.v_max * R.v_max) and err[0] == 0:
                err[0] = ERR_SPEED if sp2 == sp2 else ERR_NONFINITE
                err[1], err[2], err[3] = step, i, -1
            return s0, s1, s2
        # Body particles keep the load they received for the body reduction: the force, and its
        # moment about the body's centre taken here, at the pose the force was computed at (a
        # lever arm from the next pose tilted the body torque by rate x dt, a first-order error
        # in its power).
        acc[i, 0], acc[i, 1], acc[i, 2] = F0, F1, F2
        if BODIES:
            b = B.table[P.body[i]]
            r0 = x[i, 0] - b[B_CX]
            r1 = x[i, 1] - b[B_CX + 1]
            r2 = x[i, 2] - b[B_CX + 2]
            T0 += r1 * F2 - r2 * F1
            T1 += r2 * F0 - r0 * F2
            T2 += r0 * F1 - r1 * F0
        alpha[i, 0], alpha[i, 1], alpha[i, 2] = T0, T1, T2
        s0, s1, s2 = w[i, 0], w[i, 1], w[i, 2]  # a body's spin, at the time of its load
        if BODIES and not last and not prime:
            place_body_particle(i, B.table[P.body[i]], x, v, w, P.x_body0, t_pose)
        return s0, s1, s2

    return finish


@njit(inline="always", cache=True)
def place_body_particle(i, body, x, v, w, x_body0, t):
    """Particle i of a kinematic body at its pose at t. A ramping rotating body also sets the
    particle's spin to its rate at t (a constant-rate body's spin was set once at build)."""
    p0, p1, p2, u0, u1, u2, rate = body_pose(body, x_body0[i], t)
    x[i, 0], x[i, 1], x[i, 2] = p0, p1, p2
    v[i, 0], v[i, 1], v[i, 2] = u0, u1, u2
    if body[B_RAMP] > 0.0 and int(body[B_KIND]) == ROTATE:
        w[i, 0], w[i, 1], w[i, 2] = rate * body[B_AX], rate * body[B_AX + 1], rate * body[B_AX + 2]
