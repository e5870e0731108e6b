"""The particle half of a Simulation: making particles from their declaration, adding and removing
them between chunks with everything kept per particle (wall and mesh contact state, tags, ids, the
models' fields), and the models' per-particle arrays. Functions of the Simulation; its methods
call them."""

from collections import namedtuple

import numpy as np

from .kinematics import B_AXIS, B_KIND, B_RAMP, B_RATE, BODY_KINDS
from .mesh import MESH_SLOTS, TAG_COLUMNS
from .state import (
    ContactList,
    allocate,
    append_rows,
    disk_or_sphere_mass,
    moment_of_inertia,
    select_rows,
)


def vec3(a, n):
    # a copy: the caller's array is never the one a run advances or a body's spin is written to
    a = np.zeros((n, 3)) if a is None else np.array(a, dtype=float)
    if a.ndim == 2 and a.shape[1] == 2:
        a = np.column_stack([a, np.zeros(len(a))])
    return a.reshape(n, 3)


def model_fields(model, n):
    """Fresh per-particle arrays of a model (namedtuple), filled with the declared defaults."""
    arrays = []
    for name in model.particle_fields:
        dtype, fill = model.particle_fields[name]
        shape = (n,) if not isinstance(dtype, tuple) else (n, dtype[1])
        arrays.append(np.full(shape, fill, dtype=dtype[0] if isinstance(dtype, tuple) else dtype))
    return fields_tuple(model, arrays)


def fields_tuple(model, arrays):
    """A model's per-particle arrays as the namedtuple its hooks receive (named by its fields)."""
    return namedtuple(f"{type(model).__name__}Fields", list(model.particle_fields))(*arrays)


def tag_array(name, values, n):
    values = np.asarray(values)
    if values.shape[:1] != (n,):
        raise ValueError(f"tags[{name}]: {values.shape[0] if values.ndim else 0} values for "
                         f"{n} particles")
    return values.copy()


def make_particles(sim, x, radius, material, v, w, body):
    n = len(radius)
    if (radius <= 0).any() or not np.isfinite(radius).all():
        raise ValueError(f"radius: must be > 0, got min {radius.min():g}")
    names = material if np.ndim(material) else [material] * n
    mat = np.array([sim.material_index(m) for m in np.atleast_1d(names)], dtype=np.int32)
    if len(mat) != n:
        raise ValueError(f"material: {len(mat)} names for {n} particles")
    density = np.array([sim.table.materials[m].density for m in mat])
    mass = disk_or_sphere_mass(radius, density, sim.spec.dim, sim.thickness)
    inertia = moment_of_inertia(mass, radius, sim.spec.dim)
    body = np.full(n, -1, dtype=np.int32) if body is None else np.asarray(body, dtype=np.int32)
    if body.max(initial=-1) >= len(sim.bodies):
        raise ValueError(f"body: index {body.max()} but only {len(sim.bodies)} bodies defined")
    kin = body >= 0
    x = vec3(x, n)
    w = vec3(w, n)
    # Particles of a kinematic body move rigidly with it, spin included: a rotating body's
    # particles spin at its rate (their surfaces then move with the body at every contact,
    # which is also what the body's power, torque x rate, assumes); a translating one's not.
    for b in np.unique(body[body >= 0]):
        rotating = sim.bodies[b, B_KIND] == BODY_KINDS["rotate"]
        at_rest = sim.bodies[b, B_RAMP] > 0.0  # a ramping body starts from rest
        w[body == b] = (0.0 if at_rest else sim.bodies[b, B_RATE]) * sim.bodies[b, B_AXIS] \
            if rotating else 0.0
    if sim.spec.dim == 2:
        w[:, :2] = 0.0  # disks spin about z only
    # Kinematic particles: infinite mass and inertia (they never respond to forces).
    inv_mass = np.where(kin, 0.0, 1.0 / mass)
    inv_inertia = np.where(kin, 0.0, 1.0 / inertia)
    p = allocate(x, vec3(v, n), w, radius, inv_mass, inv_inertia, mat, body, x.copy(),
                 sim.spec.integrator == "gear", sim.spec.normal_force_sum)
    p.acc[~kin] = sim.gravity if sim.spec.gravity else 0.0
    return p


def remove_particles(sim, mask):
    """Simulation.remove_particles."""
    keep = ~np.asarray(mask, dtype=bool)
    n = sim.n_particles
    new_index = np.cumsum(keep) - 1
    old = sim.contacts
    pairs_i = np.repeat(np.arange(len(keep)), np.diff(old.start))
    sel = keep[pairs_i] & keep[old.nbr]
    ni, nj = new_index[pairs_i[sel]], new_index[old.nbr[sel]]
    start = np.zeros(int(keep.sum()) + 1, dtype=np.int64)
    np.add.at(start, ni + 1, 1)
    relabelled = ContactList(np.cumsum(start), nj.astype(np.int32), old.state[sel],
                             old.rev_start, old.rev_slot)
    sim.particles = select_rows(sim.particles, keep, n)
    sim._W = sim._W._replace(hist=sim._W.hist[keep])
    if sim._mesh_geometry:
        sim._W = sim._W._replace(mesh_hist=sim._W.mesh_hist[keep])
    sim.tags = {name: values[keep] for name, values in sim.tags.items()}
    sim.particle_ids, sim.parent_ids = sim.particle_ids[keep], sim.parent_ids[keep]
    for model in sim._fields:
        sim._fields[model] = select_rows(sim._fields[model], keep, n)
        sim._publish(model)
    sim._after_change(relabelled)


def add_particles(sim, x, radius, material, v=None, w=None, tags=None, parent_ids=None):
    """Simulation.add_particles."""
    radius = np.asarray(radius, dtype=float)
    m = len(radius)
    n_old = sim.n_particles
    tags = dict(tags or {})
    if set(tags) != set(sim.tags):
        raise ValueError(f"tags: give values for {sorted(sim.tags)}, got {sorted(tags)}")
    parents = np.asarray(np.full(m, -1) if parent_ids is None else parent_ids, np.int64)
    if parents.shape != (m,) or (parents < -1).any() or (parents >= sim._next_id).any():
        raise ValueError(f"parent_ids: {m} ids of existing or earlier particles (or -1), got "
                         f"{parents!r}")
    new = make_particles(sim, x, radius, material, v, w, None)
    sim.particles = append_rows(sim.particles, new, n_old)
    sim._W = sim._W._replace(hist=np.concatenate(
        [sim._W.hist, np.zeros((m, len(sim.walls), sim.layout.wall_columns))]))
    if sim._mesh_geometry:
        sim._W = sim._W._replace(mesh_hist=np.concatenate([sim._W.mesh_hist, np.zeros(
            (m, MESH_SLOTS, sim.layout.wall_columns + TAG_COLUMNS))]))
    for name in sim.tags:
        sim.tags[name] = np.concatenate([sim.tags[name], tag_array(name, tags[name], m)])
    sim.particle_ids = np.concatenate([sim.particle_ids,
                                       np.arange(sim._next_id, sim._next_id + m)])
    sim.parent_ids = np.concatenate([sim.parent_ids, parents])
    sim._next_id += m
    for model in sim._fields:
        sim._fields[model] = append_rows(sim._fields[model], model_fields(model, m), n_old)
        sim._publish(model)
    old = sim.contacts
    start = np.concatenate([old.start, np.full(m, old.start[-1])])
    sim._after_change(ContactList(start, old.nbr, old.state, old.rev_start, old.rev_slot))
    return np.arange(n_old, n_old + m)
