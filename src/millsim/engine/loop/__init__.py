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

The package, by pass: :mod:`.layout` (the slot record's columns, guard codes, ``Layout``),
:mod:`.runner` (``ChunkRunner``, the assembly of one variant and its ``advance``), :mod:`.pairs`
(pair geometry, the pair and colour passes, colouring), :mod:`.particles` (gather, integrator step,
body particles), :mod:`.wall_pass` (wall and mesh contacts, near walls), :mod:`.reductions`; the
implicit lubrication solve is :mod:`millsim.engine.implicit_solve`.
"""

from .layout import (
    AUDIT_TERMS,
    BLOCK,
    ERR_MESH_SLOTS,
    ERR_NONFINITE,
    ERR_OVERLAP,
    ERR_SPEED,
    N_AUDIT,
    SLOT_BASE,
    Layout,
)
from .pairs import colour_slots, pair_pass_order, touching_slots
from .particles import place_body_particle
from .runner import ChunkRunner, build_chunk_runner, chunk_parts
from .wall_pass import NEAR_BITS, near_walls

__all__ = ["AUDIT_TERMS", "BLOCK", "ERR_MESH_SLOTS", "ERR_NONFINITE", "ERR_OVERLAP", "ERR_SPEED",
           "N_AUDIT", "NEAR_BITS", "SLOT_BASE", "ChunkRunner", "Layout", "build_chunk_runner",
           "chunk_parts", "colour_slots", "near_walls", "pair_pass_order", "place_body_particle",
           "touching_slots"]
