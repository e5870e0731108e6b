"""Lubrication of a particle with a mesh wall: one film per mesh and particle, at the nearest
point of the mesh's surface within the list's reach (docs/lubrication.md, "Mesh walls").

The nearest point stands for the wall's surface as an analytic wall's contact point does: its
normal and gap go to the fluid's wall hooks (``wall_fluid`` explicit, ``wall_rows`` implicit),
which take the wall's rigid motion (its turning about the axis through its point) from the wall
row, as for any turning wall. So a mesh's film is the analytic wall's law at that point, with the
reaction, power and audit of an analytic wall. Compiled only into runs with mesh walls and a
fluid; the walls pass calls it in place of the dry runs' nothing."""

import math

from ..kinematics import W_AX, W_COS, W_PX, W_SIN
from ..mesh import rotate, triangle_contact
from .wall_pass import fluid_wall_reaction


def mesh_fluid_kernel(layout, flu):
    """The film of free particle i with mesh wall iw (active), added to its loads; the reaction
    on the wall goes to its block's partial sums (implicit scheme: the particle's row for that
    wall, S.lub_rows[i, iw], applied by the solve)."""
    IMPLICIT, AUDIT = layout.implicit, layout.audit
    wall_fluid, wall_rows = flu.wall_fluid, flu.wall_rows

    def mesh_fluid(i, iw, wall, P, W, R, S, blk, fp, F0, F1, F2, T0, T1, T2):
        x = P.x
        ri = P.radius[i]
        # Triangles within ri + reach (the largest particle's film, R.reach) are candidates
        # (listed within radius + skin + reach); the hooks apply the particle's own cutoff.
        far = ri + R.reach
        c, s = wall[W_COS], wall[W_SIN]
        y0, y1, y2 = rotate(c, -s, wall[W_AX], wall[W_AX + 1], wall[W_AX + 2],
                            x[i, 0] - wall[W_PX], x[i, 1] - wall[W_PX + 1],
                            x[i, 2] - wall[W_PX + 2])
        best, best_t = 0.0, -1
        m0 = m1 = m2 = 0.0
        for k in range(W.cand_start[i], W.cand_start[i + 1]):
            t = W.cand_tri[k]
            if W.tri_wall[t] != iw:
                continue
            d, e0, e1, e2, _ = triangle_contact(W, t, y0, y1, y2, far)
            # the nearest point; at a tie (a shared edge or vertex) the lower index, so that
            # the choice does not depend on the candidates' order
            if d > 0.0 and (d > best or (d == best and t < best_t)):
                best, best_t, m0, m1, m2 = d, t, e0, e1, e2
        if best_t >= 0:
            xi = best - R.reach  # the overlap of the particle itself (negative: the gap)
            n0, n1, n2 = rotate(c, s, wall[W_AX], wall[W_AX + 1], wall[W_AX + 2], m0, m1, m2)
        else:  # nothing within reach: the hooks see no film
            xi, n0, n1, n2 = -math.inf, 0.0, 0.0, 1.0
        if IMPLICIT:  # the row for the solve (applied in lub_finish_kernel)
            wall_rows(fp, wall, x, i, ri, n0, n1, n2, xi, S.lub_rows[i, iw])
            return F0, F1, F2, T0, T1, T2
        fluid, g0, g1, g2, c0, c1, c2, Dn, Dt, cp0, cp1, cp2, pw = wall_fluid(
            fp, wall, x, P.v, P.w, i, ri, n0, n1, n2, xi)
        if fluid:
            if AUDIT:
                S.audit_part[blk, 3] += Dn
                S.audit_part[blk, 4] += Dt
            fluid_wall_reaction(S.wall_part[blk, iw], g0, g1, g2, c0, c1, c2, cp0, cp1, cp2, pw)
            return F0 + g0, F1 + g1, F2 + g2, T0 + c0, T1 + c1, T2 + c2
        return F0, F1, F2, T0, T1, T2

    return mesh_fluid
