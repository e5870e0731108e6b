"""The assembled step loop: one compiled function per physics specification and model set.

``build_chunk_runner(spec, law, breakage, fluid)`` returns a :class:`ChunkRunner` that advances the
state by ``n_steps`` steps: one compiled function (``advance``) runs the steps of a neighbour list's
lifetime without returning to Python; the runner rebuilds the list between them. ``advance`` is a
composition of small sub-kernels (``inline="always"``) over a few named bundles of arrays
(:mod:`millsim.engine.state`):

1. pair pass (parallel over particles): every Verlet slot evaluates its contact into a per-slot
   record (no shared writes): the geometry, the model hooks that decide what overlap counts, one
   contact evaluation (the law's kernel, also used for walls), lubrication, energy audit;
2. particle pass (parallel over fixed blocks): gather the slot records in a fixed order, add wall
   contacts and gravity, let the breakage model decide, finish the integrator step and start the
   next (Verlet drift / Gear predictor), move kinematic-body particles to their prescribed pose;
3. serial: reduce body and wall loads and the energy audit over fixed blocks; return when a
   breakage model decided (the runner collects the decisions) or a particle moved more than half
   the skin (the runner rebuilds the neighbour list).

The physics options of the spec and the models' hooks are frozen into the function: what a scene
does not use is never typed or compiled (numba prunes branches on the closure's constants before
typing; absent models are the no-op hooks of :mod:`millsim.engine.models`). Because no sum
depends on how iterations are split among threads, results are bit-identical for any thread
count. Compiled variants are cached on disk (``cache=True``; the closure's functions carry a
stable identity, :func:`~millsim.engine.models.stable_identity`).
"""

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from .implicit import (
    LP_FORCE,
    LP_WIDTH,
    LPP_WIDTH,
    RW_ACT,
    RW_LAM,
    RW_VJ,
    RW_WALL_WIDTH,
    RW_WIDTH,
    RW_Z,
    lub_kernels,
    row_absent,
    row_impulse,
    row_power,
)
from .integrators import gear_correct, gear_predict, verlet_drift, verlet_kick
from .jit_options import FAST, PRANGE_ONLY
from .kinematics import (
    CYLINDER_OUTER,
    MESH,
    ROTATE,
    body_motion,
    body_pose,
    place_meshes,
    place_walls,
    wall_contact,
    wall_contact_bounded,
)
from .mesh import (
    MESH_SLOTS,
    SAME_CONTACT_COS,
    TAG_COLUMNS,
    mesh_travel,
    owns,
    rotate,
    triangle_contact,
    with_mesh_candidates,
)
from .models import NO_BREAKAGE, NO_FLUID, stable_identity
from .neighbours import min_image, rebuilt_contacts
from .state import ColourScratch, Scratch

BLOCK = 256  # particles per reduction block (fixed, so sums do not depend on the thread count)
SLOT_BASE = 8  # slot record: force on i (3), n x F_t (3), overlap, normal force
# Energy audit terms [J]: contact normal damping, tangential force x centre slip, tangential force x
# rotational slip (+ rolling friction), lubrication normal (squeeze), lubrication tangential.
N_AUDIT = 5
AUDIT_TERMS = ("contact_normal_damping", "contact_tangential_translation",
               "contact_tangential_rotation", "lubrication_normal", "lubrication_tangential")
# Guard codes written to err[0]; err = [code, step, particle, partner]. With threads the particle
# recorded is whichever got there first; the Python side names a deterministic one.
# ERR_MESH_SLOTS: a particle touches more mesh triangles at once than it has history slots.
ERR_OVERLAP, ERR_NONFINITE, ERR_SPEED, ERR_MESH_SLOTS = 1, 2, 3, 4


@dataclass(frozen=True)
class Layout:
    """Where each model's columns sit in the contact state, wall state and slot record."""

    spring: int  # contact law's per-contact state (tangential spring)
    contact_model: int  # breakage model's per-contact columns
    wall_model: int
    slot_model: int  # breakage model's slot-record columns
    fluid: bool
    audit: bool
    implicit: bool = False  # the fluid's resistance is integrated implicitly (engine.implicit)

    @property
    def contact_columns(self):
        return self.spring + self.contact_model

    @property
    def wall_columns(self):
        return self.spring + self.wall_model

    @property
    def slot_fluid(self):  # explicit lubrication torques on i and j (implicit: Scratch.lub_slots)
        return SLOT_BASE + self.slot_model

    @property
    def slot_audit(self):
        return self.slot_fluid + (6 if self.fluid and not self.implicit else 0)

    @property
    def slot_width(self):
        return self.slot_audit + (N_AUDIT if self.audit else 0)

class ChunkRunner:
    """``runner(n_steps, t, k0, dt, step0, P, C, W, B, R, A, bs, fp, events, prime)`` advances up
    to ``n_steps`` steps and returns ``(steps_done, C, W, events)``: the compiled ``advance`` runs
    the steps of one neighbour list; between its calls this rebuilds the list (one call per list
    lifetime, so the Python overhead is per rebuild, not per step) and collects breakage
    decisions. ``prime``: compute the forces of the start state before the first step.
    The chunk starts at time ``t + k0 dt``: ``t`` is the time at the last change of ``dt``, ``k0``
    the steps since. Every time in a step is ``t + k dt`` from that same origin, so that where a
    run is cut into chunks does not change a bit of it (a time summed chunk by chunk did)."""

    def __init__(self, advance, start_forces, collect, layout, rolling, periodic, near_walls,
                 colour):
        self.advance, self.start_forces, self.collect = advance, start_forces, collect
        self.slot_width, self.audit, self.implicit = layout.slot_width, layout.audit, layout.implicit
        self.rolling, self.periodic, self.near_walls = rolling, periodic, near_walls
        self.colour = colour

    def __call__(self, n_steps, t, k0, dt, step0, P, C, W, B, R, A, bs, fp, events, prime):
        n = P.x.shape[0]
        n_blocks = (n + BLOCK - 1) // BLOCK
        n_walls = W.table.shape[0]
        implicit = self.implicit
        # per chunk: wall-load and audit partial sums, the stop flag (a breakage decision ends
        # the chunk at its step) and the rebuild flag; implicit lubrication: the wall rows
        # zeroed (rows of walls a particle never visits, body particles', stay inactive), the
        # loads and velocities of the solve and its partial sums
        shared = dict(
            wall_part=np.zeros((n_blocks, max(n_walls, 1), 7)),
            audit_part=np.zeros((n_blocks if self.audit else 0, N_AUDIT)),
            stop=np.zeros(1, dtype=np.int64), rebuild=np.zeros(1, dtype=np.int64),
            lub_rows=np.zeros((n if implicit else 0, n_walls, RW_WALL_WIDTH)),
            lub_particle=np.zeros((n if implicit else 0, LP_WIDTH)),
            cg_part=np.zeros((n_blocks if implicit else 0, 3)),
            wall_near=np.zeros(n if self.near_walls else 0, dtype=np.int64))
        if self.colour:
            shared["force"] = np.zeros((n, 7))
        S = self._scratch(C, shared, P, R)
        if prime:
            self.start_forces(t, k0, dt, step0, P, C, W, B, R, A, S, bs, fp, True)
        step = self.advance(n_steps, 0, True, t, k0, dt, step0, P, C, W, B, R, A, S, bs, fp)
        self._springs_back(C, S)
        while True:
            if S.stop[0] != 0:
                events = self.collect(bs, events, A.n_events, S.out, SLOT_BASE, C.start, C.nbr,
                                      P.inv_mass, step0 + step - 1)
                break
            if A.err[0] != 0 or step >= n_steps:
                break
            # a particle moved more than half the skin
            C = rebuilt_contacts(P, C, R.skin + R.reach, R.dim, R.box_lo, R.box_len,
                                 self.periodic)
            if hasattr(W, "tri"):  # mesh walls (MeshWallArrays)
                W = with_mesh_candidates(W, P, R.skin, t + (k0 + step) * dt)
            S.rebuild[0] = 0
            S = self._scratch(C, shared, P, R)
            A.counters[0] += 1
            step = self.advance(n_steps, step, False, t, k0, dt, step0, P, C, W, B, R, A, S, bs,
                                fp)
            self._springs_back(C, S)
        A.counters[1] += step
        return step, C, W, events

    def _scratch(self, C, shared, P, R):
        """Per-slot records (see Layout) and rolling torques for the slots of list C, with the
        chunk's arrays (``shared``)."""
        slots = C.nbr.shape[0]
        implicit, colour = self.implicit, self.colour
        if colour:  # the slots in colour order, the springs with them for the list's lifetime
            touching = touching_slots(C.start, C.nbr, P.x, P.radius, R.box_len)
            start, order, owner, partner = colour_slots(C.start, C.nbr, touching)
            return ColourScratch(pair_slot=np.empty(0, dtype=np.int64),
                                 pair_owner=np.empty(0, dtype=np.int64),
                                 out=np.empty((0, self.slot_width)), proll=np.empty((0, 2, 3)),
                                 lub_slots=np.zeros((0, RW_WIDTH)),
                                 lub_partner=np.empty((0, LPP_WIDTH)), colour_start=start,
                                 colour_slot=order, colour_owner=owner, colour_partner=partner,
                                 colour_state=C.state[order], **shared)
        slot, owner = pair_pass_order(C.start,
                                      touching_slots(C.start, C.nbr, P.x, P.radius, R.box_len),
                                      (P.x.shape[0] + BLOCK - 1) // BLOCK)
        return Scratch(pair_slot=slot, pair_owner=owner,
                       out=np.empty((slots, self.slot_width)),
                       proll=np.empty((slots if self.rolling else 0, 2, 3)),
                       lub_slots=np.zeros((slots if implicit else 0, RW_WIDTH)),
                       lub_partner=np.empty((slots if implicit else 0, LPP_WIDTH)), **shared)

    def _springs_back(self, C, S):
        """Colour sums: the springs back to the list's slot order (list rebuilds, checkpoints and
        contact queries read them there)."""
        if self.colour:
            C.state[S.colour_slot] = S.colour_state


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


@njit(cache=True)
def _moved_beyond(x, x_ref, half_skin2):
    """Whether a particle has moved more than half the skin since the list was built."""
    for i in range(x.shape[0]):
        d0 = x[i, 0] - x_ref[i, 0]
        d1 = x[i, 1] - x_ref[i, 1]
        d2 = x[i, 2] - x_ref[i, 2]
        if d0 * d0 + d1 * d1 + d2 * d2 > half_skin2:
            return True
    return False


def build_chunk_runner(spec, law, breakage=None, fluid=None):
    """Compile (or load from cache) the chunk runner.

    Args:
        spec: :class:`~millsim.engine.spec.PhysicsSpec`.
        law: the contact law (``force`` kernel, ``spring_columns``, ``rolling_column``).
        breakage, fluid: model objects (:class:`~millsim.engine.models.ParticleModel`) or None.
    """
    return chunk_parts(spec, law, breakage, fluid)[0].runner


def chunk_parts(spec, law, breakage=None, fluid=None):
    """The sub-kernels of one physics variant and their column layout: ``(_Parts, Layout)``.
    The chunk runner composes them; bench/pass_times.py times its passes one by one."""
    layout = Layout(law.spring_columns,
                    len(breakage.contact_columns) if breakage else 0,
                    len(breakage.wall_columns) if breakage else 0,
                    len(breakage.slot_columns) if breakage else 0,
                    fluid is not None, spec.energy_audit, fluid is not None and fluid.implicit)
    key = (f"{spec}|{law.name}|{breakage.name if breakage else ''}|"
           f"{fluid.name if fluid else ''}|{layout}")
    parts = _Parts(spec, law, breakage.kernels if breakage else NO_BREAKAGE,
                   fluid.kernels if fluid else NO_FLUID, layout, key)
    return parts, layout


class _Parts:
    """The sub-kernels of one variant, and the chunk runner composed of them.

    The per-block passes are ordinary compiled functions (without reference counting, see
    ``_jit``) called from the parallel loops, and the small per-particle and per-contact pieces
    are inlined into them. (numba 0.68 loses writes to arrays reached through a named tuple's
    attribute inside a ``prange`` body, also when the access sits in an inlined function, so no
    bundle is opened inside a parallel loop itself.)
    """

    def __init__(self, spec, law, brk, flu, layout, key):
        self.key = key
        contact = self._inline(_contact_kernel(spec, law))
        wall_force = self._inline(_wall_force_kernel(spec, layout, contact))
        meshes = self._inline(_mesh_kernel(spec, layout, wall_force)) if spec.mesh_walls else None
        finish = self._inline(_finish_kernel(spec))
        geometry = tuple(self._inline(fn) for fn in _pair_geometry_kernels(spec))
        if spec.force_sum == "colour":
            self.pair_block = None
            self.colour_block = self._jit(_colour_block_kernel(
                spec, law, self._inline(_contact_kernel(spec, law, inlined=True)), geometry))
        else:
            self.pair_block = self._jit(_pair_block_kernel(
                self._inline(_pair_places_kernel(spec, law, brk, flu, layout, contact, geometry))))
            self.colour_block = None
        self.particle_block = self._jit(_particle_block_kernel(
            spec, brk, layout,
            gather=self._inline(_gather_kernel(spec, brk, layout)),
            walls=self._inline(_walls_kernel(spec, law, brk, flu, layout, wall_force, meshes)),
            finish=finish))
        self.start_block = self._jit(_start_block_kernel(spec))
        self.reductions = self._jit(_reduction_kernel(spec, layout))
        self.near_walls_block = (self._jit(_near_walls_kernel(spec)) if near_walls(spec, layout)
                                 else None)
        if layout.implicit:  # the implicit lubrication solve (engine.implicit); else not compiled
            self.lub_blocks = tuple(self._jit(fn) for fn in lub_kernels(spec, layout, BLOCK))
            self.lub_finish_block = self._jit(_lub_finish_kernel(spec, layout, finish))
            self.lub_solve = self._lub_solver()
        else:
            self.lub_solve = self.lub_finish_block = None
        self.runner = self._runner(spec, brk, layout)

    def _inline(self, fn):
        return stable_identity(njit(inline="always", cache=True, fastmath=FAST)(fn),
                               f"{self.key}|{fn.__name__}")

    def _jit(self, fn):
        # Without numba's reference counting (NRT): the inlined sub-kernels receive the bundles
        # per particle and per wall, and each copy of an array costs an atomic incref/decref
        # that numba's pruning pass cannot remove once the pair splits across branches and
        # loops (numba issues #2345, #2350): 30-odd pairs per particle made the loop 5x slower
        # (docs/results/restructure.md). These kernels only read and write arrays they are
        # handed, which the caller keeps alive; an allocation in them fails to compile.
        return stable_identity(njit(cache=True, fastmath=FAST, _nrt=False)(fn),
                               f"{self.key}|{fn.__name__}")

    def _parallel(self, fn):
        # PRANGE_ONLY: only the prange loops run in parallel, consecutive loops are not fused
        return stable_identity(njit(parallel=PRANGE_ONLY, cache=True, fastmath=FAST)(fn),
                               f"{self.key}|{fn.__name__}")

    def _runner(self, spec, brk, layout):
        NEAR_WALLS = near_walls(spec, layout)
        COLOUR = spec.force_sum == "colour"
        return ChunkRunner(self._advance(spec, layout), self._start_forces(spec, layout),
                           brk.collect, layout, spec.rolling_friction, spec.periodic, NEAR_WALLS,
                           COLOUR)

    # The steps of one neighbour list's lifetime (``_advance``) and the forces of the start state
    # (``_start_forces``), each with its parallel loops in one function. (Not inside one compiled
    # chunk loop that also rebuilds the list: numba links every callee's code into its caller's
    # and optimises it again at each level, so a level less is compile time less,
    # docs/results/restructure.md; and parfor lowering needs one definition of each bundle it
    # hands to the threads, which a rebuild redefines.) The block index is cast: numba types a
    # prange index int64 when it types the function and uint64 in the parallel kernel, and each
    # type would compile the block kernel again. No bundle is opened inside a prange body (numba
    # 0.68 loses writes made through a named tuple's attribute there), so err and the scratch
    # flags are taken out first.
    def _start_forces(self, spec, layout):
        TRANSLATING, MESHES = spec.translating_walls, spec.mesh_walls
        AUDIT, IMPLICIT = layout.audit, layout.implicit
        NEAR_WALLS, COLOUR = near_walls(spec, layout), spec.force_sum == "colour"
        near_walls_block, pair_block = self.near_walls_block, self.pair_block
        colour_block, particle_block = self.colour_block, self.particle_block
        lub_solve, lub_finish_block = self.lub_solve, self.lub_finish_block

        def start_forces(t, k0, dt, step0, P, C, W, B, R, A, S, bs, fp, last):
            """The forces of the start state at t + k0 dt (a run that starts in contact or inside
            a fluid film): the first drift uses them. Evaluated with dt = 0, which advances no
            spring; ``last`` is True (passed in: a literal would compile another particle pass)."""
            n_blocks = (P.x.shape[0] + BLOCK - 1) // BLOCK
            half_skin2 = 0.25 * R.skin * R.skin
            err, counters = A.err, A.counters
            wall_part, audit_part = S.wall_part, S.audit_part
            if NEAR_WALLS:
                for blk in prange(n_blocks):
                    near_walls_block(np.int64(blk), P, W, R, S)
            if COLOUR:  # colour by colour; a colour's slots share no particle
                colours = S.colour_start
                for c in range(colours.shape[0] - 1):
                    lo, hi = colours[c], colours[c + 1]
                    for b in prange((hi - lo + BLOCK - 1) // BLOCK):
                        colour_block(lo + b * BLOCK, min(hi, lo + (b + 1) * BLOCK), step0, 0.0, P,
                                     R, err, S)
            else:
                slots = C.nbr.shape[0]
                for b in prange(n_blocks):
                    pair_block(b * slots // n_blocks, (b + 1) * slots // n_blocks, step0, 0.0, P,
                               C, R, err, S, bs, fp)
            t_start = t + k0 * dt
            if TRANSLATING:
                place_walls(W.table, t_start)
            if MESHES:
                place_meshes(W.table, t_start)
            for blk in prange(n_blocks):
                particle_block(np.int64(blk), np.int64(0), last, t_start, 0.0, P, C, W, B, R, err,
                               S, bs, fp, half_skin2)
            if IMPLICIT:
                # the first kick starts at the state: half a step of lubrication, so that the
                # first drift moves with the implicit half-step velocity (lub_solve)
                lub_solve(n_blocks, 0.0, 0.5 * dt, False, P, C, R, S, fp, counters)
                for blk in prange(n_blocks):
                    lub_finish_block(np.int64(blk), np.int64(0), last, t_start, 0.0, 0.5 * dt, P,
                                     C, W, B, R, err, S, half_skin2)
            for a in range(N_AUDIT if AUDIT else 0):  # the audit's power at t (trapezoid)
                power = 0.0
                for blk in range(n_blocks):
                    power += audit_part[blk, a]
                    audit_part[blk, a] = 0.0
                A.dissipation[N_AUDIT + a] = power
            for blk in range(wall_part.shape[0]):
                for k in range(wall_part.shape[1]):
                    for c in range(wall_part.shape[2]):
                        wall_part[blk, k, c] = 0.0

        return self._parallel(start_forces)

    def _advance(self, spec, layout):
        TRANSLATING, MESHES = spec.translating_walls, spec.mesh_walls
        IMPLICIT = layout.implicit
        NEAR_WALLS, COLOUR = near_walls(spec, layout), spec.force_sum == "colour"
        near_walls_block = self.near_walls_block
        pair_block, particle_block = self.pair_block, self.particle_block
        colour_block = self.colour_block
        start_block, reductions = self.start_block, self.reductions
        lub_solve, lub_finish_block = self.lub_solve, self.lub_finish_block

        def advance(n_steps, step, begin, t, k0, dt, step0, P, C, W, B, R, A, S, bs, fp):
            """Steps from ``step`` until n_steps, a breakage decision, a guard, or a due list
            rebuild (S.rebuild set); returns the steps done. ``begin``: the chunk's first call.
            Local step k ends at t + (k0 + k + 1) dt (see ChunkRunner)."""
            n_blocks = (P.x.shape[0] + BLOCK - 1) // BLOCK
            half_skin2 = 0.25 * R.skin * R.skin
            err, counters = A.err, A.counters
            stop, rebuild = S.stop, S.rebuild
            wall_part, audit_part = S.wall_part, S.audit_part
            slots = C.nbr.shape[0]  # the pair pass: equal ranges of its order's places
            if COLOUR:
                colours = S.colour_start  # each colour's first place in the colour order
            if NEAR_WALLS:  # the walls each particle can reach in this list's lifetime
                for blk in prange(n_blocks):
                    near_walls_block(np.int64(blk), P, W, R, S)
            if begin:
                t_next = t + (k0 + 1) * dt
                for blk in prange(n_blocks):  # start the first step, bodies at its end
                    start_block(np.int64(blk), t_next, dt, P, B)
                if _moved_beyond(P.x, P.x_ref, half_skin2) or (
                        MESHES and mesh_travel(W, t + k0 * dt) > 0.5 * R.skin):
                    # the last chunk ended on a step that asked for a list rebuild: do it now,
                    # before any pair is evaluated (a list older than half a skin of travel can
                    # miss pairs)
                    rebuild[0] = 1
                    return step
            warm = False  # implicit lubrication: impulses of the last step kept in the rows
            while step < n_steps:
                step_now = step0 + step
                if COLOUR:  # colour by colour; a colour's slots share no particle
                    for c in range(colours.shape[0] - 1):
                        lo, hi = colours[c], colours[c + 1]
                        for b in prange((hi - lo + BLOCK - 1) // BLOCK):
                            colour_block(lo + b * BLOCK, min(hi, lo + (b + 1) * BLOCK), step_now,
                                         dt, P, R, err, S)
                else:
                    for b in prange(n_blocks):
                        pair_block(b * slots // n_blocks, (b + 1) * slots // n_blocks, step_now,
                                   dt, P, C, R, err, S, bs, fp)
                last = step == n_steps - 1 or stop[0] != 0
                t_end = t + (k0 + step + 1) * dt  # where the step's forces are evaluated
                t_pose = t + (k0 + step + 2) * dt  # body particles' pose for the next step
                if TRANSLATING:
                    place_walls(W.table, t_end)
                if MESHES:
                    place_meshes(W.table, t_end)
                    if mesh_travel(W, t_end) > 0.5 * R.skin:
                        rebuild[0] = 1  # the mesh's triangles near each particle are due
                for blk in prange(n_blocks):
                    particle_block(np.int64(blk), step, last, t_pose, dt, P, C, W, B, R, err, S,
                                   bs, fp, half_skin2)
                if IMPLICIT:
                    # the kick needs the lubrication impulses first; a breakage decision of the
                    # particle pass is known here, so that step ends without the drift
                    last = last or stop[0] != 0
                    lub_solve(n_blocks, 0.5 * dt, dt, warm, P, C, R, S, fp, counters)
                    warm = True
                    for blk in prange(n_blocks):
                        lub_finish_block(np.int64(blk), step, last, t_pose, dt, dt, P, C, W, B, R,
                                         err, S, half_skin2)
                elif stop[0] != 0 and not last:
                    # A particle broke in the particle pass, after ``last`` was decided, so every
                    # particle has already started the next step: take that back, so that the
                    # chunk ends at the step boundary like any other, with positions and
                    # velocities at t + dt (else each breakage added an extra drift and handed
                    # the handler predicted velocities v + dt a: an energy error per event).
                    for blk in prange(n_blocks):
                        start_block(np.int64(blk), t_end, -dt, P, B)
                reductions(t_end, dt, P, B, W, A.dissipation, wall_part, audit_part, n_blocks)
                step += 1
                if err[0] != 0 or stop[0] != 0 or (rebuild[0] != 0 and not last):
                    break
            return step

        return self._parallel(advance)

    def _lub_solver(self):
        """The implicit lubrication solve (engine.implicit); ``advance``'s finish pass applies it.

        ``lub_solve(n_blocks, back, tau, warm, ...)``: the kick of length tau starts at
        v- = v - back acc: the half-step velocity (v holds the prediction v + dt a of the last
        drift, back = dt/2), or the state itself when priming (back = 0, tau = dt/2). The other
        loads of the particle pass give the free velocity v_f = v- + tau a, and preconditioned CG
        solves (C + W) lam = b (engine.implicit: b = J v_f + (1 - theta)/theta J v-) until
        r.D^-1 r <= tol^2 b.D^-1 b or ``max_iterations``, with every sum over fixed blocks. It
        starts from the impulses of the last step (``warm``: no list rebuild since) where they
        lower the objective below its value at 0, else from 0.
        """
        setup_particles, p1_own, p1_partner, setup_slots, restart, p3 = self.lub_blocks

        # (One parallel loop per function: each pass reads what the one before wrote for other
        # blocks, so they must not be fused.)
        def setup_particle_pass(n_blocks, back, tau, P, R, S):
            for blk in prange(n_blocks):
                setup_particles(np.int64(blk), back, tau, P, R, S)

        def setup_slot_pass(n_blocks, back, tau, warm, P, C, S):
            for blk in prange(n_blocks):
                setup_slots(np.int64(blk), back, tau, warm, P, C, S)

        def restart_pass(n_blocks, P, C, S):
            for blk in prange(n_blocks):
                restart(np.int64(blk), P, C, S)

        def pass1_own(n_blocks, beta, a, P, C, S):
            for blk in prange(n_blocks):
                p1_own(np.int64(blk), beta, a, P, C, S)

        def pass1_partner(n_blocks, beta, a, P, C, S):
            for blk in prange(n_blocks):
                p1_partner(np.int64(blk), beta, a, P, C, S)

        def pass3(n_blocks, alpha, P, C, S):
            for blk in prange(n_blocks):
                p3(np.int64(blk), alpha, P, C, S)

        setup_particle_pass = self._parallel(setup_particle_pass)
        setup_slot_pass = self._parallel(setup_slot_pass)
        restart_pass = self._parallel(restart_pass)
        pass1_own, pass1_partner = self._parallel(pass1_own), self._parallel(pass1_partner)
        pass3 = self._parallel(pass3)

        def pass1(n_blocks, beta, a, P, C, S):
            """u = M^-1 J^T p and the blocks' parts of p.(C + W) p (engine.implicit p1_own,
            p1_partner)."""
            pass1_own(n_blocks, beta, a, P, C, S)
            pass1_partner(n_blocks, beta, a, P, C, S)

        def block_sum(part, col):
            total = 0.0
            for blk in range(part.shape[0]):
                total += part[blk, col]
            return total

        def lub_solve(n_blocks, back, tau, warm, P, C, R, S, fp, counters):
            setup_particle_pass(n_blocks, back, tau, P, R, S)
            if warm:  # u = M^-1 J^T lam of the impulses kept from the last step
                pass1(n_blocks, 0.0, RW_LAM, P, C, S)
            setup_slot_pass(n_blocks, back, tau, warm, P, C, S)
            part = S.cg_part
            rho = block_sum(part, 1)
            if warm and block_sum(part, 0) < 0.0:
                # the kept impulses would raise the objective above f(0) = 0, where the energy
                # argument starts: from 0 then
                restart_pass(n_blocks, P, C, S)
                rho = block_sum(part, 1)
            stop_at = fp[3] * fp[3] * block_sum(part, 2)  # relative to b.D^-1 b, b = J v_f
            iterations = 0
            beta = 0.0
            while rho > stop_at and iterations < fp[4]:
                pass1(n_blocks, beta, RW_Z, P, C, S)
                pq = block_sum(part, 0)
                if not pq > 0.0:  # rounding at convergence: nothing left to reduce
                    break
                pass3(n_blocks, rho / pq, P, C, S)
                rho_new = block_sum(part, 1)
                beta = rho_new / rho
                rho = rho_new
                iterations += 1
            counters[2] += iterations
            counters[3] = max(counters[3], iterations)

        block_sum = stable_identity(njit(cache=True)(block_sum), f"{self.key}|block_sum")
        pass1 = stable_identity(njit(cache=True)(pass1), f"{self.key}|pass1")
        lub_solve = stable_identity(njit(cache=True)(lub_solve), f"{self.key}|lub_solve")
        return lub_solve


# ---- sub-kernels (factories: the spec's options become the closure's constants) ----------------
def _contact_kernel(spec, law, inlined=False):
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


def _start_block_kernel(spec):
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


def _pair_block_kernel(pair_places):
    def pair_block(lo, hi, step, dt, P, C, R, err, S, bs, fp):
        """Pair pass for the slots at places lo to hi - 1 of the pass order (S.pair_slot)."""
        pair_places(lo, hi, step, dt, P, S.pair_slot, S.pair_owner, C.nbr, C.state, R, err, S.out,
                    S.proll, bs, fp, S.stop, S.lub_slots)

    return pair_block


def _pair_geometry_kernels(spec):
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


def _pair_places_kernel(spec, law, brk, flu, layout, contact, geometry):
    """Pair pass for the slots at places lo to hi - 1 of the pass order (``pair_pass_order``):
    each writes its record, spring and model columns only."""
    ROLLING, AUDIT = spec.rolling_friction, layout.audit
    IMPLICIT = layout.implicit
    SPRING = law.spring_columns
    SLOT, COL_BRK, COL_T = layout.slot_width, SLOT_BASE, layout.slot_fluid
    COL_AUD = layout.slot_audit
    COL_D = COL_AUD + 3 if AUDIT else -1
    BASE = SPRING  # the breakage model's first contact-state column
    reference, apart_hook = brk.pair_reference, brk.pair_apart
    override, loaded = brk.pair_override, brk.pair_loaded
    pair_fluid = flu.pair_fluid
    separation, contact_normal, contact_velocity = geometry

    def pair_places(lo, hi, step, dt, P, slot, owner, nbr, state, R, err, out, proll, bs, fp,
                    stop, rows):
        x, v, w, radius = P.x, P.v, P.w, P.radius
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
                if AUDIT:
                    o[COL_AUD + 2] -= (proll[k, 0, 0] * w[i, 0] + proll[k, 0, 1] * w[i, 1]
                                       + proll[k, 0, 2] * w[i, 2] + proll[k, 1, 0] * w[j, 0]
                                       + proll[k, 1, 1] * w[j, 1] + proll[k, 1, 2] * w[j, 2])

    return pair_places


def _colour_block_kernel(spec, law, contact, geometry):
    """Colour sums (PhysicsSpec.force_sum): the contacts at places lo to hi - 1 of the colour
    order, each added straight into both particles' sums (Scratch.force). The places of one
    colour share no particle, so threads never add into the same sum, and each sum is taken
    colour by colour whatever the thread count. The same contact as ``_pair_row_kernel``'s for
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


def _particle_block_kernel(spec, brk, layout, gather, walls, finish):
    """Particle pass for one block: gather, walls, breakage decision, integrate (with implicit
    lubrication: keep the loads for the solve; ``_lub_finish_kernel`` integrates)."""
    WALLS, PRESSURE, IMPLICIT = spec.walls, spec.normal_force_sum, layout.implicit
    decide = brk.particle_decide

    def particle_block(blk, step, last, t_pose, dt, P, C, W, B, R, err, S, bs, fp, half_skin2):
        prime = dt == 0.0  # the start state's forces: nothing advances (see advance)
        x, x_ref = P.x, P.x_ref
        stop, rebuild, lub = S.stop, S.rebuild, S.lub_particle
        for i in range(blk * BLOCK, min(x.shape[0], (blk + 1) * BLOCK)):
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
            finish(i, step, last, t_pose, dt, P, B, R, err, F0, F1, F2, T0, T1, T2, prime)
            dx0 = x[i, 0] - x_ref[i, 0]
            dx1 = x[i, 1] - x_ref[i, 1]
            dx2 = x[i, 2] - x_ref[i, 2]
            if dx0 * dx0 + dx1 * dx1 + dx2 * dx2 > half_skin2:
                rebuild[0] = 1

    return particle_block


def _gather_kernel(spec, brk, layout):
    """Sum the slot records of particle i in a fixed order: its own slots, then those where it is
    the partner (forces, torques with their lever arms, rolling and lubrication torques)."""
    ROLLING, AUDIT, PRESSURE = spec.rolling_friction, layout.audit, spec.normal_force_sum
    FLUID = layout.fluid and not layout.implicit  # explicit lubrication torques in the record
    COL_BRK, COL_T, COL_AUD = SLOT_BASE, layout.slot_fluid, layout.slot_audit
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
                for a in range(N_AUDIT):
                    audit_part[blk, a] += o[COL_AUD + a]
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
        return F0, F1, F2, R0 - C0 + L0, R1 - C1 + L1, R2 - C2 + L2, FS, acc

    return gather


def _wall_force_kernel(spec, layout, contact):
    """One dry contact of free particle i with a wall's surface (analytic or a mesh triangle):
    overlap xi (xw of it counts), unit normal n wall -> particle, the surface's velocity u; the
    force on i, the torque about its centre and the lever arm ai."""
    ROLLING, AUDIT = spec.rolling_friction, layout.audit

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
                if AUDIT:
                    audit_part[blk, 2] += m * wn * wn
        return fn, g0, g1, g2, c0, c1, c2, ai

    return wall_force


@njit(inline="always", cache=True, fastmath=FAST)
def _wall_reaction(wp, x, i, ai, n0, n1, n2, g0, g1, g2, u0, u1, u2, wall):
    """Reaction on a wall of force g on particle i: force, torque about the wall's point p
    (lever from p to the contact point), and the power the wall gives."""
    cp0 = x[i, 0] - ai * n0 - wall[1]
    cp1 = x[i, 1] - ai * n1 - wall[2]
    cp2 = x[i, 2] - ai * n2 - wall[3]
    wp[0] -= g0
    wp[1] -= g1
    wp[2] -= g2
    wp[3] -= cp1 * g2 - cp2 * g1
    wp[4] -= cp2 * g0 - cp0 * g2
    wp[5] -= cp0 * g1 - cp1 * g0
    wp[6] -= g0 * u0 + g1 * u1 + g2 * u2


def _walls_kernel(spec, law, brk, flu, layout, wall_force, meshes):
    """Contacts (and lubrication) of free particle i with every wall; the reaction on each wall
    goes to its block's partial sums."""
    AUDIT, PRESSURE = layout.audit, spec.normal_force_sum
    IMPLICIT = layout.implicit
    SPRING = law.spring_columns
    reference, loaded, wall_fluid = brk.wall_reference, brk.wall_loaded, flu.wall_fluid
    wall_rows = flu.wall_rows
    wall_apart = brk.wall_apart
    contact_with = wall_contact_bounded if spec.bounded_walls else wall_contact
    TRANSLATING, MESHES = spec.translating_walls, spec.mesh_walls
    # a constant, so that the reset of a wall's state is a few stores, not a call to memset
    # (with the vector registers saved around it) per particle and wall
    HIST = layout.wall_columns
    NEAR_WALLS = near_walls(spec, layout)

    def walls(i, step, dt, P, W, R, err, S, blk, bs, fp, F0, F1, F2, T0, T1, T2, FS, acc):
        x, v, w = P.x, P.v, P.w
        wall_part, audit_part = S.wall_part, S.audit_part
        ri = P.radius[i]
        near = S.wall_near[i] if NEAR_WALLS else 0
        for iw in range(W.table.shape[0]):
            if NEAR_WALLS and iw < NEAR_BITS and not (near >> iw) & 1:
                continue  # out of reach until the next list rebuild: apart, nothing to add
            wall = W.table[iw]
            if wall[10] == 0.0:  # disabled
                if IMPLICIT:
                    row_absent(S.lub_rows[i, iw])
                continue
            if MESHES and int(wall[0]) == MESH:  # below, with every mesh at once
                continue
            xi, n0, n1, n2, u0, u1, u2 = contact_with(wall, x[i, 0], x[i, 1], x[i, 2], ri)
            if TRANSLATING:  # the surface's velocity: turning (above) plus translation
                u0 += wall[15]
                u1 += wall[16]
                u2 += wall[17]
            if IMPLICIT:  # the row for the solve (applied in _lub_finish_kernel)
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
                # Reaction on the wall: force through the sphere's centre plus the couple,
                # about the wall's point p, and the power given.
                wp = wall_part[blk, iw]
                wp[0] -= g0
                wp[1] -= g1
                wp[2] -= g2
                wp[3] -= cp1 * g2 - cp2 * g1 + c0
                wp[4] -= cp2 * g0 - cp0 * g2 + c1
                wp[5] -= cp0 * g1 - cp1 * g0 + c2
                wp[6] -= pw
            if xi <= 0.0:
                for c in range(HIST):
                    W.hist[i, iw, c] = 0.0
                wall_apart(bs, W.hist, i, iw, SPRING, xi)
                continue
            # Progeny created reaching into a wall: only overlap beyond the creation state counts.
            xw, touching = reference(bs, W.hist, i, iw, SPRING, xi)
            if not touching:
                continue
            if xw > R.max_overlap * ri and err[0] == 0:
                err[0], err[1], err[2], err[3] = ERR_OVERLAP, step, i, -1 - iw
            p = R.pair_params[P.material[i], int(wall[9])]
            fn, g0, g1, g2, c0, c1, c2, ai = wall_force(i, xi, xw, n0, n1, n2, u0, u1, u2, p,
                                                        W.hist[i], iw, dt, P, audit_part, blk)
            acc = loaded(bs, W.hist, i, iw, SPRING, xw, fn, g0, g1, g2, P.material[i],
                         int(wall[9]), acc)
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
            F0, F1, F2, T0, T1, T2, FS = meshes(i, step, dt, P, W, R, err, S, blk, F0, F1, F2,
                                                 T0, T1, T2, FS)
        return F0, F1, F2, T0, T1, T2, FS, acc

    return walls


def _mesh_kernel(spec, layout, wall_force):
    """Contacts of free particle i with the triangles of every mesh wall (engine.mesh): the
    candidates listed at the last rebuild, one contact per touching surface (mesh.owns),
    history slots matched by normal."""
    PRESSURE = spec.normal_force_sum
    TAG = layout.wall_columns
    HIST = TAG + TAG_COLUMNS

    def meshes(i, step, dt, P, W, R, err, S, blk, F0, F1, F2, T0, T1, T2, FS):
        M = W
        x = P.x
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
                active = wall[10] != 0.0
                c, s = wall[11], wall[12]
                y0, y1, y2 = rotate(c, -s, wall[4], wall[5], wall[6], x[i, 0] - wall[1],
                                    x[i, 1] - wall[2], x[i, 2] - wall[3])
            if not active:
                continue
            xi, m0, m1, m2, region = triangle_contact(M, t, y0, y1, y2, ri)
            if xi <= 0.0:
                continue
            if not owns(M, k0, k1, k, y0, y1, y2, ri):  # one contact per touching surface
                continue
            if xi > R.max_overlap * ri and err[0] == 0:
                err[0], err[1], err[2], err[3] = ERR_OVERLAP, step, i, -1 - iw
            # the slot of this contact: the one whose normal is near, else a free one
            slot = -1
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
                        break
            if slot < 0:
                if err[0] == 0:
                    err[0], err[1], err[2], err[3] = ERR_MESH_SLOTS, step, i, -1 - iw
                continue
            seen |= 1 << slot
            hist[slot, TAG], hist[slot, TAG + 1], hist[slot, TAG + 2] = m0, m1, m2
            hist[slot, TAG + 3] = iw + 1
            n0, n1, n2 = rotate(c, s, wall[4], wall[5], wall[6], m0, m1, m2)
            # the surface's velocity at the contact point (mid-overlap): turning plus translation
            lever = ri - 0.5 * xi
            d0 = x[i, 0] - lever * n0 - wall[1]
            d1 = x[i, 1] - lever * n1 - wall[2]
            d2 = x[i, 2] - lever * n2 - wall[3]
            om = wall[8]
            u0 = om * (wall[5] * d2 - wall[6] * d1) + wall[15]
            u1 = om * (wall[6] * d0 - wall[4] * d2) + wall[16]
            u2 = om * (wall[4] * d1 - wall[5] * d0) + wall[17]
            p = R.pair_params[P.material[i], M.tri_material[t]]
            fn, g0, g1, g2, c0, c1, c2, ai = wall_force(i, xi, xi, n0, n1, n2, u0, u1, u2, p,
                                                        hist, slot, dt, P, S.audit_part, blk)
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
                for col in range(HIST):
                    hist[q, col] = 0.0
        return F0, F1, F2, T0, T1, T2, FS

    return meshes


def _lub_finish_kernel(spec, layout, finish):
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
                    cp0, cp1, cp2 = x[i, 0] - wall[1], x[i, 1] - wall[2], x[i, 2] - wall[3]
                    wp = wall_part[blk, iw]
                    wp[0] -= g0
                    wp[1] -= g1
                    wp[2] -= g2
                    wp[3] -= cp1 * g2 - cp2 * g1 + c0
                    wp[4] -= cp2 * g0 - cp0 * g2 + c1
                    wp[5] -= cp0 * g1 - cp1 * g0 + c2
                    wp[6] -= (g0 * o[RW_VJ] + g1 * o[RW_VJ + 1] + g2 * o[RW_VJ + 2]
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


NEAR_BITS = 63  # walls with a bit in a particle's near-wall mask; walls beyond it are always visited


def near_walls(spec, layout):
    """Whether the loop visits only the walls near each particle (dry runs with walls). With a
    fluid every wall is visited: its lubrication rows are rewritten each step."""
    return spec.walls and not layout.fluid


def _near_walls_kernel(spec):
    """The walls each free particle of the block may touch before the next list rebuild, as a bit
    mask: static planes and cylinders within the skin of its list position (it moves at most
    half the skin before a rebuild, as for the pair list); every other wall (moving, bounded)
    counts as near. Visiting only those gives the same numbers: a wall out of reach is apart
    at every step, and its state was reset when the particle last left it."""
    TRANSLATING = spec.translating_walls

    def near_walls_block(blk, P, W, R, S):
        x_ref, near = P.x_ref, S.wall_near
        reach = R.skin + R.reach
        n_walls = min(W.table.shape[0], NEAR_BITS)
        for i in range(blk * BLOCK, min(x_ref.shape[0], (blk + 1) * BLOCK)):
            mask = 0
            for iw in range(n_walls):
                wall = W.table[iw]
                kind = int(wall[0])
                if wall[10] == 0.0 or kind == MESH:  # disabled; meshes have their candidates
                    continue
                static = kind <= CYLINDER_OUTER and not (
                    TRANSLATING and (wall[15] != 0.0 or wall[16] != 0.0 or wall[17] != 0.0))
                if static:
                    gap = wall_contact(wall, x_ref[i, 0], x_ref[i, 1], x_ref[i, 2],
                                       P.radius[i] + reach)[0]
                    if gap <= 0.0:
                        continue
                mask |= np.int64(1) << np.int64(iw)
            near[i] = mask

    return near_walls_block


def _finish_kernel(spec):
    """Finish the step of particle i from its force and torque (free particles), or keep the load
    a body particle received for the body reduction; then start the next step."""
    GEAR, GRAVITY, BODIES = spec.integrator == "gear", spec.gravity, spec.bodies

    def finish(i, step, last, t_pose, dt, P, B, R, err, F0, F1, F2, T0, T1, T2, prime):
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
                return
            if GEAR:
                gear_correct(i, dt, x, v, w, acc, alpha, P.gear, a0, a1, a2, b0, b1, b2)
                if not last:
                    gear_predict(i, dt, x, v, w, acc, alpha, P.gear)
            else:
                verlet_kick(i, dt, v, w, acc, alpha, a0, a1, a2, b0, b1, b2)
                if not last:
                    verlet_drift(i, dt, x, v, w, acc, alpha)
            sp2 = v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2
            if not (sp2 <= R.v_max * R.v_max) and err[0] == 0:
                err[0] = ERR_SPEED if sp2 == sp2 else ERR_NONFINITE
                err[1], err[2], err[3] = step, i, -1
            return
        # Body particles keep the load they received for the body reduction: the force, and its
        # moment about the body's centre taken here, at the pose the force was computed at (a
        # lever arm from the next pose tilted the body torque by rate x dt, a first-order error
        # in its power).
        acc[i, 0], acc[i, 1], acc[i, 2] = F0, F1, F2
        if BODIES:
            b = B.table[P.body[i]]
            r0 = x[i, 0] - b[1]
            r1 = x[i, 1] - b[2]
            r2 = x[i, 2] - b[3]
            T0 += r1 * F2 - r2 * F1
            T1 += r2 * F0 - r0 * F2
            T2 += r0 * F1 - r1 * F0
        alpha[i, 0], alpha[i, 1], alpha[i, 2] = T0, T1, T2
        if BODIES and not last and not prime:
            place_body_particle(i, B.table[P.body[i]], x, v, w, P.x_body0, t_pose)

    return finish


@njit(inline="always", cache=True)
def place_body_particle(i, body, x, v, w, x_body0, t):
    """Particle i of a kinematic body at its pose at t. A ramping rotating body also sets the
    particle's spin to its rate at t (a constant-rate body's spin was set once at build)."""
    p0, p1, p2, u0, u1, u2, rate = body_pose(body, x_body0[i], t)
    x[i, 0], x[i, 1], x[i, 2] = p0, p1, p2
    v[i, 0], v[i, 1], v[i, 2] = u0, u1, u2
    if body[8] > 0.0 and int(body[0]) == ROTATE:
        w[i, 0], w[i, 1], w[i, 2] = rate * body[4], rate * body[5], rate * body[6]


def _reduction_kernel(spec, layout):
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
                a0, a1, a2 = B.table[b, 4], B.table[b, 5], B.table[b, 6]
                rate = body_motion(B.table[b], t_load)[1]
                if int(B.table[b, 0]) == ROTATE:
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
