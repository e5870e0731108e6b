"""Walls in the particle pass: one dry contact with a wall's surface, every analytic wall of a
particle, the triangles of mesh walls, and the walls near each particle for a list's lifetime.
The kernels are factories: the spec's options become the closure's constants, and
:class:`~millsim.engine.loop.runner._Parts` compiles what they return."""

import math

import numpy as np
from numba import njit

from ..implicit import row_absent
from ..jit_options import FAST
from ..kinematics import (
    MESH,
    W_ACTIVE,
    W_AX,
    W_COS,
    W_KIND,
    W_MATERIAL,
    W_OMEGA,
    W_PX,
    W_RAMP,
    W_SIN,
    W_VX,
)
from ..mesh import MESH_SLOTS, SAME_CONTACT_COS, TAG_COLUMNS, owns, rotate, triangle_contact
from ..walls import SKIP_WHEN_FAR, wall_contact, wall_contact_bounded
from .layout import BLOCK, ERR_MESH_SLOTS, ERR_OVERLAP, ROLLING_AUDIT
from .spectra import forgotten, spectra_close_wall, spectra_step


def wall_force_kernel(spec, layout, contact):
    """One dry contact of free particle i with a wall's surface (analytic or a mesh triangle):
    overlap xi (xw of it counts), unit normal n wall -> particle, the surface's velocity u; the
    force on i, the torque about its centre and the lever arm ai."""
    ROLLING, AUDIT = spec.rolling_friction, layout.audit
    SPECTRA, SPW = layout.spectra, layout.wall_spectra

    def wall_force(i, xi, xw, n0, n1, n2, u0, u1, u2, p, hist, k, dt, P, audit_part, blk):
        v, w = P.v, P.w
        ri = P.radius[i]
        ai = ri - 0.5 * xi
        vr0 = v[i, 0] - u0 - ai * (w[i, 1] * n2 - w[i, 2] * n1)
        vr1 = v[i, 1] - u1 - ai * (w[i, 2] * n0 - w[i, 0] * n2)
        vr2 = v[i, 2] - u2 - ai * (w[i, 0] * n1 - w[i, 1] * n0)
        fn, f0, f1, f2, fn_el, mr = contact(p, xw, n0, n1, n2, vr0, vr1, vr2,
                                            1.0 / P.inv_mass[i], ri, hist, k, dt)
        g0 = fn * n0 + f0
        g1 = fn * n1 + f1
        g2 = fn * n2 + f2
        if AUDIT:
            dv0 = v[i, 0] - u0
            dv1 = v[i, 1] - u1
            dv2 = v[i, 2] - u2
            audit_part[blk, 0] -= (fn - fn_el) * (vr0 * n0 + vr1 * n1 + vr2 * n2)
            audit_part[blk, 1] -= f0 * dv0 + f1 * dv1 + f2 * dv2
            audit_part[blk, 2] -= (f0 * (vr0 - dv0) + f1 * (vr1 - dv1) + f2 * (vr2 - dv2))
        c0 = -ai * (n1 * f2 - n2 * f1)
        c1 = -ai * (n2 * f0 - n0 * f2)
        c2 = -ai * (n0 * f1 - n1 * f0)
        if ROLLING:
            wn = math.sqrt(w[i, 0] ** 2 + w[i, 1] ** 2 + w[i, 2] ** 2)
            if wn > 0.0:
                m = mr * ri / wn
                c0 -= m * w[i, 0]
                c1 -= m * w[i, 1]
                c2 -= m * w[i, 2]
                if AUDIT:  # at the spin the torque saw; particle_block moves it to the kick's
                    audit_part[blk, ROLLING_AUDIT] += m * wn * wn
        if SPECTRA:  # collision spectra: this contact's share of the audit's contact powers
            pt = -(f0 * vr0 + f1 * vr1 + f2 * vr2)  # centre and rotational slip together
            spectra_step(hist[k], SPW, -(fn - fn_el) * (vr0 * n0 + vr1 * n1 + vr2 * n2), pt, dt,
                         forgotten(audit_part))
        return fn, g0, g1, g2, c0, c1, c2, ai

    return wall_force


@njit(inline="always", cache=True, fastmath=FAST)
def _wall_reaction(wp, x, i, ai, n0, n1, n2, g0, g1, g2, u0, u1, u2, wall):
    """Reaction on a wall of force g on particle i: force, torque about the wall's point p
    (lever from p to the contact point), and the power the wall gives."""
    cp0 = x[i, 0] - ai * n0 - wall[W_PX]
    cp1 = x[i, 1] - ai * n1 - wall[W_PX + 1]
    cp2 = x[i, 2] - ai * n2 - wall[W_PX + 2]
    wp[0] -= g0
    wp[1] -= g1
    wp[2] -= g2
    wp[3] -= cp1 * g2 - cp2 * g1
    wp[4] -= cp2 * g0 - cp0 * g2
    wp[5] -= cp0 * g1 - cp1 * g0
    wp[6] -= g0 * u0 + g1 * u1 + g2 * u2


@njit(inline="always", cache=True, fastmath=FAST)
def fluid_wall_reaction(wp, g0, g1, g2, c0, c1, c2, cp0, cp1, cp2, pw):
    """Reaction on a wall of a film's force g and couple c on a sphere: the force through the
    sphere's centre (lever cp from the wall's point p) plus the couple, and the power pw the wall
    gives. One for analytic walls, meshes and the implicit solve's rows."""
    wp[0] -= g0
    wp[1] -= g1
    wp[2] -= g2
    wp[3] -= cp1 * g2 - cp2 * g1 + c0
    wp[4] -= cp2 * g0 - cp0 * g2 + c1
    wp[5] -= cp0 * g1 - cp1 * g0 + c2
    wp[6] -= pw


def walls_kernel(spec, law, brk, flu, layout, wall_force, meshes, mesh_fluid=None):
    """Contacts (and lubrication) of free particle i with every wall; the reaction on each wall
    goes to its block's partial sums. ``mesh_fluid``: the film at mesh walls (loop.mesh_fluid;
    runs with mesh walls and a fluid)."""
    AUDIT, PRESSURE = layout.audit, spec.normal_force_sum
    IMPLICIT = layout.implicit
    SPRING = law.spring_columns
    reference, loaded, wall_fluid = brk.wall_reference, brk.wall_loaded, flu.wall_fluid
    wall_rows = flu.wall_rows
    wall_apart = brk.wall_apart
    contact_with = wall_contact_bounded if spec.bounded_walls else wall_contact
    TRANSLATING, MESHES = spec.translating_walls, spec.mesh_walls
    MESH_FLUID = MESHES and layout.fluid
    # a constant, so that the reset of a wall's state is a few stores, not a call to memset
    # (with the vector registers saved around it) per particle and wall
    HIST = layout.wall_columns
    NEAR_WALLS = near_walls(spec, layout)
    SPECTRA, SPW = layout.spectra, layout.wall_spectra  # collision spectra (loop.spectra)

    def walls(i, step, dt, P, W, R, err, S, blk, bs, fp, F0, F1, F2, T0, T1, T2, FS, acc):
        x, v, w = P.x, P.v, P.w
        wall_part, audit_part = S.wall_part, S.audit_part
        ri = P.radius[i]
        near = S.wall_near[i] if NEAR_WALLS else 0
        for iw in range(W.table.shape[0]):
            if NEAR_WALLS and iw < NEAR_BITS and not (near >> iw) & 1:
                continue  # out of reach until the next list rebuild: apart, nothing to add
            wall = W.table[iw]
            if wall[W_ACTIVE] == 0.0:  # disabled
                if IMPLICIT:
                    row_absent(S.lub_rows[i, iw])
                continue
            if MESHES and int(wall[W_KIND]) == MESH:  # contacts below, with every mesh at once
                if MESH_FLUID:  # its film here: one per mesh and particle
                    F0, F1, F2, T0, T1, T2 = mesh_fluid(i, iw, wall, P, W, R, S, blk, fp,
                                                        F0, F1, F2, T0, T1, T2)
                continue
            xi, n0, n1, n2, u0, u1, u2 = contact_with(wall, x[i, 0], x[i, 1], x[i, 2], ri)
            if TRANSLATING:  # the surface's velocity: turning (above) plus translation
                u0 += wall[W_VX]
                u1 += wall[W_VX + 1]
                u2 += wall[W_VX + 2]
            if IMPLICIT:  # the row for the solve (applied in lub_finish_kernel)
                wall_rows(fp, wall, x, i, ri, n0, n1, n2, xi, S.lub_rows[i, iw])
                fluid, g0, g1, g2, c0, c1, c2, Dn, Dt, cp0, cp1, cp2, pw = (
                    False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
            else:
                fluid, g0, g1, g2, c0, c1, c2, Dn, Dt, cp0, cp1, cp2, pw = wall_fluid(
                    fp, wall, x, v, w, i, ri, n0, n1, n2, xi)
            if fluid:
                F0 += g0
                F1 += g1
                F2 += g2
                T0 += c0
                T1 += c1
                T2 += c2
                if AUDIT:
                    audit_part[blk, 3] += Dn
                    audit_part[blk, 4] += Dt
                fluid_wall_reaction(wall_part[blk, iw], g0, g1, g2, c0, c1, c2, cp0, cp1, cp2,
                                    pw)
            if xi <= 0.0:
                if SPECTRA:  # collision spectra: the collision with the wall ends
                    spectra_close_wall(W.hist[i, iw], SPW, dt, S, blk, P.material[i])
                for c in range(HIST):
                    W.hist[i, iw, c] = 0.0
                wall_apart(bs, W.hist, i, iw, SPRING, xi)
                continue
            # Progeny created reaching into a wall: only overlap beyond the creation state counts.
            xw, touching = reference(bs, W.hist, i, iw, SPRING, xi)
            if not touching:
                if SPECTRA:  # collision spectra: within its reference, the collision ends
                    spectra_close_wall(W.hist[i, iw], SPW, dt, S, blk, P.material[i])
                continue
            if SPECTRA:  # collision spectra: the wall's material, the contact open
                W.hist[i, iw, SPW] = wall[W_MATERIAL] + 1.0
            if xw > R.max_overlap * ri and err[0] == 0:
                err[0], err[1], err[2], err[3] = ERR_OVERLAP, step, i, -1 - iw
            p = R.pair_params[P.material[i], int(wall[W_MATERIAL])]
            fn, g0, g1, g2, c0, c1, c2, ai = wall_force(i, xi, xw, n0, n1, n2, u0, u1, u2, p,
                                                        W.hist[i], iw, dt, P, audit_part, blk)
            acc = loaded(bs, W.hist, i, iw, SPRING, xw, fn, g0, g1, g2, P.material[i],
                         int(wall[W_MATERIAL]), acc)
            F0 += g0
            F1 += g1
            F2 += g2
            if PRESSURE:
                FS += fn
            T0 += c0
            T1 += c1
            T2 += c2
            _wall_reaction(wall_part[blk, iw], x, i, ai, n0, n1, n2, g0, g1, g2, u0, u1, u2, wall)
        if MESHES:
            F0, F1, F2, T0, T1, T2, FS, acc = meshes(i, step, dt, P, W, R, err, S, blk, bs, F0,
                                                      F1, F2, T0, T1, T2, FS, acc)
        return F0, F1, F2, T0, T1, T2, FS, acc

    return walls


def mesh_kernel(spec, brk, layout, wall_force):
    """Contacts of free particle i with the triangles of every mesh wall (engine.mesh): the
    candidates listed at the last rebuild, one contact per touching surface (mesh.owns),
    history slots matched by normal. A breakage model's wall hooks see each slot as an analytic
    wall's contact (``hist[i, slot]`` for ``hist[i, iw]``)."""
    PRESSURE = spec.normal_force_sum
    SPRING, TAG = layout.spring, layout.wall_columns
    HIST = TAG + TAG_COLUMNS
    SPECTRA, SPW = layout.spectra, layout.wall_spectra  # collision spectra (loop.spectra)
    MODEL = layout.wall_model > 0  # a breakage model keeps wall-contact state: its hooks run
    reference, loaded, wall_apart = brk.wall_reference, brk.wall_loaded, brk.wall_apart

    def meshes(i, step, dt, P, W, R, err, S, blk, bs, F0, F1, F2, T0, T1, T2, FS, acc):
        M = W
        x, v = P.x, P.v
        hist = M.mesh_hist[i]
        ri = P.radius[i]
        k0, k1 = M.cand_start[i], M.cand_start[i + 1]
        seen = 0
        current = -1
        active = False
        c = s = y0 = y1 = y2 = 0.0
        for k in range(k0, k1):
            t = M.cand_tri[k]
            iw = M.tri_wall[t]
            wall = W.table[iw]
            if iw != current:  # the particle in this mesh's frame
                current = iw
                active = wall[W_ACTIVE] != 0.0
                c, s = wall[W_COS], wall[W_SIN]
                y0, y1, y2 = rotate(c, -s, wall[W_AX], wall[W_AX + 1], wall[W_AX + 2],
                                    x[i, 0] - wall[W_PX], x[i, 1] - wall[W_PX + 1],
                                    x[i, 2] - wall[W_PX + 2])
            if not active:
                continue
            xi, m0, m1, m2, region = triangle_contact(M, t, y0, y1, y2, ri)
            if xi <= 0.0:
                continue
            if not owns(M, k0, k1, k, y0, y1, y2, ri):  # one contact per touching surface
                continue
            if not MODEL and xi > R.max_overlap * ri and err[0] == 0:
                err[0], err[1], err[2], err[3] = ERR_OVERLAP, step, i, -1 - iw
            # the slot of this contact: the one whose normal is near, else a free one
            slot = -1
            fresh = False
            for q in range(MESH_SLOTS):
                if (not (seen >> q) & 1 and hist[q, TAG + 3] == iw + 1
                        and hist[q, TAG] * m0 + hist[q, TAG + 1] * m1 + hist[q, TAG + 2] * m2
                        > SAME_CONTACT_COS):
                    slot = q
                    break
            if slot < 0:
                for q in range(MESH_SLOTS):
                    if not (seen >> q) & 1 and hist[q, TAG + 3] == 0.0:
                        slot = q
                        fresh = True
                        break
            if slot < 0:
                if err[0] == 0:
                    err[0], err[1], err[2], err[3] = ERR_MESH_SLOTS, step, i, -1 - iw
                continue
            seen |= 1 << slot
            hist[slot, TAG], hist[slot, TAG + 1], hist[slot, TAG + 2] = m0, m1, m2
            hist[slot, TAG + 3] = iw + 1
            n0, n1, n2 = rotate(c, s, wall[W_AX], wall[W_AX + 1], wall[W_AX + 2], m0, m1, m2)
            # the surface's velocity at the contact point (mid-overlap): turning plus translation
            lever = ri - 0.5 * xi
            d0 = x[i, 0] - lever * n0 - wall[W_PX]
            d1 = x[i, 1] - lever * n1 - wall[W_PX + 1]
            d2 = x[i, 2] - lever * n2 - wall[W_PX + 2]
            om = wall[W_OMEGA]
            u0 = om * (wall[W_AX + 1] * d2 - wall[W_AX + 2] * d1) + wall[W_VX]
            u1 = om * (wall[W_AX + 2] * d0 - wall[W_AX] * d2) + wall[W_VX + 1]
            u2 = om * (wall[W_AX] * d1 - wall[W_AX + 1] * d0) + wall[W_VX + 2]
            xw = xi
            if MODEL:
                if fresh:
                    # Apart one step ago: the overlap then, the step's drift relative to the
                    # surface taken back (velocity Verlet: x - dt (v - dt a / 2) exactly), is
                    # what an analytic wall's apart hook keeps, so the loading work of the step
                    # that makes the contact counts its whole approach as there.
                    e0 = dt * (v[i, 0] - 0.5 * dt * P.acc[i, 0] - u0)
                    e1 = dt * (v[i, 1] - 0.5 * dt * P.acc[i, 1] - u1)
                    e2 = dt * (v[i, 2] - 0.5 * dt * P.acc[i, 2] - u2)
                    wall_apart(bs, M.mesh_hist, i, slot, SPRING, xi + e0 * n0 + e1 * n1 + e2 * n2)
                # progeny created reaching into a triangle: only overlap beyond that counts
                xw, touching = reference(bs, M.mesh_hist, i, slot, SPRING, xi)
                if not touching:
                    continue
                if xw > R.max_overlap * ri and err[0] == 0:
                    err[0], err[1], err[2], err[3] = ERR_OVERLAP, step, i, -1 - iw
            p = R.pair_params[P.material[i], M.tri_material[t]]
            if SPECTRA:  # collision spectra: the triangle's material, the contact open
                hist[slot, SPW] = M.tri_material[t] + 1.0
            fn, g0, g1, g2, c0, c1, c2, ai = wall_force(i, xi, xw, n0, n1, n2, u0, u1, u2, p,
                                                        hist, slot, dt, P, S.audit_part, blk)
            if MODEL:
                acc = loaded(bs, M.mesh_hist, i, slot, SPRING, xw, fn, g0, g1, g2, P.material[i],
                             M.tri_material[t], acc)
            F0 += g0
            F1 += g1
            F2 += g2
            if PRESSURE:
                FS += fn
            T0 += c0
            T1 += c1
            T2 += c2
            _wall_reaction(S.wall_part[blk, iw], x, i, ai, n0, n1, n2, g0, g1, g2, u0, u1, u2,
                           wall)
        for q in range(MESH_SLOTS):  # contacts that ended
            if not (seen >> q) & 1 and hist[q, TAG + 3] != 0.0:
                if SPECTRA:  # collision spectra: the collision with the mesh ends
                    spectra_close_wall(hist[q], SPW, dt, S, blk, P.material[i])
                for col in range(HIST):
                    hist[q, col] = 0.0
        return F0, F1, F2, T0, T1, T2, FS, acc

    return meshes



NEAR_BITS = 63  # walls with a bit in a particle's near-wall mask; walls beyond it are always visited


def near_walls(spec, layout):
    """Whether the loop visits only the walls near each particle (dry runs with walls). With a
    fluid every wall is visited: its lubrication rows are rewritten each step."""
    return spec.walls and not layout.fluid


def near_walls_kernel(spec):
    """The walls each free particle of the block may touch before the next list rebuild, as a bit
    mask: static planes and cylinders within the skin of its list position (it moves at most
    half the skin before a rebuild, as for the pair list); every other wall (moving, bounded)
    counts as near. Visiting only those gives the same numbers: a wall out of reach is apart
    at every step, and its state was reset when the particle last left it."""
    TRANSLATING, RAMPED = spec.translating_walls, spec.ramped_walls

    def near_walls_block(blk, P, W, R, S):
        x_ref, near = P.x_ref, S.wall_near
        reach = R.skin + R.reach
        n_walls = min(W.table.shape[0], NEAR_BITS)
        for i in range(blk * BLOCK, min(x_ref.shape[0], (blk + 1) * BLOCK)):
            mask = 0
            for iw in range(n_walls):
                wall = W.table[iw]
                kind = int(wall[W_KIND])
                if wall[W_ACTIVE] == 0.0 or kind == MESH:  # disabled; meshes have their candidates
                    continue
                static = SKIP_WHEN_FAR[kind] and not (
                    TRANSLATING and (wall[W_VX] != 0.0 or wall[W_VX + 1] != 0.0
                                     or wall[W_VX + 2] != 0.0)) and not (
                    RAMPED and wall[W_RAMP] > 0.0)  # at rest at t = 0, not for long
                if static:
                    gap = wall_contact(wall, x_ref[i, 0], x_ref[i, 1], x_ref[i, 2],
                                       P.radius[i] + reach)[0]
                    if gap <= 0.0:
                        continue
                mask |= np.int64(1) << np.int64(iw)
            near[i] = mask

    return near_walls_block
