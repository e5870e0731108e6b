"""The chunk runner and the assembly of one physics variant's step loop (see
:mod:`millsim.engine.loop`): ``_Parts`` compiles the passes' kernels and composes them into the
parallel functions ``advance`` and ``start_forces``; ``ChunkRunner`` calls them between list
rebuilds."""

import numpy as np
from numba import njit, prange

from ..implicit import LP_WIDTH, LPP_WIDTH, RW_WALL_WIDTH, RW_WIDTH, lub_kernels
from ..implicit_solve import lub_solver
from ..jit_options import FAST, PRANGE_ONLY
from ..kinematics import place_meshes, place_walls, ramp_walls
from ..mesh import mesh_travel, with_mesh_candidates
from ..models import NO_BREAKAGE, NO_FLUID, stable_identity
from ..neighbours import rebuilt_contacts
from ..state import ColourScratch, Scratch, SpectraScratch
from .layout import BLOCK, N_AUDIT, SLOT_BASE, Layout
from .mesh_fluid import mesh_fluid_kernel
from .pairs import (
    colour_block_kernel,
    colour_slots,
    contact_kernel,
    pair_block_kernel,
    pair_geometry_kernels,
    pair_pass_order,
    pair_places_kernel,
    touching_slots,
)
from .particles import (
    finish_kernel,
    gather_kernel,
    lub_finish_kernel,
    moved_beyond,
    particle_block_kernel,
    start_block_kernel,
)
from .reductions import reduction_kernel
from .spectra import spectra_reduce
from .wall_pass import mesh_kernel, near_walls, near_walls_kernel, wall_force_kernel, walls_kernel


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
        self.colour, self.spectra = colour, layout.spectra

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
            audit_part=np.zeros((n_blocks if self.audit else 0,
                                 N_AUDIT + 1 if self.spectra else N_AUDIT)),
            stop=np.zeros(1, dtype=np.int64), rebuild=np.zeros(1, dtype=np.int64),
            lub_rows=np.zeros((n if implicit else 0, n_walls, RW_WALL_WIDTH)),
            lub_particle=np.zeros((n if implicit else 0, LP_WIDTH)),
            cg_part=np.zeros((n_blocks if implicit else 0, 3)),
            wall_near=np.zeros(n if self.near_walls else 0, dtype=np.int64))
        if self.colour:
            shared["force"] = np.zeros((n, 7))
        if self.spectra:  # collision spectra (loop.spectra): each block's share of a step
            shared["audit_part"][:, N_AUDIT] = np.isnan(A.dissipation[N_AUDIT])
            shared.update(spectra_counts=np.zeros((n_blocks, *A.spectra_counts.shape), np.int64),
                          spectra_energy=np.zeros((n_blocks, A.spectra_energy.shape[0])),
                          spectra_bins=A.spectra_bins)
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
                W = with_mesh_candidates(W, P, R.skin + R.reach, t + (k0 + step) * dt)
            S.rebuild[0] = 0
            S = self._scratch(C, shared, P, R)
            A.counters[0] += 1
            step = self.advance(n_steps, step, False, t, k0, dt, step0, P, C, W, B, R, A, S, bs,
                                fp)
            self._springs_back(C, S)
        A.counters[1] += step
        if self.spectra:  # the counts are integers: summed once a chunk, in any order
            A.spectra_counts[:] += shared["spectra_counts"].sum(axis=0)
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
        scratch = SpectraScratch if self.spectra else Scratch
        return scratch(pair_slot=slot, pair_owner=owner,
                       out=np.empty((slots, self.slot_width)),
                       proll=np.empty((slots if self.rolling else 0, 2, 3)),
                       lub_slots=np.zeros((slots if implicit else 0, RW_WIDTH)),
                       lub_partner=np.empty((slots if implicit else 0, LPP_WIDTH)), **shared)

    def _springs_back(self, C, S):
        """Colour sums: the springs back to the list's slot order (list rebuilds, checkpoints and
        contact queries read them there)."""
        if self.colour:
            C.state[S.colour_slot] = S.colour_state



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
    layout = Layout.of(spec, law, breakage, fluid)
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
        contact = self._inline(contact_kernel(spec, law))
        wall_force = self._inline(wall_force_kernel(spec, layout, contact))
        meshes = self._inline(mesh_kernel(spec, brk, layout, wall_force)) if spec.mesh_walls else None
        mesh_fluid = (self._inline(mesh_fluid_kernel(layout, flu))
                      if spec.mesh_walls and layout.fluid else None)
        finish = self._inline(finish_kernel(spec))
        geometry = tuple(self._inline(fn) for fn in pair_geometry_kernels(spec))
        if spec.force_sum == "colour":
            self.pair_block = None
            self.colour_block = self._jit(colour_block_kernel(
                spec, law, self._inline(contact_kernel(spec, law, inlined=True)), geometry))
        else:
            self.pair_block = self._jit(pair_block_kernel(
                self._inline(pair_places_kernel(spec, law, brk, flu, layout, contact, geometry))))
            self.colour_block = None
        self.particle_block = self._jit(particle_block_kernel(
            spec, brk, layout,
            gather=self._inline(gather_kernel(spec, brk, layout)),
            walls=self._inline(walls_kernel(spec, law, brk, flu, layout, wall_force, meshes,
                                             mesh_fluid)),
            finish=finish))
        self.start_block = self._jit(start_block_kernel(spec))
        self.reductions = self._jit(reduction_kernel(spec, layout))
        self.near_walls_block = (self._jit(near_walls_kernel(spec)) if near_walls(spec, layout)
                                 else None)
        if layout.implicit:  # the implicit lubrication solve (engine.implicit); else not compiled
            self.lub_blocks = tuple(self._jit(fn) for fn in lub_kernels(spec, layout, BLOCK))
            self.lub_finish_block = self._jit(lub_finish_kernel(spec, layout, finish))
            self.lub_solve = lub_solver(self.lub_blocks, self._parallel, self.key)
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
        TRANSLATING, MESHES, RAMPED = spec.translating_walls, spec.mesh_walls, spec.ramped_walls
        AUDIT, IMPLICIT, SPECTRA = layout.audit, layout.implicit, layout.spectra
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
            if RAMPED:
                ramp_walls(W.table, t_start)
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
            if SPECTRA:  # contacts found apart at the start end their collisions
                spectra_reduce(S.spectra_energy, A.spectra_energy, audit_part, n_blocks)
            for blk in range(wall_part.shape[0]):
                for k in range(wall_part.shape[1]):
                    for c in range(wall_part.shape[2]):
                        wall_part[blk, k, c] = 0.0

        return self._parallel(start_forces)

    def _advance(self, spec, layout):
        TRANSLATING, MESHES, RAMPED = spec.translating_walls, spec.mesh_walls, spec.ramped_walls
        IMPLICIT, SPECTRA = layout.implicit, layout.spectra
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
                if moved_beyond(P.x, P.x_ref, half_skin2) or (
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
                if RAMPED:
                    ramp_walls(W.table, t_end)
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
                if SPECTRA:  # collision spectra: the blocks' energies, in block order
                    spectra_reduce(S.spectra_energy, A.spectra_energy, audit_part, n_blocks)
                step += 1
                if err[0] != 0 or stop[0] != 0 or (rebuild[0] != 0 and not last):
                    break
            return step

        return self._parallel(advance)
