"""The Simulation object: owns the state, chooses the time step, runs compiled chunks, guards.

Python touches the state only between chunks: to record outputs, check the guards, and add or
remove particles. Everything inside a chunk runs in the compiled loop of :mod:`millsim.engine.loop`.
Models (contact law via the material table, breakage, fluid) are objects handed in; the
Simulation allocates their per-particle arrays, keeps them in step with added and removed
particles, and hands their hooks to the loop.
"""

import signal
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass

import numba
import numpy as np

from .guards import (
    SimulationError,
    check_contact_resolution,
    check_initial_overlaps,
    describe_error,
)
from .kinematics import body_table
from .loop import AUDIT_TERMS, N_AUDIT, Layout
from .mesh import build_meshes, with_mesh_candidates
from .neighbours import rebuilt_contacts
from .particles import (
    add_particles,
    fields_tuple,
    make_particles,
    model_fields,
    remove_particles,
    tag_array,
)
from .spec import PhysicsSpec, chunk_runner
from .spectra import SpectraBins, close_open, collision_spectra, spectra_accumulators
from .state import (
    Accumulators,
    BodyArrays,
    ContactList,
    MeshWallArrays,
    RunSettings,
    WallArrays,
    empty_contacts,
)
from .stepping import (
    StepPolicy,
    set_time_step,
    sim_time_step_report,
    smallest_for_fluid,
    step_particles,
)
from .walls import mesh_clearance, open_mesh_contacts, set_wall, set_wall_active, wall_table

__all__ = ["Guards", "Simulation", "SimulationError", "StepPolicy"]

# Below this many particles one thread is faster than opening parallel regions every step
# (docs/engine.md, "Determinism and threads"); results are identical either way.
SERIAL_BELOW = 2000


@dataclass(frozen=True)
class Guards:
    """The run stops with a named error when an overlap exceeds ``max_overlap`` of the smaller
    radius, or a particle moves faster than ``v_max`` [m/s] (default max(100, 10 x the impact
    speed)); NaN always stops it."""

    max_overlap: float = 0.3
    v_max: float = None


DEFAULT_STEP = StepPolicy()


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
        walls: list of dicts ``{kind, point, normal|axis, material, omega, velocity, ...}``, each
            with its kind's keys (docs/walls.md; the kinds: engine.walls.KINDS).
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
        spectra: :class:`~millsim.engine.spectra.SpectraBins` of the collision spectra
            (``spec.collision_spectra``; default ``SpectraBins()``).
    """

    def __init__(self, spec: PhysicsSpec, table, x, radius, material, *, v=None, w=None,
                 body=None, walls=(), bodies=(), gravity=(0.0, 0.0, -9.81), box=None, skin=None,
                 thickness=1.0, step=DEFAULT_STEP, guards=Guards(), breakage=None, fluid=None,
                 tags=None, spectra=None):
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
        self.walls = wall_table(self, walls)
        self.bodies = body_table(spec, bodies)
        self.gravity = np.asarray(gravity, dtype=float).reshape(3)
        lo, length = (np.zeros(3), np.zeros(3)) if box is None else box
        self.box_lo = np.asarray(lo, dtype=float).reshape(3)
        self.box_len = np.asarray(length, dtype=float).reshape(3)
        if (self.box_len > 0).any() != spec.periodic:
            raise ValueError("box: periodic lengths given iff spec.periodic is true")
        self.policy = step
        self.guards = Guards(guards.max_overlap, float(guards.v_max) if guards.v_max is not None
                             else max(100.0, 10.0 * step.impact_speed))
        self.particles = make_particles(self, x, radius, material, v, w, body)
        self.breakage, self.fluid = breakage, None
        if fluid is not None and fluid.scheme == "auto":  # the scheme the dry step calls for
            fluid = fluid.resolve(sim_time_step_report(self).recommended,
                                  smallest_for_fluid(self, *step_particles(self)))
        if fluid is not None and fluid.implicit and spec.integrator != "verlet":
            # the implicit solve is a leapfrog kick (engine.implicit); Gear has none
            raise ValueError(f"fluid: the implicit lubrication scheme needs integrator 'verlet', "
                             f"got {spec.integrator!r}")
        self.fluid = fluid
        if fluid is not None and spec.translating_walls:
            raise ValueError("translating_walls: not with a fluid (the wall lubrication knows "
                             "only a wall's turning)")
        self.layout = Layout.of(spec, self.law, breakage, fluid)
        # lubrication reaches h_max beyond contact: the neighbour list must hold those pairs
        self.reach = fluid.reach(float(np.max(radius))) if fluid else 0.0
        self.tags = {}
        for name, values in (tags or {}).items():
            self.tags[name] = tag_array(name, values, n)
        # Who is who, to follow fragments across snapshots: an id per particle, never reused, and
        # the id of the particle it broke from (-1: none). Python-side, like the tags: the compiled
        # loop never sees them, so they cost nothing in a step, with or without breakage.
        self.particle_ids = np.arange(n, dtype=np.int64)
        self.parent_ids = np.full(n, -1, dtype=np.int64)
        self._next_id = n
        self._fields = {m: model_fields(m, n) for m in (breakage, fluid) if m is not None}
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
        if spectra is not None and not spec.collision_spectra:
            raise ValueError("spectra: needs PhysicsSpec(collision_spectra=True)")
        self.spectra_bins = (spectra if spectra is not None else SpectraBins()) \
            if spec.collision_spectra else None
        if self.spectra_bins is not None:
            self.accumulators = spectra_accumulators(self.accumulators, self.spectra_bins,
                                                     len(self.pair_params))
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
        check_initial_overlaps(self)
        self.dt_report = sim_time_step_report(self)
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
        self._fields = {model: fields_tuple(model, arrays) for model, arrays in self._fields.items()}
        for model in self._fields:
            self._publish(model)

    # ---- construction helpers -----------------------------------------------------------------
    def material_index(self, name):
        name = str(name)
        if name not in self.table.index:
            raise ValueError(f"material: unknown material {name!r}; known: {sorted(self.table.index)}")
        return self.table.index[name]

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
            self._W = with_mesh_candidates(self._W, self.particles, self.skin + self.reach,
                                           self.time)

    # ---- time step ----------------------------------------------------------------------------
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
        set_time_step(self, dt, dt_factor)

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
        check_contact_resolution(self)
        try:
            numba.set_num_threads(1 if self.n_particles < SERIAL_BELOW else
                                  min(threads, numba.config.NUMBA_NUM_THREADS))
            while done < steps:
                n = min(next_observation, steps) - done
                t0 = time.perf_counter()
                done += self._run_chunk(runner, n)
                self.wall_seconds += time.perf_counter() - t0
                check_contact_resolution(self)
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
            raise SimulationError(describe_error(self, self.accumulators.err))
        return done

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
        set_wall(self, index, point, axis, radius, omega, velocity)

    def disable_wall(self, index):
        """Take wall ``index`` away: no contact, no lubrication, no load from now on."""
        if self.spectra_bins is not None:  # its collisions end here (half a step to come)
            close_open(self, wall=index, tail=self.dt)
        set_wall_active(self, index, False)

    def enable_wall(self, index):
        """Put wall ``index`` (back) in place, with no contact history (e.g. a silo's bottom once
        its gate is taken away)."""
        if self.spectra_bins is not None:
            close_open(self, wall=index, tail=self.dt)
        set_wall_active(self, index, True)

    def mesh_clearance(self, points):
        """Per point, its distance to the nearest active mesh wall now, negative inside a mesh's
        solid (inf without meshes): e.g. where a pour may place a particle."""
        return mesh_clearance(self, points)

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

    @property
    def mesh_hist(self):
        """Per particle and mesh history slot, the contact state as in ``wall_hist``, then the
        slot's tag (engine.mesh); None without mesh walls."""
        return self._W.mesh_hist if self._mesh_geometry else None

    def open_mesh_contacts(self, indices):
        """Give each mesh contact the particles ``indices`` (just created) have now its history
        slot; returns (particle, slot, overlap) arrays, for a model to set its state in
        ``mesh_hist`` (empty without mesh walls)."""
        return open_mesh_contacts(self, indices)

    # ---- adding and removing particles (between chunks) ---------------------------------------
    def remove_particles(self, mask):
        """Remove particles where ``mask`` is true; contact state of surviving pairs is kept
        (their open collisions are counted, engine.spectra)."""
        if self.spectra_bins is not None:
            close_open(self, removed=mask)
        remove_particles(self, mask)

    def add_particles(self, x, radius, material, v=None, w=None, tags=None, parent_ids=None):
        """Append free particles; the time step bound is re-evaluated (fragments shrink it).

        ``tags``: {name: values} for the new particles, for every tag the simulation keeps.
        ``parent_ids``: for fragments, the ``particle_ids`` of the particles they broke from
        (default: none, -1). Models give the new particles their declared defaults. The new
        particles get fresh ids. Returns their indices.
        """
        return add_particles(self, x, radius, material, v, w, tags, parent_ids)

    def _after_change(self, relabelled):
        self._refresh_members()
        self._rebuild_contacts(relabelled)
        self.dt_report = sim_time_step_report(self)
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
        if self.spectra_bins is not None:  # the wall contacts' collisions end here
            close_open(self)
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

    def collision_spectra(self):
        """Collision energy spectra since the start (spec.collision_spectra):
        :class:`~millsim.engine.spectra.CollisionSpectra`."""
        if self.spectra_bins is None:
            raise ValueError("collision_spectra: spec.collision_spectra is off")
        return collision_spectra(self, self.spectra_bins)

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
