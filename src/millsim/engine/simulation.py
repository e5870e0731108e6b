"""The Simulation object: owns the state, chooses the time step, runs compiled chunks, guards.

Python touches the state only between chunks: to record outputs, check the guards, and add or
remove particles. Everything inside a chunk runs in the compiled loop of :mod:`millsim.engine.loop`.
Models (contact law via the material table, breakage, fluid) are objects handed in; the
Simulation allocates their per-particle arrays, keeps them in step with added and removed
particles, and hands their hooks to the loop.
"""

import math
import signal
import threading
import time
from collections import namedtuple
from contextlib import contextmanager
from dataclasses import dataclass

import numba
import numpy as np

from ..util.validation import check_range
from .kinematics import (
    B_AXIS,
    B_KIND,
    B_RAMP,
    B_RATE,
    BODY_COLUMNS,
    BODY_KINDS,
    MESH,
    PLANE,
    W_ACTIVE,
    W_ANGLE_REF,
    W_AXIS,
    W_KIND,
    W_MATERIAL,
    W_OMEGA,
    W_ORIGIN,
    W_POINT,
    W_RADIUS,
    W_SEGMENT,
    W_TIME_REF,
    W_VELOCITY,
    WALL_COLUMNS,
    WALL_KINDS,
    mesh_angle,
    wall_contact_bounded,
)
from .loop import (
    AUDIT_TERMS,
    ERR_MESH_SLOTS,
    ERR_NONFINITE,
    ERR_OVERLAP,
    ERR_SPEED,
    N_AUDIT,
    Layout,
)
from .mesh import (
    MESH_SLOTS,
    TAG_COLUMNS,
    build_meshes,
    mesh_geometry,
    mesh_overlaps,
    points_in_frame,
    signed_clearance,
    with_mesh_candidates,
)
from .neighbours import rebuilt_contacts
from .spec import PhysicsSpec, chunk_runner
from .state import (
    Accumulators,
    BodyArrays,
    ContactList,
    MeshWallArrays,
    RunSettings,
    WallArrays,
    allocate,
    append_rows,
    disk_or_sphere_mass,
    empty_contacts,
    moment_of_inertia,
    select_rows,
)
from .timestep import STEPS_PER_CONTACT_LIMIT, time_step_report

# Below this many particles one thread is faster than opening parallel regions every step
# (docs/engine.md, "Determinism and threads"); results are identical either way.
SERIAL_BELOW = 2000

# At half the step limit or less (20+ steps per Hertz contact) velocity Verlet's peak overlap is
# within about a percent of the exact one, so an overlap beyond the guard there is the contact's
# softness at that speed, not the step: the message says so instead of asking for a smaller dt.
OVERLAP_FROM_STIFFNESS_BELOW = 0.5


class SimulationError(RuntimeError):
    """The run became unphysical (NaN, runaway speed, excessive overlap); names step and particle."""


@dataclass(frozen=True)
class StepPolicy:
    """How the time step is chosen (engine.timestep): ``dt_factor`` x the recommended step of
    the particles present, followed as they change, unless an absolute ``dt`` [s] is given.
    ``impact_speed`` [m/s]: the largest expected impact speed (Hertz contact-time bound);
    ``smallest_radius`` [m]: the smallest free particle that can ever exist (fragments down to a
    sieve size), whose bounds then hold from the start."""

    dt: float = None
    dt_factor: float = 1.0
    impact_speed: float = 1.0
    smallest_radius: float = None

    def __post_init__(self):
        if self.dt is not None:
            check_range("dt", self.dt, 0.0, lo_open=True)
        check_range("dt_factor", self.dt_factor, 0.0, lo_open=True)
        check_range("impact_speed", self.impact_speed, 0.0, lo_open=True)
        if self.smallest_radius is not None:
            check_range("smallest_radius", self.smallest_radius, 0.0, lo_open=True)


@dataclass(frozen=True)
class Guards:
    """The run stops with a named error when an overlap exceeds ``max_overlap`` of the smaller
    radius, or a particle moves faster than ``v_max`` [m/s] (default max(100, 10 x the impact
    speed)); NaN always stops it."""

    max_overlap: float = 0.3
    v_max: float = None


def _unit(v, key):
    v = np.asarray(v, dtype=float).reshape(3)
    norm = np.linalg.norm(v)
    if norm == 0:
        raise ValueError(f"{key}: must be a non-zero vector")
    return v / norm


def _vec3(a, n):
    a = np.zeros((n, 3)) if a is None else np.asarray(a, dtype=float)
    if a.ndim == 2 and a.shape[1] == 2:
        a = np.column_stack([a, np.zeros(len(a))])
    return a.reshape(n, 3)


def _model_fields(model, n):
    """Fresh per-particle arrays of a model (namedtuple), filled with the declared defaults."""
    arrays = []
    for name in model.particle_fields:
        dtype, fill = model.particle_fields[name]
        shape = (n,) if not isinstance(dtype, tuple) else (n, dtype[1])
        arrays.append(np.full(shape, fill, dtype=dtype[0] if isinstance(dtype, tuple) else dtype))
    return _fields_tuple(model, arrays)


def _fields_tuple(model, arrays):
    """A model's per-particle arrays as the namedtuple its hooks receive (named by its fields)."""
    return namedtuple(f"{type(model).__name__}Fields", list(model.particle_fields))(*arrays)


@contextmanager
def _signals_after_chunk():
    """Hold SIGINT and SIGTERM back while a compiled chunk runs.

    A Python signal handler runs at the first bytecode after the signal, which after a chunk is
    inside numba's conversion of its results to Python objects: the KeyboardInterrupt of Ctrl-C
    raised there crashed the interpreter (SIGSEGV). During the chunk a signal is only recorded;
    once the chunk has returned it is raised again for the handler that was there (~25 us a
    chunk).
    """
    if threading.current_thread() is not threading.main_thread():
        yield  # handlers run in the main thread only
        return
    caught = []
    previous = {}
    for signum in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(signum) is not None:  # None: a handler not set from Python
            previous[signum] = signal.signal(signum, lambda received, _: caught.append(received))
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        for signum in caught:
            signal.raise_signal(signum)


class Simulation:
    """One DEM system: particles, walls, kinematic bodies, a material table, models and a spec.

    Args:
        spec: the engine options compiled into the step loop.
        table: :class:`~millsim.models.materials.MaterialTable`; it names the contact law.
        x, radius, material: initial positions [m] (N x dim), radii [m], material names.
        v, w: initial velocities [m/s] and angular velocities [rad/s] (default 0).
        body: kinematic body index per particle (-1 = free; default all free).
        walls: list of dicts ``{kind, point, normal|axis, radius, omega, material}`` (``omega``:
            rad/s about the axis, or for a plane about its normal through ``point``; an
            ``annulus`` takes ``radius`` and ``inner_radius`` (0: a disk), a ``frustum``
            (truncated cone, bounded cylinder shell) ``start`` and ``end``: [height along the
            axis from ``point``, radius] [m]; any kind may take ``velocity``: a constant
            translation [m/s] from ``point`` at t = 0, with PhysicsSpec.translating_walls).
        bodies: list of dicts ``{kind: rotate|translate, center, axis, rate, ramp}`` (``ramp``:
            seconds from rest to ``rate`` at constant acceleration; 0 or absent: at ``rate`` from
            the start).
        gravity: acceleration vector [m/s2].
        box: periodic box (origin, lengths per axis) [m]; a length 0 is not periodic.
        skin: Verlet skin [m] (default 0.1 of the mean diameter).
        thickness: disk thickness [m] for 2D masses.
        step: :class:`StepPolicy`; guards: :class:`Guards`.
        breakage, fluid: model objects (e.g. ``WeibullModel``, ``TavaresModel``, ``Lubrication``)
            or None; their hooks are compiled into the loop only when given.
        tags: {name: per-particle array} of the caller's, kept in step with added and removed
            particles (``sim.tags[name]``).
    """

    def __init__(self, spec: PhysicsSpec, table, x, radius, material, *, v=None, w=None,
                 body=None, walls=(), bodies=(), gravity=(0.0, 0.0, -9.81), box=None, skin=None,
                 thickness=1.0, step=StepPolicy(), guards=Guards(), breakage=None, fluid=None,
                 tags=None):
        self.spec, self.table, self.law = spec, table, table.law
        if spec.rolling_friction and self.law.rolling_column < 0:
            raise ValueError(f"rolling_friction: contact_law {table.contact_law!r} has no rolling "
                             "friction coefficient (ContactLaw.rolling_column)")
        for model, kind in ((breakage, "breakage"), (fluid, "fluid")):
            if model is not None and getattr(model, "kind", None) != kind:
                raise ValueError(f"{kind}: expected a {kind} model, got {model!r}")
            if model is not None and spec.force_sum == "colour":
                raise ValueError(f"force_sum: 'colour' keeps no slot records, which the {kind} "
                                 "model reads; use 'records'")
        self.thickness = float(thickness)
        self.pair_params = table.pair_params(spec.convention)
        radius = np.asarray(radius, dtype=float)
        n = len(radius)
        if n == 0:
            raise ValueError("radius: at least one particle is required")
        self._mesh_geometry = []  # (wall row, vertices in the frame, faces, material)
        self.walls = self._wall_table(walls)
        self.bodies = self._body_table(bodies)
        self.gravity = np.asarray(gravity, dtype=float).reshape(3)
        lo, length = (np.zeros(3), np.zeros(3)) if box is None else box
        self.box_lo = np.asarray(lo, dtype=float).reshape(3)
        self.box_len = np.asarray(length, dtype=float).reshape(3)
        if (self.box_len > 0).any() != spec.periodic:
            raise ValueError("box: periodic lengths given iff spec.periodic is true")
        self.policy = step
        self.guards = Guards(guards.max_overlap, float(guards.v_max) if guards.v_max is not None
                             else max(100.0, 10.0 * step.impact_speed))
        self.particles = self._make_particles(x, radius, material, v, w, body)
        self.breakage, self.fluid = breakage, None
        if fluid is not None and fluid.scheme == "auto":  # the scheme the dry step calls for
            fluid = fluid.resolve(self._time_step_report().recommended,
                                  self._smallest_for_fluid(*self._step_particles()))
        if fluid is not None and fluid.implicit and spec.integrator != "verlet":
            # the implicit solve is a leapfrog kick (engine.implicit); Gear has none
            raise ValueError(f"fluid: the implicit lubrication scheme needs integrator 'verlet', "
                             f"got {spec.integrator!r}")
        self.fluid = fluid
        if fluid is not None and spec.translating_walls:
            raise ValueError("translating_walls: not with a fluid (the wall lubrication knows "
                             "only a wall's turning)")
        if self._mesh_geometry and (fluid is not None or breakage is not None):
            raise ValueError("walls: mesh walls are dry and without breakage for now (no "
                             "lubrication or progeny reference state at a triangle)")
        self.layout = Layout(self.law.spring_columns,
                             len(breakage.contact_columns) if breakage else 0,
                             len(breakage.wall_columns) if breakage else 0,
                             len(breakage.slot_columns) if breakage else 0,
                             fluid is not None, spec.energy_audit,
                             fluid is not None and fluid.implicit)
        # lubrication reaches h_max beyond contact: the neighbour list must hold those pairs
        self.reach = fluid.reach(float(np.max(radius))) if fluid else 0.0
        self.tags = {}
        for name, values in (tags or {}).items():
            self.tags[name] = self._tag_array(name, values, n)
        # Who is who, to follow fragments across snapshots: an id per particle, never reused, and
        # the id of the particle it broke from (-1: none). Python-side, like the tags: the compiled
        # loop never sees them, so they cost nothing in a step, with or without breakage.
        self.particle_ids = np.arange(n, dtype=np.int64)
        self.parent_ids = np.full(n, -1, dtype=np.int64)
        self._next_id = n
        self._fields = {m: _model_fields(m, n) for m in (breakage, fluid) if m is not None}
        self.skin = 0.1 * 2.0 * float(np.mean(radius)) if skin is None else float(skin)
        # The time of a step is taken from the last change of dt (``_time_origin`` at
        # ``_step_origin``), never summed chunk by chunk: where a run is cut into chunks (output
        # cadence, breakage, a resume) then changes no bit of the trajectory.
        self.time = 0.0
        self.step = 0
        self._time_origin, self._step_origin = 0.0, 0
        # dissipated energy [J] per audit term, then the last step's power [W] per term (the loop
        # integrates trapezoidally; 0 at the start, NaN = unknown after a change of the particles)
        self.accumulators = Accumulators(np.zeros(4, dtype=np.int64), np.zeros(4, dtype=np.int64),
                                         np.zeros(2 * N_AUDIT), np.zeros(1, dtype=np.int64))
        # breakage decisions, a row each (the model names the columns); grows inside the loop
        self.events = np.zeros((64, breakage.event_columns if breakage else 1))
        nb, nw = len(self.bodies), len(self.walls)
        self._B = BodyArrays(self.bodies, np.zeros(0, dtype=np.int64), np.zeros((nb, 6)),
                             np.zeros((nb, 6)), np.zeros(nb))
        self._W = WallArrays(self.walls, np.zeros((n, nw, self.layout.wall_columns)),
                             np.zeros((nw, 6)), np.zeros(nw))
        if self._mesh_geometry:
            self._W = MeshWallArrays(*self._W, *build_meshes(
                self._mesh_geometry, nw, n, self.layout.wall_columns,
                2.0 * float(np.max(radius)) + self.skin))
        self._refresh_members()
        for model in self._fields:
            model.attach(self)
            self._publish(model)
        self._rebuild_contacts(empty_contacts(n, self.layout.contact_columns))
        self._check_initial_overlaps()
        self.dt_report = self._time_step_report()
        self.dt = self.dt_report.check(self._policy_dt())
        self.wall_seconds = 0.0
        self._forces_current = False  # the start's forces are evaluated before the first step

    # ---- checkpoints (util.checkpoint) ---------------------------------------------------------
    def __getstate__(self):
        # The contact law carries its compiled kernel, and the models' field tuples are of a class
        # made at run time: a checkpoint stores neither, both are rebuilt on load from what it does.
        state = self.__dict__.copy()
        del state["law"]
        state["_fields"] = {model: tuple(fields) for model, fields in self._fields.items()}
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self.law = self.table.law
        self._fields = {model: _fields_tuple(model, arrays) for model, arrays in self._fields.items()}
        for model in self._fields:
            self._publish(model)

    # ---- construction helpers -----------------------------------------------------------------
    def material_index(self, name):
        name = str(name)
        if name not in self.table.index:
            raise ValueError(f"material: unknown material {name!r}; known: {sorted(self.table.index)}")
        return self.table.index[name]

    def _make_particles(self, x, radius, material, v, w, body):
        n = len(radius)
        if (radius <= 0).any() or not np.isfinite(radius).all():
            raise ValueError(f"radius: must be > 0, got min {radius.min():g}")
        names = material if np.ndim(material) else [material] * n
        mat = np.array([self.material_index(m) for m in np.atleast_1d(names)], dtype=np.int32)
        if len(mat) != n:
            raise ValueError(f"material: {len(mat)} names for {n} particles")
        density = np.array([self.table.materials[m].density for m in mat])
        mass = disk_or_sphere_mass(radius, density, self.spec.dim, self.thickness)
        inertia = moment_of_inertia(mass, radius, self.spec.dim)
        body = np.full(n, -1, dtype=np.int32) if body is None else np.asarray(body, dtype=np.int32)
        if body.max(initial=-1) >= len(self.bodies):
            raise ValueError(f"body: index {body.max()} but only {len(self.bodies)} bodies defined")
        kin = body >= 0
        x = _vec3(x, n)
        w = _vec3(w, n)
        # Particles of a kinematic body move rigidly with it, spin included: a rotating body's
        # particles spin at its rate (their surfaces then move with the body at every contact,
        # which is also what the body's power, torque x rate, assumes); a translating one's not.
        for b in np.unique(body[body >= 0]):
            rotating = self.bodies[b, B_KIND] == BODY_KINDS["rotate"]
            at_rest = self.bodies[b, B_RAMP] > 0.0  # a ramping body starts from rest
            w[body == b] = (0.0 if at_rest else self.bodies[b, B_RATE]) * self.bodies[b, B_AXIS] \
                if rotating else 0.0
        if self.spec.dim == 2:
            w[:, :2] = 0.0  # disks spin about z only
        # Kinematic particles: infinite mass and inertia (they never respond to forces).
        inv_mass = np.where(kin, 0.0, 1.0 / mass)
        inv_inertia = np.where(kin, 0.0, 1.0 / inertia)
        p = allocate(x, _vec3(v, n), w, radius, inv_mass, inv_inertia, mat, body, x.copy(),
                     self.spec.integrator == "gear", self.spec.normal_force_sum)
        p.acc[~kin] = self.gravity if self.spec.gravity else 0.0
        return p

    def _tag_array(self, name, values, n):
        values = np.asarray(values)
        if values.shape[:1] != (n,):
            raise ValueError(f"tags[{name}]: {values.shape[0] if values.ndim else 0} values for "
                             f"{n} particles")
        return values.copy()

    def _wall_table(self, walls):
        table = np.zeros((len(walls), WALL_COLUMNS))
        for k, wall in enumerate(walls):
            key = f"walls[{k}]"
            kind = wall.get("kind")
            if kind not in WALL_KINDS:
                raise ValueError(f"{key}.kind: must be one of {sorted(WALL_KINDS)}, got {kind!r}")
            table[k, 0] = WALL_KINDS[kind]
            table[k, W_POINT] = np.asarray(wall.get("point", (0, 0, 0)), dtype=float)
            table[k, W_AXIS] = _unit(wall.get("normal", wall.get("axis", (0, 0, 1) if kind == "mesh"
                                                               else None)), f"{key}.axis")
            if kind == "mesh":
                table[k, W_RADIUS] = self._mesh_wall(key, k, wall, table[k])
            elif kind in ("cylinder_inner", "cylinder_outer"):
                table[k, W_RADIUS] = wall["radius"]
                if table[k, W_RADIUS] <= 0:
                    raise ValueError(f"{key}.radius: must be > 0")
            elif kind not in ("plane", "mesh"):
                if not self.spec.bounded_walls:
                    raise ValueError(f"{key}.kind: {kind} walls need PhysicsSpec(bounded_walls=True)")
                table[k, W_SEGMENT] = self._frustum_segment(key, kind, wall)
                table[k, W_RADIUS] = max(table[k, W_SEGMENT][1], table[k, W_SEGMENT][3])
            if kind != "annulus" and "inner_radius" in wall:
                raise ValueError(f"{key}.inner_radius: only an annulus has one")
            table[k, W_OMEGA] = wall.get("omega", 0.0)
            if kind == "plane" and table[k, W_OMEGA] != 0.0 and self.spec.dim == 2:
                raise ValueError(f"{key}.omega: a plane turning about its normal would carry disks "
                                 "out of the plane of a 2D run; give 0")
            table[k, W_MATERIAL] = self.material_index(wall["material"])
            table[k, W_ACTIVE] = 1.0
            table[k, W_VELOCITY] = self._wall_velocity(key, wall.get("velocity", (0.0, 0.0, 0.0)))
            table[k, W_ORIGIN] = table[k, W_POINT]
        if len(walls) and not self.spec.walls:
            raise ValueError("walls: given but spec.walls is false")
        return table

    def _mesh_wall(self, key, k, wall, row):
        """Read and check a mesh wall's triangles (file or vertices and faces, in the world at
        t = 0, metres after ``scale``); returns its farthest vertex from the axis [m]."""
        if not self.spec.mesh_walls:
            raise ValueError(f"{key}.kind: mesh walls need PhysicsSpec(mesh_walls=True)")
        unknown = set(wall) - {"kind", "file", "scale", "vertices", "faces", "point", "axis",
                                "omega", "velocity", "material", "triangle_materials"}
        if unknown:
            raise ValueError(f"{key}: unknown keys {sorted(unknown)} for a mesh wall")
        vertices, faces = mesh_geometry(key, wall)
        frame = vertices - row[W_POINT]  # the frame's origin is the wall's point
        along = frame @ row[W_AXIS]
        arm = np.sqrt(np.maximum((frame**2).sum(1) - along**2, 0.0))
        material = np.full(len(faces), self.material_index(wall["material"]), np.int64)
        names = wall.get("triangle_materials")
        if names is not None:  # e.g. rubber liner plates with steel lifters in one solid
            if len(names) != len(faces):
                raise ValueError(f"{key}.triangle_materials: {len(names)} names for "
                                 f"{len(faces)} triangles")
            material = np.array([self.material_index(m) for m in names], np.int64)
        self._mesh_geometry.append((k, np.ascontiguousarray(frame), faces, material))
        return float(arm.max())

    def _wall_velocity(self, key, velocity):
        velocity = np.asarray(velocity, dtype=float)
        if velocity.shape != (3,) or not np.isfinite(velocity).all():
            raise ValueError(f"{key}.velocity: must be 3 finite numbers [m/s], got "
                             f"{velocity.tolist()}")
        if velocity.any() and not self.spec.translating_walls:
            raise ValueError(f"{key}.velocity: translating walls need "
                             "PhysicsSpec(translating_walls=True)")
        if self.spec.dim == 2 and velocity[2] != 0.0:
            raise ValueError(f"{key}.velocity: a 2D run's walls move in the xy plane; give vz = 0")
        return velocity

    def _frustum_segment(self, key, kind, wall):
        """(z0, r0, z1, r1) of a frustum wall; an annulus is the flat ring from inner_radius to
        radius at height 0."""
        if self.spec.dim == 2:
            raise ValueError(f"{key}.kind: {kind} is a 3D wall")
        if kind == "annulus":
            outer, inner = wall.get("radius", 0.0), wall.get("inner_radius", 0.0)
            if not outer > 0.0:
                raise ValueError(f"{key}.radius: must be > 0")
            if not 0.0 <= inner < outer:
                raise ValueError(f"{key}.inner_radius: must be in [0, radius = {outer:g}), got "
                                 f"{inner:g}")
            return 0.0, inner, 0.0, outer
        try:
            (z0, r0), (z1, r1) = wall["start"], wall["end"]
        except (KeyError, TypeError, ValueError):
            raise ValueError(f"{key}: a frustum needs start and end, each [height along the axis, "
                             "radius] in m") from None
        if min(r0, r1) < 0.0 or (z0 == z1 and r0 == r1):
            raise ValueError(f"{key}: start {[z0, r0]} and end {[z1, r1]} must be distinct "
                             "points with radii >= 0")
        return float(z0), float(r0), float(z1), float(r1)

    def _body_table(self, bodies):
        table = np.zeros((len(bodies), BODY_COLUMNS))
        for k, b in enumerate(bodies):
            kind = b.get("kind")
            if kind not in BODY_KINDS:
                raise ValueError(f"bodies[{k}].kind: must be one of {sorted(BODY_KINDS)}, got {kind!r}")
            table[k, 0] = BODY_KINDS[kind]
            table[k, 1:4] = np.asarray(b.get("center", (0, 0, 0)), dtype=float)
            table[k, B_AXIS] = _unit(b.get("axis", (0, 0, 1)), f"bodies[{k}].axis")
            table[k, B_RATE] = float(b.get("rate", 0.0))
            ramp = float(b.get("ramp", 0.0))
            if not ramp >= 0.0 or not math.isfinite(ramp):
                raise ValueError(f"bodies[{k}].ramp: must be a finite time >= 0 s, got {ramp!r}")
            table[k, B_RAMP] = ramp
        if len(bodies) and not self.spec.bodies:
            raise ValueError("bodies: given but spec.bodies is false")
        return table

    def _check_initial_overlaps(self):
        """Refuse a start whose overlaps already exceed the guard: the first steps would turn them
        into a numerical explosion, so say which pair and how to get a usable state."""
        p = self.particles
        i, j, overlap = self.contact_pairs()
        worst, what = 0.0, ""
        if len(i):
            ratio = overlap / np.minimum(p.radius[i], p.radius[j])
            k = int(np.argmax(ratio))
            worst, what = float(ratio[k]), f"particles {i[k]} and {j[k]}"
        if self._mesh_geometry:
            xi = mesh_overlaps(self._W, self.walls, p.x, p.radius, p.body, self.time)
            q = int(np.argmax(xi / p.radius))
            if xi[q] / p.radius[q] > worst:
                worst, what = float(xi[q] / p.radius[q]), f"particle {q} and a mesh wall"
        for iw, wall in enumerate(self.walls):
            if wall[W_KIND] == MESH:
                continue
            for q in np.flatnonzero(self.free):
                xi = wall_contact_bounded(wall, p.x[q, 0], p.x[q, 1], p.x[q, 2], p.radius[q])[0]
                if xi / p.radius[q] > worst:
                    worst, what = float(xi / p.radius[q]), f"particle {q} and wall {iw}"
        if worst > self.guards.max_overlap:
            raise ValueError(
                f"initial state: {what} overlap by {worst:.3g} of the smaller radius, above "
                f"max_overlap = {self.guards.max_overlap:g}; relax the state first (e.g. the "
                f"packing scene, or a short run with softer contacts) or place the particles apart")

    def _refresh_members(self):
        members = np.flatnonzero(self.particles.body >= 0).astype(np.int64)
        self._B = self._B._replace(members=members)

    def _publish(self, model):
        """Expose a model's current per-particle arrays as its attributes (``sim.breakage.e_frac``)."""
        fields = self._fields[model]
        model.fields = fields
        for name, array in zip(fields._fields, fields):
            setattr(model, name, array)

    def _rebuild_contacts(self, old):
        self.contacts = rebuilt_contacts(self.particles, old, self.skin + self.reach,
                                         self.spec.dim, self.box_lo, self.box_len,
                                         self.spec.periodic)
        if self._mesh_geometry:
            self._W = with_mesh_candidates(self._W, self.particles, self.skin, self.time)

    # ---- time step ----------------------------------------------------------------------------
    def _step_particles(self):
        """(radius, mass, material, body) of the particles the step is set for: those present and,
        with a policy's smallest_radius, one virtual particle of that size per free material."""
        p = self.particles
        mass = np.where(p.inv_mass > 0, 1.0 / np.where(p.inv_mass > 0, p.inv_mass, 1.0), np.inf)
        radius, material, body = p.radius, p.material, p.body
        if self.policy.smallest_radius is not None:
            # One virtual particle of the smallest possible size per free material.
            mats = np.unique(material[body < 0])
            density = np.array([self.table.materials[m].density for m in mats])
            r = np.full(len(mats), self.policy.smallest_radius)
            radius = np.concatenate([radius, r])
            mass = np.concatenate([mass, disk_or_sphere_mass(r, density, self.spec.dim,
                                                             self.thickness)])
            material = np.concatenate([material, mats])
            body = np.concatenate([body, np.full(len(mats), -1)])
        return radius, mass, material, body

    def _time_step_report(self):
        radius, mass, material, body = self._step_particles()
        p = self.particles
        boundary = [int(m) for m in self.walls[:, W_MATERIAL]] + [int(m) for m in
                                                                 p.material[p.body >= 0]]
        boundary += [int(m) for mesh in self._mesh_geometry for m in np.unique(mesh[3])]
        extra = self.fluid.step_bounds(self._smallest_for_fluid(radius, mass, material, body)) \
            if self.fluid else ()
        return time_step_report(self.law, self.table.materials, self.pair_params, self.spec.dim,
                                self.spec.integrator, radius, mass, material, body, boundary,
                                self.policy.impact_speed, extra)

    def _smallest_for_fluid(self, radius, mass, material, body):
        """(radius, mass, k_n, gamma_n, integrator) of the lightest free particle (lubrication.md
        4: with the contact spring and dashpot of a pair of them)."""
        k = int(np.argmin(np.where(body < 0, mass, np.inf)))
        m_min, a_min, mat = float(mass[k]), float(radius[k]), int(material[k])
        k_n, gamma_n = self.law.stiffness_and_damping(self.pair_params[mat, mat], 0.5 * m_min)
        return a_min, m_min, k_n, gamma_n, self.spec.integrator

    @property
    def dt(self):
        """The time step [s]. A change starts a new time origin at the current step."""
        return self._dt

    @dt.setter
    def dt(self, value):
        if value != getattr(self, "_dt", None):
            self._time_origin, self._step_origin = self.time, self.step
        self._dt = value

    def _policy_dt(self):
        if self.policy.dt is not None:
            return self.policy.dt
        return self.policy.dt_factor * self.dt_report.recommended

    def set_time_step(self, dt=None, dt_factor=None):
        """Change the policy: an absolute ``dt`` [s], or ``dt_factor`` x the recommended step
        (followed as particles change); a step above the stability limit is refused."""
        if (dt is None) == (dt_factor is None):
            raise ValueError("set_time_step: give dt or dt_factor")
        policy = StepPolicy(dt, 1.0 if dt_factor is None else dt_factor, self.policy.impact_speed,
                            self.policy.smallest_radius)
        dt_new = self.dt_report.check(dt if dt is not None else policy.dt_factor
                                      * self.dt_report.recommended)
        self.policy, self.dt = policy, dt_new

    # ---- running ------------------------------------------------------------------------------
    def run(self, steps, chunk=2000, observer=None, threads=None, on_events=None):
        """Advance ``steps`` steps in compiled chunks.

        ``observer(self)`` is called every ``chunk`` steps (the output cadence). A breakage
        decision ends a chunk early at a step boundary; ``on_events(self)`` then handles the
        decisions (``pop_events``) before the run goes on. ``threads``: numba threads (default all
        of numba's); systems below SERIAL_BELOW particles run on one thread (same results).
        """
        runner = chunk_runner(self.spec, self.law, self.breakage, self.fluid)
        saved = numba.get_num_threads()
        threads = numba.config.NUMBA_NUM_THREADS if threads is None else int(threads)
        if threads < 1:
            raise ValueError(f"threads: must be >= 1, got {threads}")
        done = 0
        next_observation = chunk
        self._check_contact_resolution()
        try:
            numba.set_num_threads(1 if self.n_particles < SERIAL_BELOW else
                                  min(threads, numba.config.NUMBA_NUM_THREADS))
            while done < steps:
                n = min(next_observation, steps) - done
                t0 = time.perf_counter()
                done += self._run_chunk(runner, n)
                self.wall_seconds += time.perf_counter() - t0
                self._check_contact_resolution()
                if self.accumulators.n_events[0]:
                    if on_events is None:
                        raise RuntimeError("breakage decided but no on_events handler given")
                    on_events(self)
                    numba.set_num_threads(1 if self.n_particles < SERIAL_BELOW else
                                          min(threads, numba.config.NUMBA_NUM_THREADS))
                if done >= next_observation or done == steps:
                    next_observation += chunk
                    if observer is not None:
                        observer(self)
        finally:
            numba.set_num_threads(saved)

    def _bundles(self):
        p = self.particles
        settings = RunSettings(self.pair_params, self.gravity, self.box_lo, self.box_len,
                               self.skin, self.reach, self.spec.dim, self.guards.max_overlap,
                               self.guards.v_max)
        bs = self.breakage.bundle(self._fields[self.breakage]) if self.breakage else np.zeros(0)
        fp = self.fluid.params() if self.fluid else np.zeros(0)
        return p, settings, bs, fp

    def _run_chunk(self, runner, n):
        p, settings, bs, fp = self._bundles()
        self.accumulators.err[:] = 0
        with _signals_after_chunk():
            steps, contacts, self._W, events = runner(
                n, self._time_origin, self.step - self._step_origin, self.dt, self.step, p,
                self.contacts, self._W, self._B, settings, self.accumulators, bs, fp, self.events,
                not self._forces_current)
        self._forces_current = True
        done = int(steps)
        self.contacts = ContactList(*contacts)
        self.events = events
        self.step += done
        self.time = self._time_origin + (self.step - self._step_origin) * self.dt
        if self.accumulators.err[0]:
            raise SimulationError(self._describe_error(self.accumulators.err))
        return done

    def _check_contact_resolution(self):
        """Hertz contacts shorten with speed: stop, naming the speed, once a particle moves so
        fast that its impacts would be resolved by fewer steps than the refusal limit."""
        if self.dt_report.hertz_contact_time is None:
            return
        p = self.particles
        speed = float(np.sqrt((p.v[self.free] ** 2).sum(1)).max(initial=0.0))
        if len(self.walls):
            w = self.walls
            surface = np.abs(w[:, W_RADIUS] * w[:, W_OMEGA])
            # a turning plane has no radius: its surface speed is omega x the farthest particle
            for k in np.flatnonzero((w[:, W_KIND] == PLANE) & (w[:, W_OMEGA] != 0.0)):
                arm = np.cross(w[k, W_AXIS], p.x[self.free] - w[k, W_POINT])
                surface[k] = abs(w[k, W_OMEGA]) * np.sqrt((arm**2).sum(1)).max(initial=0.0)
            surface += np.sqrt((w[:, W_VELOCITY] ** 2).sum(1))  # translating walls
            speed += float(surface.max())
        if len(self.bodies):
            speed += float(np.sqrt((p.v[~self.free] ** 2).sum(1)).max(initial=0.0))
        steps = self.dt_report.steps_per_contact(self.dt, speed)
        if steps < STEPS_PER_CONTACT_LIMIT:
            raise SimulationError(
                f"step {self.step} (t = {self.time:.6g} s): impacts at {speed:.4g} m/s, above "
                f"impact_speed = {self.dt_report.impact_speed:g} m/s the time step was chosen for, "
                f"would be resolved by {steps:.1f} steps (limit {STEPS_PER_CONTACT_LIMIT}); "
                f"declare impact_speed >= {speed:.4g} m/s (dt follows) or reduce dt")

    def _describe_error(self, err):
        """One line naming the step, the particle(s) and the limit that was crossed.

        The kernel stops at the end of the step where a guard fired; the culprit is re-derived
        here so that the message does not depend on which thread saw it first.
        """
        code, step, i, j = (int(e) for e in err)
        where = f"step {self.step - 1} (t = {self.time:.6g} s)"
        p = self.particles
        if code == ERR_OVERLAP:
            pi, pj, overlap, slot = self.contact_pairs(with_slots=True)
            if self.breakage:  # fragments count only beyond their reference overlap
                base = self.layout.spring
                overlap = overlap - self.breakage.reference_overlap(self.contacts.state[slot, base:])
            if len(pi):
                k = int(np.argmax(overlap / np.minimum(p.radius[pi], p.radius[pj])))
                i, j = int(pi[k]), int(pj[k])
            partner = f"wall {-1 - j}" if j < 0 else f"particle {j}"
            fraction = self.dt / self.dt_report.limit
            if fraction <= OVERLAP_FROM_STIFFNESS_BELOW:
                # the step resolves the contact: the overlap is what this spring allows at
                # this speed, and a smaller dt would not change it
                cure = (f"dt is {fraction:.2g} of its limit, so not the cause: the contact is too "
                        "soft for this speed (stiffen it, or bring the bodies together more "
                        "slowly, e.g. a speed ramp), or the state was set in overlap")
            else:
                cure = (f"reduce dt (now {self.dt:.4g} s, limit {self.dt_report.limit:.4g} s) "
                        "or check the initial state")
            return (f"{where}: overlap between particle {i} and {partner} exceeds "
                    f"{self.guards.max_overlap:g} of the smaller radius; {cure}")
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
            i = int(np.argmax(np.where(self.free, speed, 0.0)))
            return (f"{where}: runaway kinetic energy, particle {i} moves at {speed[i]:.4g} m/s, "
                    f"above v_max = {self.guards.v_max:.4g} m/s")
        return f"{where}: guard code {code} on particle {i}"

    def pop_events(self):
        """The breakage model's decisions of the last chunk, as its named records."""
        n = int(self.accumulators.n_events[0])
        rows = self.events[:n].copy()
        self.accumulators.n_events[0] = 0
        return self.breakage.records(rows) if self.breakage else []

    # ---- named access to walls, bodies and what they received --------------------------------
    def set_wall(self, index, *, point=None, axis=None, radius=None, omega=None, velocity=None):
        """Move or change wall ``index`` between chunks (its kind and material stay); a
        translating wall goes on from ``point`` at ``velocity`` from now."""
        row = self.walls[index]
        if velocity is not None:
            row[W_VELOCITY] = self._wall_velocity(f"walls[{index}]", velocity)
        if point is not None:
            row[W_POINT] = np.asarray(point, dtype=float)
        if point is not None or velocity is not None:
            row[W_ORIGIN] = row[W_POINT] - row[W_VELOCITY] * self.time
        if axis is not None:
            row[W_AXIS] = _unit(axis, f"walls[{index}].axis")
        if radius is not None:
            row[W_RADIUS] = check_range(f"walls[{index}].radius", radius, 0.0, lo_open=True)
        if omega is not None:
            if row[W_KIND] == MESH:  # the angle goes on from where it is
                row[W_ANGLE_REF] = mesh_angle(row, self.time)
                row[W_TIME_REF] = self.time
            row[W_OMEGA] = float(omega)

    def disable_wall(self, index):
        """Take wall ``index`` away: no contact, no lubrication, no load from now on."""
        self.walls[index, W_ACTIVE] = 0.0
        self.wall_hist[:, index, :] = 0.0
        self._forget_mesh_contacts(index)

    def enable_wall(self, index):
        """Put wall ``index`` (back) in place, with no contact history (e.g. a silo's bottom once
        its gate is taken away)."""
        self.walls[index, W_ACTIVE] = 1.0
        self.wall_hist[:, index, :] = 0.0
        self._forget_mesh_contacts(index)

    def mesh_clearance(self, points):
        """Per point, its distance to the nearest active mesh wall now, negative inside a mesh's
        solid (inf without meshes): e.g. where a pour may place a particle."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        out = np.full(len(points), np.inf)
        W = self._W
        for row, *_ in self._mesh_geometry:
            wall = self.walls[row]
            if wall[W_ACTIVE] == 0.0:
                continue
            frame = points_in_frame(wall, self.time, points)
            mine = W.tri_wall == row
            out = np.minimum(out, signed_clearance(W.tri[mine], W.tri_normal[mine], frame))
        return out

    def _forget_mesh_contacts(self, index):
        if self._mesh_geometry:
            hist = self._W.mesh_hist
            hist[hist[:, :, self.layout.wall_columns + 3] == index + 1] = 0.0

    def impulse(self, *, wall=None, body=None):
        """Force impulse [N s] a wall or body has received from the particles since the start."""
        return self._loads(wall, body).impulse[wall if body is None else body, 0:3].copy()

    def angular_impulse(self, *, wall=None, body=None):
        """Angular impulse [N m s] received, about the wall's point or the body's centre."""
        return self._loads(wall, body).impulse[wall if body is None else body, 3:6].copy()

    def work(self, *, wall=None, body=None):
        """Work [J] a (moving) wall or body has done on the particles since the start."""
        return float(self._loads(wall, body).work[wall if body is None else body])

    def _loads(self, wall, body):
        if (wall is None) == (body is None):
            raise ValueError("give wall=index or body=index")
        return self._W if body is None else self._B

    @property
    def wall_hist(self):
        """Per particle and wall, the contact state (tangential spring, model columns)."""
        return self._W.hist

    # ---- adding and removing particles (between chunks) ---------------------------------------
    def remove_particles(self, mask):
        """Remove particles where ``mask`` is true; contact state of surviving pairs is kept."""
        keep = ~np.asarray(mask, dtype=bool)
        n = self.n_particles
        new_index = np.cumsum(keep) - 1
        old = self.contacts
        pairs_i = np.repeat(np.arange(len(keep)), np.diff(old.start))
        sel = keep[pairs_i] & keep[old.nbr]
        ni, nj = new_index[pairs_i[sel]], new_index[old.nbr[sel]]
        start = np.zeros(int(keep.sum()) + 1, dtype=np.int64)
        np.add.at(start, ni + 1, 1)
        relabelled = ContactList(np.cumsum(start), nj.astype(np.int32), old.state[sel],
                                 old.rev_start, old.rev_slot)
        self.particles = select_rows(self.particles, keep, n)
        self._W = self._W._replace(hist=self._W.hist[keep])
        if self._mesh_geometry:
            self._W = self._W._replace(mesh_hist=self._W.mesh_hist[keep])
        self.tags = {name: values[keep] for name, values in self.tags.items()}
        self.particle_ids, self.parent_ids = self.particle_ids[keep], self.parent_ids[keep]
        for model in self._fields:
            self._fields[model] = select_rows(self._fields[model], keep, n)
            self._publish(model)
        self._after_change(relabelled)

    def add_particles(self, x, radius, material, v=None, w=None, tags=None, parent_ids=None):
        """Append free particles; the time step bound is re-evaluated (fragments shrink it).

        ``tags``: {name: values} for the new particles, for every tag the simulation keeps.
        ``parent_ids``: for fragments, the ``particle_ids`` of the particles they broke from
        (default: none, -1). Models give the new particles their declared defaults. The new
        particles get fresh ids. Returns their indices.
        """
        radius = np.asarray(radius, dtype=float)
        m = len(radius)
        n_old = self.n_particles
        tags = dict(tags or {})
        if set(tags) != set(self.tags):
            raise ValueError(f"tags: give values for {sorted(self.tags)}, got {sorted(tags)}")
        parents = np.asarray(np.full(m, -1) if parent_ids is None else parent_ids, np.int64)
        if parents.shape != (m,) or (parents < -1).any() or (parents >= self._next_id).any():
            raise ValueError(f"parent_ids: {m} ids of existing or earlier particles (or -1), got "
                             f"{parents!r}")
        new = self._make_particles(x, radius, material, v, w, None)
        self.particles = append_rows(self.particles, new, n_old)
        self._W = self._W._replace(hist=np.concatenate(
            [self._W.hist, np.zeros((m, len(self.walls), self.layout.wall_columns))]))
        if self._mesh_geometry:
            self._W = self._W._replace(mesh_hist=np.concatenate([self._W.mesh_hist, np.zeros(
                (m, MESH_SLOTS, self.layout.wall_columns + TAG_COLUMNS))]))
        for name in self.tags:
            self.tags[name] = np.concatenate([self.tags[name], self._tag_array(name, tags[name], m)])
        self.particle_ids = np.concatenate([self.particle_ids,
                                            np.arange(self._next_id, self._next_id + m)])
        self.parent_ids = np.concatenate([self.parent_ids, parents])
        self._next_id += m
        for model in self._fields:
            self._fields[model] = append_rows(self._fields[model], _model_fields(model, m), n_old)
            self._publish(model)
        old = self.contacts
        start = np.concatenate([old.start, np.full(m, old.start[-1])])
        self._after_change(ContactList(start, old.nbr, old.state, old.rev_start, old.rev_slot))
        return np.arange(n_old, n_old + m)

    def _after_change(self, relabelled):
        self._refresh_members()
        self._rebuild_contacts(relabelled)
        self.dt_report = self._time_step_report()
        # The per-contact limit (10 steps per contact) does not hold for a cluster of progeny
        # created overlapping each other (each touches several at once): at 0.95 of it a 40 m/s
        # Tavares fragmentation created energy 1.6x the impact energy (tests/test_stability.py).
        # An automatic step therefore follows the recommendation (times the factor), not just
        # the limit.
        if self.policy.dt is None:
            self.dt = min(self.dt, self.policy.dt_factor * self.dt_report.recommended)
        if self.dt_report.exceeds(self.dt):
            self.dt = self.dt_report.recommended
        self.accumulators.dissipation[N_AUDIT:] = np.nan  # the last powers belong to the old set

    def restart_free_flight(self):
        """Forget every contact's history and the integrator's: accelerations, Gear derivatives,
        wall contact state and the models' event state (e.g. a repeated-impact test putting
        survivors back in free flight); the neighbour list is rebuilt."""
        p = self.particles
        p.acc[:] = 0.0
        p.alpha[:] = 0.0
        p.gear[:] = 0.0
        self._W.hist[:] = 0.0
        if self._mesh_geometry:
            self._W.mesh_hist[:] = 0.0
        for model in self._fields:
            model.reset_events()
        self._after_change(self.contacts)
        self._forces_current = False

    # ---- observables --------------------------------------------------------------------------
    @property
    def n_particles(self):
        return len(self.particles.radius)

    @property
    def free(self):
        return self.particles.body < 0

    def masses(self):
        p = self.particles
        return np.where(p.inv_mass > 0, 1.0 / np.where(p.inv_mass > 0, p.inv_mass, 1.0), 0.0)

    def kinetic_energy(self):
        """Translational + rotational kinetic energy of the free particles [J]."""
        p = self.particles
        free = self.free
        m = 1.0 / p.inv_mass[free]
        inertia = 1.0 / p.inv_inertia[free]
        return float(0.5 * (m * (p.v[free] ** 2).sum(1)).sum()
                     + 0.5 * (inertia * (p.w[free] ** 2).sum(1)).sum())

    def potential_energy(self):
        """Gravitational potential energy of the free particles relative to the origin [J]."""
        if not self.spec.gravity:
            return 0.0
        p = self.particles
        free = self.free
        return float(-(1.0 / p.inv_mass[free] * (p.x[free] @ self.gravity)).sum())

    def energy_audit(self):
        """Energy dissipated since the start [J], by term (spec.energy_audit)."""
        if not self.spec.energy_audit:
            raise ValueError("energy_audit: spec.energy_audit is off")
        return dict(zip(AUDIT_TERMS, (float(e) for e in self.accumulators.dissipation[:N_AUDIT])))

    @property
    def counters(self):
        """[neighbour-list rebuilds, steps] since the start."""
        return self.accumulators.counters

    def separation(self, i, j):
        """x_i - x_j for index arrays i, j (minimum image on periodic axes)."""
        p = self.particles
        d = p.x[i] - p.x[j]
        for a in range(3):
            if self.box_len[a] > 0:
                d[:, a] -= self.box_len[a] * np.floor(d[:, a] / self.box_len[a] + 0.5)
        return d

    def contact_pairs(self, with_slots=False):
        """(i, j, overlap) of the particle pairs in contact now (and their list slots)."""
        p, c = self.particles, self.contacts
        i = np.repeat(np.arange(self.n_particles), np.diff(c.start))
        j = c.nbr.astype(np.int64)
        overlap = p.radius[i] + p.radius[j] - np.linalg.norm(self.separation(i, j), axis=1)
        touching = overlap > 0
        if with_slots:
            return i[touching], j[touching], overlap[touching], np.flatnonzero(touching)
        return i[touching], j[touching], overlap[touching]

    def slot(self, i, j):
        """The contact-list slot of the pair (i, j), or None when it is not listed."""
        a, b = min(i, j), max(i, j)
        c = self.contacts
        row = c.nbr[c.start[a]:c.start[a + 1]]
        k = c.start[a] + int(np.searchsorted(row, b))
        if k >= c.start[a + 1] or c.nbr[k] != b:
            return None
        return k
