"""The serial end of a step: loads on bodies and walls and the energy audit, summed over fixed
blocks (so that no sum depends on the thread count)."""

from ..kinematics import B_AX, B_KIND, ROTATE, body_motion
from .layout import N_AUDIT


def reduction_kernel(spec, layout):
    """Serial part of a step: loads on bodies and walls and the energy audit, over fixed blocks."""
    BODIES, WALLS, AUDIT = spec.bodies, spec.walls, layout.audit

    def reductions(t_load, dt, P, B, W, dissipation, wall_part, audit_part, n_blocks):
        if BODIES:
            B.load[:, :] = 0.0
            for q in range(B.members.shape[0]):
                i = B.members[q]
                bl = B.load[P.body[i]]
                bl[0] += P.acc[i, 0]
                bl[1] += P.acc[i, 1]
                bl[2] += P.acc[i, 2]
                bl[3] += P.alpha[i, 0]  # moment about the body's centre (particle pass)
                bl[4] += P.alpha[i, 1]
                bl[5] += P.alpha[i, 2]
            for b in range(B.table.shape[0]):
                for c in range(6):
                    B.impulse[b, c] += B.load[b, c] * dt
                # Power the body puts in: minus the load it receives dotted with its velocity.
                # (at its rate when the loads were computed, the time of this step's forces)
                a0, a1, a2 = B.table[b, B_AX], B.table[b, B_AX + 1], B.table[b, B_AX + 2]
                rate = body_motion(B.table[b], t_load)[1]
                if int(B.table[b, B_KIND]) == ROTATE:
                    power = -(B.load[b, 3] * a0 + B.load[b, 4] * a1 + B.load[b, 5] * a2) * rate
                else:
                    power = -(B.load[b, 0] * a0 + B.load[b, 1] * a1 + B.load[b, 2] * a2) * rate
                B.work[b] += power * dt
        if AUDIT:
            # Trapezoidal in time: the powers are evaluated at the end of each step, so a plain
            # sum (right-endpoint rule) runs half a step of dissipation ahead of the state, an
            # O(dt) error wherever the audit is read mid-contact. dissipation[N_AUDIT:] keeps the
            # last step's powers (0 at the start); NaN (particles added or removed since) means
            # unknown, and that step uses its own power.
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
            for iw in range(W.table.shape[0]):
                for blk in range(n_blocks):
                    for c in range(6):
                        W.impulse[iw, c] += wall_part[blk, iw, c] * dt
                    W.work[iw] -= wall_part[blk, iw, 6] * dt
            wall_part[:, :, :] = 0.0

    return reductions
