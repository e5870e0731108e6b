"""Fracture of disks (Buchholtz et al. 2000): Weibull probability per contact event, split into two
disks.

- Probability that a disk of radius R breaks under a contact whose largest normal force over the
  contact event was F: P = 1 - exp(-c R^-3 F^4) (Buchholtz et al. 2000, eq 11 with z = 2 in 2D). It
  is evaluated once per contact event, when the contact ends, so the breakage rate does not depend
  on dt.
- The engine's part (:class:`WeibullModel`): the largest normal force of every contact event is
  kept in the contact state; when the event ends the trial is made inside the step loop, and the
  broken particles end the chunk for the scene's handler to split (``Simulation.pop_events``).
- Fragment sizes: one fragment from the Rosin-Rammler law with k = R, beta = 1, truncated at 3R/4
  (inverse transform R_f = -R ln(1 - u (1 - e^-3/4))), the other from area conservation
  R_2 = sqrt(R^2 - R_f^2) (ballmill.md section 6). Both are placed inside the parent along the
  direction perpendicular to the force, so the split opens across the load.
"""

import math
from collections import namedtuple
from typing import NamedTuple

import numpy as np
from numba import njit

from ...engine.events import room_for
from ...engine.models import NO_BREAKAGE, ParticleModel, stable_identity
from ...engine.rng import hash_uniform
from ...util.validation import check_range

RR_TRUNCATION = 0.75  # largest Rosin-Rammler fragment, in parent radii
_Q_MAX = 1.0 - math.exp(-RR_TRUNCATION)


@njit(inline="always", cache=True)
def fracture_probability(c, radius, force):
    """P = 1 - exp(-c R^-3 F^4) [c in m^3 N^-4, R in m, F in N]."""
    return 1.0 - math.exp(-c * force**4 / radius**3)


def force_at_half_probability(c, radius):
    """F with P = 1/2: (ln 2 R^3 / c)^(1/4)."""
    return (math.log(2.0) * np.asarray(radius) ** 3 / c) ** 0.25


def rosin_rammler_radius(parent, u):
    """Inverse-transform sample of the truncated Rosin-Rammler fragment radius."""
    return -parent * np.log1p(-np.asarray(u) * _Q_MAX)


def rosin_rammler_cdf(r, parent):
    """Truncated, renormalised Rosin-Rammler CDF of the drawn fragment's radius."""
    r = np.clip(np.asarray(r, dtype=float), 0.0, RR_TRUNCATION * parent)
    return (1.0 - np.exp(-r / parent)) / _Q_MAX


def split_disk(center, parent, force_dir, u):
    """Two fragments (centres, radii) filling the parent disk, opened across the force.

    Args:
        center: parent centre (3,), z = 0 in 2D.
        parent: parent radius.
        force_dir: unit vector of the breaking force in the plane.
        u: uniform number for the Rosin-Rammler draw.
    """
    r1 = float(rosin_rammler_radius(parent, u))
    r2 = math.sqrt(parent * parent - r1 * r1)  # area conservation, exact to round-off
    across = np.array([-force_dir[1], force_dir[0], 0.0])
    norm = np.linalg.norm(across)
    across = across / norm if norm > 0 else np.array([1.0, 0.0, 0.0])
    centers = np.array([center + (parent - r1) * across, center - (parent - r2) * across])
    return centers, np.array([r1, r2])


# ---- the model the engine runs: one fracture trial per contact event -----------------------------
# Contact-state columns (after the law's): largest normal force of the event, twin flag, twin
# reference overlap (Buchholtz et al. 2000, eqs 19-20). Slot record columns: the decision (bit 1: i
# breaks, bit 2: j breaks) and the peak force, written when an event ends.
FMAX, TWIN, XIP = 0, 1, 2
DECISION, PEAK = 0, 1
# The twin relief force re-evaluates the law's linear normal force: a law whose parameter row holds
# the spring k_n and the damping rate gamma_n (force m_eff gamma_n v_n) in these columns.
P_K_N, P_GAMMA_N = 0, 1

WeibullBundle = namedtuple("WeibullBundle", ["params"])


def _pair_reference(bs, state, k, base, apart, rsum, dist2):
    # Twin fragments until first separation: only overlap beyond the creation overlap counts.
    if not apart and state[k, base + TWIN] > 0.0:
        return state[k, base + XIP], apart
    return 0.0, apart


def _pair_apart(bs, state, k, base, o, col, step, i, j, radius, body, rsum, dist2, seen, stop):
    # (Twins are never "apart" while they overlap.) The contact event ended: one fracture trial
    # per free body at the event's peak force, with counter-based uniforms (thread-independent).
    fmax = state[k, base + FMAX]
    flag = 0
    if fmax > 0.0:
        c_w = bs.params[0]
        seed = int(bs.params[1])
        if body[i] < 0 and hash_uniform(seed, step, i, j) < fracture_probability(c_w, radius[i], fmax):
            flag |= 1
        if body[j] < 0 and hash_uniform(seed, step, j, i) < fracture_probability(c_w, radius[j], fmax):
            flag |= 2
    o[col + DECISION] = flag
    o[col + PEAK] = fmax
    if flag:
        stop[0] = 1
    state[k, base + FMAX] = 0.0
    state[k, base + TWIN] = 0.0
    state[k, base + XIP] = 0.0


def _pair_override(bs, state, k, base, p, xi, n0, n1, n2, v0, v1, v2, m_eff):
    # Twin fragments (Buchholtz et al. 2000, eqs 19-20): only overlap beyond the reference (the
    # creation overlap, shrinking as they part) resists compression; while they part, a small
    # constant force drives them apart.
    if state[k, base + TWIN] <= 0.0:
        return False, 0.0
    vn = v0 * n0 + v1 * n1 + v2 * n2
    ref = state[k, base + XIP]
    if vn < 0.0:
        fn = max(p[P_K_N] * (xi - ref) - m_eff * p[P_GAMMA_N] * vn, 0.0)
    else:
        fn = bs.params[2]
    state[k, base + XIP] = min(ref, xi)
    return True, fn


def _pair_loaded(bs, state, k, base, o, col, fn, xi, material_i, material_j):
    if state[k, base + TWIN] == 0.0 and fn > state[k, base + FMAX]:
        state[k, base + FMAX] = fn


def _collect(bs, events, n_events, out, col, start, nbr, inv_mass, step):
    # This step's decisions in slot order (deterministic): rows [particle, partner, peak force,
    # step]; the table grows so that no decision is ever dropped.
    needed = n_events[0]
    for k in range(out.shape[0]):
        flag = int(out[k, col + DECISION])
        needed += (flag & 1) + ((flag >> 1) & 1)
    events = room_for(events, n_events[0], needed)
    for i in range(start.shape[0] - 1):
        for k in range(start[i], start[i + 1]):
            flag = int(out[k, col + DECISION])
            if flag == 0:
                continue
            j = nbr[k]
            for side in range(2):
                if flag & (1 << side):
                    me, other = (i, j) if side == 0 else (j, i)
                    row = events[n_events[0]]
                    row[0] = me
                    row[1] = other
                    row[2] = out[k, col + PEAK]
                    row[3] = step
                    n_events[0] += 1
            out[k, col + DECISION] = 0.0
    return events


def _kernel(fn):
    return stable_identity(njit(inline="always", cache=True)(fn), f"weibull.{fn.__name__}")


KERNELS = NO_BREAKAGE._replace(
    pair_reference=_kernel(_pair_reference), pair_apart=_kernel(_pair_apart),
    pair_override=_kernel(_pair_override), pair_loaded=_kernel(_pair_loaded),
    collect=stable_identity(njit(cache=True)(_collect), "weibull._collect"))


class FractureTrial(NamedTuple):
    """A particle that broke when a contact event with ``partner`` ended (Buchholtz et al. 2000)."""

    particle: int
    partner: int
    peak_force: float  # largest normal force of the event [N]
    step: int


class WeibullModel(ParticleModel):
    """Buchholtz et al. 2000 breakage for the engine: fracture trials per contact event, twin
    relief.

    Args:
        c: Weibull constant [m^3 N^-4] of P = 1 - exp(-c R^-3 F^4).
        twin_repulsion: constant force [N] pushing twin fragments apart until they separate.
        seed: seed of the counter-based trials.
    """

    kind, name = "breakage", "weibull"
    contact_columns = ("peak_force", "twin", "twin_reference_overlap")
    slot_columns = ("decision", "peak_force")
    kernels = KERNELS
    event_columns = 4

    def __init__(self, c, twin_repulsion=0.0, seed=0):
        self.c = check_range("weibull.c", c, 0.0)
        self.twin_repulsion = check_range("weibull.twin_repulsion", twin_repulsion, 0.0)
        self.seed = int(seed)

    def attach(self, sim):
        if (sim.law.column("k_n"), sim.law.column("gamma_n")) != (P_K_N, P_GAMMA_N):
            raise ValueError("breakage: the Weibull model (Buchholtz et al. 2000) needs a contact law "
                             f"with a linear spring k_n and damping rate gamma_n; {sim.law.name!r} "
                             "has none")
        super().attach(sim)

    def params(self):
        return np.array([self.c, self.seed, self.twin_repulsion], dtype=float)

    def bundle(self, fields):
        return WeibullBundle(self.params())

    def records(self, rows):
        return [FractureTrial(int(a), int(b), float(f), int(s)) for a, b, f, s in rows]

    def reference_overlap(self, state):
        """Creation overlap of twin pairs (0 for ordinary pairs), from their contact-state rows."""
        return np.where(state[:, TWIN] > 0, state[:, XIP], 0.0)

    def mark_twins(self, i, j):
        """Fragments i and j were created overlapping: only overlap beyond the present one counts,
        and the pair gets the twin relief force until it first separates (Buchholtz et al. 2000,
        eqs 19-20)."""
        sim = self.sim
        k = sim.slot(i, j)
        if k is None:
            return
        base = sim.layout.spring
        d = sim.particles.x[i] - sim.particles.x[j]
        overlap = sim.particles.radius[i] + sim.particles.radius[j] - np.linalg.norm(d)
        sim.contacts.state[k, base + TWIN] = 1.0
        sim.contacts.state[k, base + XIP] = overlap

    def twin_partners(self, i):
        """Particles that are still twins of particle i (fragments not yet separated)."""
        c = self.sim.contacts
        twin = c.state[:, self.sim.layout.spring + TWIN] > 0
        mine = np.arange(c.start[i], c.start[i + 1])
        theirs = c.rev_slot[c.rev_start[i]:c.rev_start[i + 1]]
        owner = np.searchsorted(c.start, theirs, side="right") - 1
        return [int(j) for j in c.nbr[mine][twin[mine]]] + [int(o) for o in owner[twin[theirs]]]


class Fracture(NamedTuple):
    """One breakage of :class:`WeibullSplit`: when, where, which grain, how hard."""

    time: float  # [s]
    x: float  # centre of the breaking grain [m]
    y: float
    radius: float  # of the breaking grain [m]
    force: float  # peak normal force of the breaking contact [N]


class WeibullSplit:
    """Breakage handler of Buchholtz et al. 2000 (``Simulation.run(on_events=...)``): every grain
    that broke in the last step becomes two disks (:func:`split_disk`, opened across the breaking
    force), fragments below the sieve radius leave as dust.

    New fragments are twins of each other, of the other fragments created in the same step that
    they overlap (children of twins that broke together) and of the parent's remaining twins: all
    those overlaps are artefacts of the split, not compression. A fragment inherits the parent's
    rigid-body velocity at its centre and its spin, and has its id as parent id
    (``Simulation.parent_ids``).

    Args:
        sieve_radius: fragments smaller than this leave as dust [m].
        mass: the mass of a disk of radius r (callable, kg).
        material: material name of the fragments; rng: numpy Generator of the split draws.
    """

    def __init__(self, sieve_radius, mass, material, rng):
        self.sieve_radius, self.mass, self.material, self.rng = sieve_radius, mass, material, rng
        self.events = []  # a Fracture per breakage
        self.dust_total = 0.0  # dust removed so far [kg]
        self.dust_pending = 0.0  # dust removed and not yet returned by the caller [kg]

    def __call__(self, sim):
        p = sim.particles
        parents, frag_x, frag_r, frag_v, frag_w, frag_parent = [], [], [], [], [], []
        for i, j, force, _ in sim.pop_events():
            if i in parents:
                continue  # two contacts broke the same grain in one step: one split
            d = p.x[i] - p.x[j]
            centres, radii = split_disk(p.x[i].copy(), float(p.radius[i]), d / np.linalg.norm(d),
                                        self.rng.uniform())
            self.events.append(Fracture(sim.time, p.x[i, 0], p.x[i, 1], float(p.radius[i]), force))
            parents.append(i)
            keep = radii >= self.sieve_radius
            dust = float(self.mass(radii[~keep]).sum())
            self.dust_pending += dust
            self.dust_total += dust
            for c, r in zip(centres[keep], radii[keep]):
                frag_x.append(c)
                frag_r.append(r)
                frag_v.append(p.v[i] + np.cross(p.w[i], c - p.x[i]))
                frag_w.append(p.w[i].copy())
                frag_parent.append(i)
        model = sim.breakage
        partners = {i: model.twin_partners(i) for i in parents}
        parent_ids = sim.particle_ids[np.array(frag_parent, np.int64)]  # before removing them
        mask = np.zeros(sim.n_particles, bool)
        mask[parents] = True
        new_index = np.cumsum(~mask) - 1
        sim.remove_particles(mask)
        first = sim.n_particles
        if not frag_r:
            return
        sim.add_particles(np.array(frag_x), np.array(frag_r), self.material, v=np.array(frag_v),
                          w=np.array(frag_w), parent_ids=parent_ids)
        xs, rs = np.array(frag_x), np.array(frag_r)
        for a in range(len(rs)):
            for b in range(a + 1, len(rs)):
                if np.linalg.norm(xs[a] - xs[b]) < rs[a] + rs[b]:
                    model.mark_twins(first + a, first + b)
            for q in partners[frag_parent[a]]:
                if not mask[q]:
                    model.mark_twins(first + a, int(new_index[q]))
