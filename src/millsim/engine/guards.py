"""The guards of a Simulation between chunks: a start already in excessive overlap, impacts too
fast for the time step, and the one-line description of what stopped a chunk. Functions of the
Simulation; its methods call them."""

import numpy as np

from .loop import ERR_MESH_SLOTS, ERR_NONFINITE, ERR_OVERLAP, ERR_SPEED
from .mesh import MESH_SLOTS, mesh_overlaps
from .timestep import STEPS_PER_CONTACT_LIMIT
from .walls import surface_speed, worst_wall_overlap

# At half the step limit or less (20+ steps per Hertz contact) velocity Verlet's peak overlap is
# within about a percent of the exact one, so an overlap beyond the guard there is the contact's
# softness at that speed, not the step: the message says so instead of asking for a smaller dt.
OVERLAP_FROM_STIFFNESS_BELOW = 0.5


class SimulationError(RuntimeError):
    """The run became unphysical (NaN, runaway speed, excessive overlap); names step and particle."""


def check_initial_overlaps(sim):
    """Refuse a start whose overlaps already exceed the guard: the first steps would turn them
    into a numerical explosion, so say which pair and how to get a usable state."""
    p = sim.particles
    i, j, overlap = sim.contact_pairs()
    worst, what = 0.0, ""
    if len(i):
        ratio = overlap / np.minimum(p.radius[i], p.radius[j])
        k = int(np.argmax(ratio))
        worst, what = float(ratio[k]), f"particles {i[k]} and {j[k]}"
    if sim._mesh_geometry:
        xi = mesh_overlaps(sim._W, sim.walls, p.x, p.radius, p.body, sim.time)
        q = int(np.argmax(xi / p.radius))
        if xi[q] / p.radius[q] > worst:
            worst, what = float(xi[q] / p.radius[q]), f"particle {q} and a mesh wall"
    worst, what = worst_wall_overlap(sim, worst, what)
    if worst > sim.guards.max_overlap:
        raise ValueError(
            f"initial state: {what} overlap by {worst:.3g} of the smaller radius, above "
            f"max_overlap = {sim.guards.max_overlap:g}; relax the state first (e.g. the "
            f"packing scene, or a short run with softer contacts) or place the particles apart")


def check_contact_resolution(sim):
    """Hertz contacts shorten with speed: stop, naming the speed, once a particle moves so
    fast that its impacts would be resolved by fewer steps than the refusal limit."""
    if sim.dt_report.hertz_contact_time is None:
        return
    p = sim.particles
    speed = float(np.sqrt((p.v[sim.free] ** 2).sum(1)).max(initial=0.0))
    if len(sim.walls):
        speed += surface_speed(sim, sim.free)
    if len(sim.bodies):
        speed += float(np.sqrt((p.v[~sim.free] ** 2).sum(1)).max(initial=0.0))
    steps = sim.dt_report.steps_per_contact(sim.dt, speed)
    if steps < STEPS_PER_CONTACT_LIMIT:
        raise SimulationError(
            f"step {sim.step} (t = {sim.time:.6g} s): impacts at {speed:.4g} m/s, above "
            f"impact_speed = {sim.dt_report.impact_speed:g} m/s the time step was chosen for, "
            f"would be resolved by {steps:.1f} steps (limit {STEPS_PER_CONTACT_LIMIT}); "
            f"declare impact_speed >= {speed:.4g} m/s (dt follows) or reduce dt")


def describe_error(sim, err):
    """One line naming the step, the particle(s) and the limit that was crossed.

    The kernel stops at the end of the step where a guard fired; the culprit is re-derived
    here so that the message does not depend on which thread saw it first.
    """
    code, step, i, j = (int(e) for e in err)
    where = f"step {sim.step - 1} (t = {sim.time:.6g} s)"
    p = sim.particles
    if code == ERR_OVERLAP:
        pi, pj, overlap, slot = sim.contact_pairs(with_slots=True)
        if sim.breakage:  # fragments count only beyond their reference overlap
            base = sim.layout.spring
            overlap = overlap - sim.breakage.reference_overlap(sim.contacts.state[slot, base:])
        if len(pi):
            k = int(np.argmax(overlap / np.minimum(p.radius[pi], p.radius[pj])))
            i, j = int(pi[k]), int(pj[k])
        partner = f"wall {-1 - j}" if j < 0 else f"particle {j}"
        fraction = sim.dt / sim.dt_report.limit
        if fraction <= OVERLAP_FROM_STIFFNESS_BELOW:
            # the step resolves the contact: the overlap is what this spring allows at
            # this speed, and a smaller dt would not change it
            cure = (f"dt is {fraction:.2g} of its limit, so not the cause: the contact is too "
                    "soft for this speed (stiffen it, or bring the bodies together more "
                    "slowly, e.g. a speed ramp), or the state was set in overlap")
        else:
            cure = (f"reduce dt (now {sim.dt:.4g} s, limit {sim.dt_report.limit:.4g} s) "
                    "or check the initial state")
        return (f"{where}: overlap between particle {i} and {partner} exceeds "
                f"{sim.guards.max_overlap:g} of the smaller radius; {cure}")
    bad = ~np.isfinite(p.v).all(1) | ~np.isfinite(p.x).all(1)
    if code == ERR_NONFINITE or bad.any():
        first = int(np.flatnonzero(bad)[0]) if bad.any() else i
        return (f"{where}: particle {first} has a non-finite velocity (NaN/inf); "
                f"{int(bad.sum())} particle(s) affected")
    if code == ERR_MESH_SLOTS:
        return (f"{where}: particle {i} touches more mesh triangles at once than its "
                f"{MESH_SLOTS} contact slots (a mesh with slivers or a crevice narrower than "
                "a particle); check the mesh")
    if code == ERR_SPEED:
        speed = np.linalg.norm(p.v, axis=1)
        i = int(np.argmax(np.where(sim.free, speed, 0.0)))
        return (f"{where}: runaway kinetic energy, particle {i} moves at {speed[i]:.4g} m/s, "
                f"above v_max = {sim.guards.v_max:.4g} m/s")
    return f"{where}: guard code {code} on particle {i}"
