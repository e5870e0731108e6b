"""Struct-of-arrays state handed to the compiled loop, as numba-compatible named tuples.

The loop receives a few named bundles instead of dozens of positional arrays:

- :class:`ParticleArrays` (per particle: kinematics, size, mass, owner body, integrator history);
- :class:`ContactList` (the half Verlet list in CSR form and its per-contact state);
- :class:`WallArrays` and :class:`BodyArrays` (the prescribed boundaries and what they receive);
- :class:`RunSettings` (constants of the run) and :class:`Accumulators` (counters, guard, energy
  audit).

Models keep their own per-particle arrays (see :mod:`millsim.engine.models`). 2D scenes use the
same 3-component arrays with z = 0 (disks spin about z only), so one set of kernels serves both
dimensions; only masses, inertias and the cell grid depend on ``dim``. An array that a spec does
not use has length 0 (Gear history with Verlet, the normal-force sum without pressure maps).
"""

from collections import namedtuple

import numpy as np

from .integrators import GEAR_SLOTS

# Memory of one particle in the engine's arrays: 1.0 kB in a built stirred-mill slice (3142
# particles, 3.9 contact slots each: kinematics, contact list and state, the loop's slot records),
# less in sparser scenes; denser beds hold more contacts, so it is a lower bound there.
BYTES_PER_PARTICLE = 1000

ParticleArrays = namedtuple(
    "ParticleArrays",
    ["x", "v", "w", "acc", "alpha", "radius", "inv_mass", "inv_inertia", "material", "body",
     "x_ref", "x_body0", "gear", "fn_sum"],
)
ContactList = namedtuple("ContactList", ["start", "nbr", "state", "rev_start", "rev_slot"])
# table: one row per wall (engine.kinematics); hist: per particle and wall, the contact state;
# impulse: force and torque about the wall's point, integrated over time [N s, N m s]; work [J]
# the wall has done on the particles. A run with mesh walls has MeshWallArrays: the same and the
# fields of engine.mesh.MeshArrays (flat, not nested: numba's parallel loops take no tuple inside
# a tuple; a separate type, so that the other runs' loop is typed and compiled as before).
MESH_FIELDS = ["tri", "tri_normal", "tri_vertex", "tri_wall", "tri_material", "mesh_grid",
               "cell_start", "cell_tri", "cand_start", "cand_tri", "mesh_hist", "mesh_built"]
WallArrays = namedtuple("WallArrays", ["table", "hist", "impulse", "work"])
MeshWallArrays = namedtuple("MeshWallArrays", [*WallArrays._fields, *MESH_FIELDS])
# table: one row per body; members: its particles; load: force and torque about the body's
# centre of the last step [N, N m]; impulse, work: integrated as for walls.
BodyArrays = namedtuple("BodyArrays", ["table", "members", "load", "impulse", "work"])
RunSettings = namedtuple("RunSettings", [
    "pair_params", "gravity", "box_lo", "box_len", "skin", "reach", "dim", "max_overlap", "v_max"])
# Per-chunk scratch of the loop: the record pass's order (slot and its particle at each place,
# engine.loop.pair_pass_order; empty with colour sums), slot records and rolling torques per
# Verlet slot, per-block partial sums of wall loads and audit powers, and the stop and rebuild
# flags; with implicit lubrication (engine.implicit) the rows per slot and per particle and wall,
# each pair row's share on its partner in a CG product, the per-particle loads and velocities of
# the solve, and its per-block partial sums (length 0 otherwise); in dry runs with walls, each
# particle's near-wall bit mask (engine.loop.near_walls). ColourScratch, with force_sum "colour"
# (engine.loop.colour_slots), adds each particle's force, torque and normal-force sums, the
# list's slots in colour order (each colour's first place, the slot, its particle and partner)
# and the springs in that order.
Scratch = namedtuple("Scratch", ["pair_slot", "pair_owner", "out", "proll", "wall_part",
                                 "audit_part", "stop", "rebuild", "lub_slots", "lub_rows",
                                 "lub_partner", "lub_particle", "cg_part", "wall_near"])
# A separate type, so that the other runs' loop is typed and compiled as before (with more
# fields, LLVM inlined and fused the implicit solve otherwise: other rounding).
ColourScratch = namedtuple("ColourScratch", [*Scratch._fields, "force", "colour_start",
                                             "colour_slot", "colour_owner", "colour_partner",
                                             "colour_state"])
# counters: [list rebuilds, steps, implicit-lubrication CG iterations in all, most in one step];
# err: [guard code, step, particle, partner]; dissipation:
# energy per audit term [J] then the last step's power per term [W]; n_events: rows used in
# the events table.
Accumulators = namedtuple("Accumulators", ["counters", "err", "dissipation", "n_events"])
# With collision spectra (engine.spectra; separate types, so that other runs' loop is typed and
# compiled as before): the accumulators add the counts (table pair/wall, material a, material b,
# normal/tangential, bin incl. under- and overflow), the energy binned per (table, a, b,
# normal/tangential) [J] and the bins (log lo, bins per unit of log E); the scratch adds each
# block's share of a step's counts and energies.
SpectraAccumulators = namedtuple("SpectraAccumulators", [*Accumulators._fields, "spectra_counts",
                                                         "spectra_energy", "spectra_bins"])
SpectraScratch = namedtuple("SpectraScratch", [*Scratch._fields, "spectra_counts",
                                               "spectra_energy", "spectra_bins"])


def disk_or_sphere_mass(radius, density, dim, thickness):
    """Mass of a 3D sphere, or of a 2D disk of the given thickness [kg]."""
    radius = np.asarray(radius, dtype=float)
    if dim == 3:
        return density * 4.0 / 3.0 * np.pi * radius**3
    return density * np.pi * radius**2 * thickness


def moment_of_inertia(mass, radius, dim):
    """Solid sphere 2/5 m r^2 in 3D, solid disk 1/2 m r^2 about its axis in 2D [kg m^2]."""
    return (0.4 if dim == 3 else 0.5) * mass * np.asarray(radius) ** 2


def allocate(x, v, w, radius, inv_mass, inv_inertia, material, body, x_body0, gear, force_sum):
    """Assemble ParticleArrays with C-contiguous, correctly typed arrays and fresh scratch arrays."""
    n = len(radius)

    def as3(a):
        return np.ascontiguousarray(np.asarray(a, dtype=np.float64).reshape(n, 3))

    x = as3(x)
    return ParticleArrays(
        x=x, v=as3(v), w=as3(w), acc=np.zeros((n, 3)), alpha=np.zeros((n, 3)),
        radius=np.ascontiguousarray(radius, dtype=np.float64),
        inv_mass=np.ascontiguousarray(inv_mass, dtype=np.float64),
        inv_inertia=np.ascontiguousarray(inv_inertia, dtype=np.float64),
        material=np.ascontiguousarray(material, dtype=np.int32),
        body=np.ascontiguousarray(body, dtype=np.int32),
        x_ref=x.copy(), x_body0=as3(x_body0),
        gear=np.zeros((n if gear else 0, GEAR_SLOTS, 3)),
        fn_sum=np.zeros(n if force_sum else 0),
    )


def select_rows(arrays, keep, n):
    """The same named tuple with the rows where ``keep`` is true of every per-particle array
    (length ``n``); arrays of another length (unused ones) are kept as they are."""
    return type(arrays)(*(a[keep].copy() if a.shape[0] == n else a for a in arrays))


def append_rows(a, b, n):
    """Append the rows of ``b`` to the per-particle arrays of ``a`` (length ``n``)."""
    return type(a)(*(np.ascontiguousarray(np.concatenate([u, w])) if u.shape[0] == n else u
                     for u, w in zip(a, b)))


def empty_contacts(n: int, state_columns: int) -> ContactList:
    """A contact list with no pairs (forces a rebuild before the first step)."""
    return ContactList(
        start=np.zeros(n + 1, dtype=np.int64), nbr=np.zeros(0, dtype=np.int32),
        state=np.zeros((0, state_columns)), rev_start=np.zeros(n + 1, dtype=np.int64),
        rev_slot=np.zeros(0, dtype=np.int64),
    )
