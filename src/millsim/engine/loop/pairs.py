"""The pair passes: the colouring and orders of a list's slots, the geometry of a pair, the
contact evaluation shared with the walls, the slot-record pass (``pair_places_kernel``) and the
colour pass (``colour_block_kernel``). The kernels are factories: the spec's options become the
closure's constants, and :class:`~millsim.engine.loop.runner._Parts` compiles what they return."""

import math

import numpy as np
from numba import njit

from ..neighbours import min_image
from .layout import BLOCK, ERR_OVERLAP, SLOT_BASE
from .spectra import forgotten, spectra_end, spectra_step


@njit(cache=True)
def _slot_rows(start):
    """The particle (row) of each slot of a CSR list."""
    row = np.empty(start[start.shape[0] - 1], dtype=np.int64)
    for i in range(start.shape[0] - 1):
        row[start[i]:start[i + 1]] = i
    return row


@njit(cache=True)
def touching_slots(start, nbr, x, radius, box_len):
    """Whether each slot's pair overlaps now (minimum image along axes with box_len > 0)."""
    touching = np.empty(nbr.shape[0], dtype=np.bool_)
    for i in range(start.shape[0] - 1):
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            dist2 = 0.0
            for a in range(x.shape[1]):
                d = min_image(x[i, a] - x[j, a], a, box_len)
                dist2 += d * d
            rsum = radius[i] + radius[j]
            touching[k] = dist2 < rsum * rsum
    return touching


@njit(cache=True)
def colour_slots(start, nbr, touching):
    """The half list's slots coloured so that no two slots of a colour share a particle (greedy,
    rows in order: the same colours on any thread count), in colour order. Within each block of
    BLOCK places of a colour (the pass's unit of work) the slots that are ``touching`` come
    first, then the others, each by slot: the pass's branch between touching and apart slots is
    then taken the same way for long runs (1.10x in bench/colour_scatter_probe.py), and every
    block keeps its mix of costly and cheap slots. A colour's slots share no particle, so their
    order within it changes no sum. Returns (each colour's first place and the end, the slot,
    its particle and partner at each place)."""
    n, slots = start.shape[0] - 1, nbr.shape[0]
    degree = np.zeros(max(n, 1), dtype=np.int64)
    for i in range(n):
        degree[i] += start[i + 1] - start[i]
        for k in range(start[i], start[i + 1]):
            degree[nbr[k]] += 1
    words = (2 * degree.max()) // 64 + 1  # greedy needs at most deg i + deg j - 1 colours
    used = np.zeros((max(n, 1), words), dtype=np.uint64)
    colour = np.empty(slots, dtype=np.int64)
    n_colours = 0
    for i in range(n):
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            c = 0
            for word in range(words):
                free = ~(used[i, word] | used[j, word])
                if free != 0:
                    bit = 0
                    while (free >> np.uint64(bit)) & np.uint64(1) == 0:
                        bit += 1
                    c = 64 * word + bit
                    break
            colour[k] = c
            used[i, c // 64] |= np.uint64(1) << np.uint64(c % 64)
            used[j, c // 64] |= np.uint64(1) << np.uint64(c % 64)
            n_colours = max(n_colours, c + 1)
    first = np.zeros(n_colours + 1, dtype=np.int64)
    for k in range(slots):
        first[colour[k] + 1] += 1
    for c in range(n_colours):
        first[c + 1] += first[c]
    place = first[:-1].copy()
    order = np.empty(slots, dtype=np.int64)
    owner = np.empty(slots, dtype=np.int64)
    partner = np.empty(slots, dtype=np.int64)
    for i in range(n):
        for k in range(start[i], start[i + 1]):
            q = place[colour[k]]
            place[colour[k]] += 1
            order[q] = k
    # within each block of BLOCK places of a colour (a thread's share), touching slots first
    for c in range(n_colours):
        for lo in range(first[c], first[c + 1], BLOCK):
            hi = min(lo + BLOCK, first[c + 1])
            block = order[lo:hi].copy()
            q = lo
            for sweep in (True, False):
                for k in block:
                    if touching[k] == sweep:
                        order[q] = k
                        q += 1
    row = _slot_rows(start)
    for q in range(slots):
        owner[q], partner[q] = row[order[q]], nbr[order[q]]
    return first, order, owner, partner


@njit(cache=True)
def pair_pass_order(start, touching, n_ranges):
    """The order the pair pass takes the slots in (slot records), for its ``n_ranges`` ranges of
    equal size (the threads' shares, in slot order): within each range the slots ``touching``
    first, then the others, each in slot order. Returns (the slot, its particle) at each place.
    The pass's branch between touching and apart slots is then taken the same way for long
    runs (1.10x on one thread, docs/results/engine_speed.md), and every range keeps its mix of
    costly and cheap slots. Each slot writes only its own record and state, so the order
    changes no number."""
    slots = touching.shape[0]
    row = _slot_rows(start)
    slot = np.empty(slots, dtype=np.int64)
    owner = np.empty(slots, dtype=np.int64)
    q = 0
    for r in range(n_ranges):
        for touching_now in (True, False):
            for k in range(r * slots // n_ranges, (r + 1) * slots // n_ranges):
                if touching[k] == touching_now:
                    slot[q], owner[q] = k, row[k]
                    q += 1
    return slot, owner



def contact_kernel(spec, law, inlined=False):
    """One contact evaluation for pairs and walls: the law, then rolling friction (``inlined``:
    the law inlined into the caller, ContactLaw.inlined_force)."""
    CLIP, ROLLING = spec.clip_normal, spec.rolling_friction
    ROLL = law.rolling_column
    force = law.inlined_force if inlined else law.force

    def contact(p, xi, n0, n1, n2, vr0, vr1, vr2, m_eff, r_eff, hist, k, dt):
        fn, f0, f1, f2, fn_el = force(p, xi, n0, n1, n2, vr0, vr1, vr2, m_eff, r_eff, CLIP, hist,
                                      k, dt)
        # EDEM "standard" rolling friction: a torque mu_r F_n^el r opposing each body's own spin
        # (the caller applies it with r and the spin direction).
        mr = p[ROLL] * fn_el if ROLLING else 0.0
        return fn, f0, f1, f2, fn_el, mr

    if inlined:  # its own name: the kernel cache keys the closure by it (_Parts._inline)
        contact.__name__ = contact.__qualname__ = "contact_inlined"
    return contact



def pair_block_kernel(pair_places):
    def pair_block(lo, hi, step, dt, P, C, R, err, S, bs, fp):
        """Pair pass for the slots at places lo to hi - 1 of the pass order (S.pair_slot)."""
        pair_places(lo, hi, step, dt, P, S.pair_slot, S.pair_owner, C.nbr, C.state, R, err, S.out,
                    S.proll, bs, fp, S.stop, S.lub_slots, S)

    return pair_block


def pair_geometry_kernels(spec):
    """The geometry of a pair, shared by the pair pass and the colour pass: ``separation``
    (x_i - x_j, the minimum image in a periodic box), ``contact_normal`` (unit normal and
    overlap) and ``contact_velocity`` (lever arms, relative velocity of the contact points,
    effective mass). The callers test the overlap guard between the last two: a branch bounds
    where LLVM fuses multiply-adds, so moving it would change the rounding."""
    PERIODIC = spec.periodic

    def separation(i, j, x, R):
        d0 = x[i, 0] - x[j, 0]
        d1 = x[i, 1] - x[j, 1]
        d2 = x[i, 2] - x[j, 2]
        if PERIODIC:
            d0 = min_image(d0, 0, R.box_len)
            d1 = min_image(d1, 1, R.box_len)
            d2 = min_image(d2, 2, R.box_len)
        return d0, d1, d2

    def contact_normal(d0, d1, d2, dist2, rsum):
        dist = math.sqrt(dist2)
        inv = 1.0 / dist
        return d0 * inv, d1 * inv, d2 * inv, rsum - dist

    def contact_velocity(i, j, n0, n1, n2, xi, P):
        # Relative velocity of i's contact point w.r.t. j's: dv - (ai wi + aj wj) x n,
        # lever arms a = r - xi/2 (the contact point sits mid-overlap).
        v, w = P.v, P.w
        ai = P.radius[i] - 0.5 * xi
        aj = P.radius[j] - 0.5 * xi
        s0 = ai * w[i, 0] + aj * w[j, 0]
        s1 = ai * w[i, 1] + aj * w[j, 1]
        s2 = ai * w[i, 2] + aj * w[j, 2]
        vr0 = v[i, 0] - v[j, 0] - (s1 * n2 - s2 * n1)
        vr1 = v[i, 1] - v[j, 1] - (s2 * n0 - s0 * n2)
        vr2 = v[i, 2] - v[j, 2] - (s0 * n1 - s1 * n0)
        m_eff = 1.0 / (P.inv_mass[i] + P.inv_mass[j])
        return ai, aj, vr0, vr1, vr2, m_eff

    return separation, contact_normal, contact_velocity


def pair_places_kernel(spec, law, brk, flu, layout, contact, geometry):
    """Pair pass for the slots at places lo to hi - 1 of the pass order (``pair_pass_order``):
    each writes its record, spring and model columns only."""
    ROLLING, AUDIT = spec.rolling_friction, layout.audit
    IMPLICIT = layout.implicit
    SPRING = law.spring_columns
    SLOT, COL_BRK, COL_T = layout.slot_width, SLOT_BASE, layout.slot_fluid
    COL_AUD = layout.slot_audit
    COL_D = COL_AUD + 3 if AUDIT else -1
    BASE = SPRING  # the breakage model's first contact-state column
    SPECTRA, SP, COL_SP = layout.spectra, layout.contact_spectra, layout.slot_spectra
    reference, apart_hook = brk.pair_reference, brk.pair_apart
    override, loaded = brk.pair_override, brk.pair_loaded
    pair_fluid = flu.pair_fluid
    separation, contact_normal, contact_velocity = geometry

    def pair_places(lo, hi, step, dt, P, slot, owner, nbr, state, R, err, out, proll, bs, fp,
                    stop, rows, S):
        x, v, w, radius = P.x, P.v, P.w, P.radius
        if SPECTRA:
            forget = forgotten(S.audit_part)
        for q in range(lo, hi):
            i, k = owner[q], slot[q]
            j = nbr[k]
            d0, d1, d2 = separation(i, j, x, R)
            rsum = radius[i] + radius[j]
            dist2 = d0 * d0 + d1 * d1 + d2 * d2
            # Fragments start deeply overlapped by construction: only the overlap beyond their
            # reference counts (it shrinks as they part); within it they are apart.
            xi_ref, apart = reference(bs, state, k, BASE, dist2 >= rsum * rsum, rsum, dist2)
            o = out[k]
            if apart:
                for c in range(SPRING):
                    state[k, c] = 0.0
                for a in range(SLOT):
                    o[a] = 0.0
                if SPECTRA:  # a collision that ended: the particle pass counts it (gather)
                    o[COL_SP], o[COL_SP + 1], o[COL_SP + 2] = spectra_end(state[k], SP, dt, forget)
                if ROLLING:
                    proll[k, :, :] = 0.0
                dist = math.sqrt(dist2)
                if IMPLICIT:  # the pair's row record for the solve
                    pair_fluid(fp, rows[k], 0, -1, radius[i], radius[j], d0 / dist, d1 / dist,
                               d2 / dist, dist - rsum, v, w, i, j)
                else:
                    pair_fluid(fp, o, COL_T, COL_D, radius[i], radius[j], d0 / dist, d1 / dist,
                               d2 / dist, dist - rsum, v, w, i, j)
                apart_hook(bs, state, k, BASE, o, COL_BRK, step, i, j, radius, P.body, rsum,
                           dist2, rsum - dist - xi_ref, stop)
                continue
            n0, n1, n2, xi = contact_normal(d0, d1, d2, dist2, rsum)
            ri, rj = radius[i], radius[j]
            xi_c = xi - xi_ref  # the overlap the force and the guard see
            if xi_c > R.max_overlap * min(ri, rj) and err[0] == 0:
                err[0], err[1], err[2], err[3] = ERR_OVERLAP, step, i, j
            ai, aj, vr0, vr1, vr2, m_eff = contact_velocity(i, j, n0, n1, n2, xi, P)
            p = R.pair_params[P.material[i], P.material[j]]
            fixed, fn = override(bs, state, k, BASE, p, xi, n0, n1, n2, vr0, vr1, vr2, m_eff)
            if fixed:
                fn_el, f0, f1, f2, mr = fn, 0.0, 0.0, 0.0, 0.0
            else:
                fn, f0, f1, f2, fn_el, mr = contact(p, xi_c, n0, n1, n2, vr0, vr1, vr2, m_eff,
                                                    ri * rj / rsum, state, k, dt)
            o[0] = fn * n0 + f0
            o[1] = fn * n1 + f1
            o[2] = fn * n2 + f2
            o[3] = n1 * f2 - n2 * f1
            o[4] = n2 * f0 - n0 * f2
            o[5] = n0 * f1 - n1 * f0
            o[6] = xi
            o[7] = fn
            for a in range(SLOT_BASE, SLOT):
                o[a] = 0.0
            if AUDIT:
                # Dissipated power: dashpot part of the normal force, and the tangential force
                # against the slip of the centres and of the surfaces' rotation.
                vn = vr0 * n0 + vr1 * n1 + vr2 * n2
                dv0 = v[i, 0] - v[j, 0]
                dv1 = v[i, 1] - v[j, 1]
                dv2 = v[i, 2] - v[j, 2]
                o[COL_AUD] = -(fn - fn_el) * vn
                o[COL_AUD + 1] = -(f0 * dv0 + f1 * dv1 + f2 * dv2)
                o[COL_AUD + 2] = -(f0 * (vr0 - dv0) + f1 * (vr1 - dv1) + f2 * (vr2 - dv2))
            if IMPLICIT:
                pair_fluid(fp, rows[k], 0, -1, ri, rj, n0, n1, n2, -xi, v, w, i, j)
            else:
                pair_fluid(fp, o, COL_T, COL_D, ri, rj, n0, n1, n2, -xi, v, w, i, j)
            loaded(bs, state, k, BASE, o, COL_BRK, fn, xi_c, P.material[i], P.material[j])
            if ROLLING:
                wi = math.sqrt(w[i, 0] ** 2 + w[i, 1] ** 2 + w[i, 2] ** 2)
                wj = math.sqrt(w[j, 0] ** 2 + w[j, 1] ** 2 + w[j, 2] ** 2)
                for a in range(3):
                    proll[k, 0, a] = -mr * ri * w[i, a] / wi if wi > 0.0 else 0.0
                    proll[k, 1, a] = -mr * rj * w[j, a] / wj if wj > 0.0 else 0.0
                # (its power is booked per particle, after the kick: gather, particle_block)
            if SPECTRA:  # this contact's share of the audit's powers, over its lifetime
                state[k, SP] = 1.0
                spectra_step(state[k], SP, o[COL_AUD], o[COL_AUD + 1] + o[COL_AUD + 2], dt,
                             forget)

    return pair_places


def colour_block_kernel(spec, law, contact, geometry):
    """Colour sums (PhysicsSpec.force_sum): the contacts at places lo to hi - 1 of the colour
    order, each added straight into both particles' sums (Scratch.force). The places of one
    colour share no particle, so threads never add into the same sum, and each sum is taken
    colour by colour whatever the thread count. The same contact as ``pair_places_kernel``'s for
    a run without breakage model or fluid."""
    ROLLING, PRESSURE = spec.rolling_friction, spec.normal_force_sum
    SPRING = law.spring_columns
    separation, contact_normal, contact_velocity = geometry

    def colour_block(lo, hi, step, dt, P, R, err, S):
        x, w, radius = P.x, P.w, P.radius
        owner, partner, state, force = S.colour_owner, S.colour_partner, S.colour_state, S.force
        for q in range(lo, hi):
            i, j = owner[q], partner[q]
            d0, d1, d2 = separation(i, j, x, R)
            rsum = radius[i] + radius[j]
            dist2 = d0 * d0 + d1 * d1 + d2 * d2
            if dist2 >= rsum * rsum:
                for c in range(SPRING):
                    state[q, c] = 0.0
                continue
            n0, n1, n2, xi = contact_normal(d0, d1, d2, dist2, rsum)
            ri, rj = radius[i], radius[j]
            if xi > R.max_overlap * min(ri, rj) and err[0] == 0:
                err[0], err[1], err[2], err[3] = ERR_OVERLAP, step, i, j
            ai, aj, vr0, vr1, vr2, m_eff = contact_velocity(i, j, n0, n1, n2, xi, P)
            p = R.pair_params[P.material[i], P.material[j]]
            fn, f0, f1, f2, fn_el, mr = contact(p, xi, n0, n1, n2, vr0, vr1, vr2, m_eff,
                                                ri * rj / rsum, state, q, dt)
            g0 = fn * n0 + f0
            g1 = fn * n1 + f1
            g2 = fn * n2 + f2
            c0 = n1 * f2 - n2 * f1  # n x F_t, the same for both bodies
            c1 = n2 * f0 - n0 * f2
            c2 = n0 * f1 - n1 * f0
            force[i, 0] += g0
            force[i, 1] += g1
            force[i, 2] += g2
            force[j, 0] -= g0
            force[j, 1] -= g1
            force[j, 2] -= g2
            force[i, 3] -= ai * c0
            force[i, 4] -= ai * c1
            force[i, 5] -= ai * c2
            force[j, 3] -= aj * c0
            force[j, 4] -= aj * c1
            force[j, 5] -= aj * c2
            if PRESSURE:
                force[i, 6] += fn
                force[j, 6] += fn
            if ROLLING:
                wi = math.sqrt(w[i, 0] ** 2 + w[i, 1] ** 2 + w[i, 2] ** 2)
                wj = math.sqrt(w[j, 0] ** 2 + w[j, 1] ** 2 + w[j, 2] ** 2)
                for a in range(3):
                    if wi > 0.0:
                        force[i, 3 + a] -= mr * ri * w[i, a] / wi
                    if wj > 0.0:
                        force[j, 3 + a] -= mr * rj * w[j, a] / wj

    return colour_block
