"""The Simulation object: owns the state, chooses the time step, runs compiled chunks, guards.

Python touches the state only between chunks: to record outputs, print progress, check the guards,
and add or remove particles. Everything inside a chunk runs in the compiled loop of
:mod:`millsim.engine.loop`.
"""

import math
import sys
import time

import numba
import numpy as np

from . import contact as law
from .kinematics import BODY_COLUMNS, BODY_KINDS, WALL_COLUMNS, WALL_KINDS, wall_contact
from .loop import AUDIT_TERMS, ERR_NONFINITE, ERR_OVERLAP, ERR_SPEED, N_AUDIT
from .lubrication import check_lubrication_params, lubrication_dt_limit
from .materials import check_range
from .neighbours import build_verlet, wrap_periodic
from .spec import PhysicsSpec, chunk_runner
from .state import (allocate, concatenate, disk_or_sphere_mass, empty_contacts, moment_of_inertia,
                    select)
from .timestep import STEPS_PER_CONTACT_LIMIT, TimeStepReport, time_step_report


# Below this many particles one thread is faster than opening parallel regions every step; results
# are identical either way.
SERIAL_BELOW = 2000


class SimulationError(RuntimeError):
    """The run became unphysical (NaN, runaway speed, excessive overlap); names step and particle."""


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


class Simulation:
    """One DEM system: particles, walls, kinematic bodies, a material table and a physics spec.

    Args:
        spec: which physics the compiled loop contains.
        table: :class:`~millsim.engine.materials.MaterialTable` (contact law must match ``spec``).
        x, radius, material: initial positions [m] (N x dim), radii [m], material names.
        v, w: initial velocities [m/s] and angular velocities [rad/s] (default 0).
        body: kinematic body index per particle (-1 = free; default all free).
        walls: list of dicts ``{kind, point, normal|axis, radius, omega, material}``.
        bodies: list of dicts ``{kind: rotate|translate, center, axis, rate}``.
        gravity: acceleration vector [m/s2].
        box_lo, box_len: periodic box origin and lengths per axis [m] (length 0 = not periodic).
        skin: Verlet skin [m] (default 0.1 of the mean diameter).
        dt: time step [s]; default the recommended step; refused above the stability limit.
        impact_speed: largest expected impact speed [m/s] (sets the Hertz contact-time bound).
        max_overlap: guard, overlap / smaller radius beyond which the run stops.
        v_max: guard, particle speed [m/s] beyond which the run stops (runaway energy).
        thickness: disk thickness [m] for 2D masses.
        fracture_c: Weibull constant c [m^3 N^-4] of seed 000 (spec.fracture == "weibull").
        twin_repulsion: constant force [N] pushing twin fragments apart until they separate.
        seed: seed of the counter-based random numbers drawn inside the step loop.
        breakage: Tavares model (spec.fracture == "tavares"): {material: (gamma, e_min)} with the
            damage coefficient of eqs 5-6 and the smallest specific energy [J/kg] an event must
            reach to damage; materials not named never break. Each particle's fracture energy
            [J/kg] is ``particles.e_frac`` (set by the caller, inf = unbreakable).
        fluid: lubrication (spec.lubrication): {eta [Pa s], h_min, h_max} with the inner and outer
            gap cutoffs as fractions of the smaller diameter of a pair (defaults 0.001 and 0.05).
        smallest_radius: the smallest free particle that can ever exist [m] (fragments down to a
            sieve size): the time-step bounds hold for it from the start, so dt never has to change.
    """

    def __init__(self, spec: PhysicsSpec, table, x, radius, material, v=None, w=None, body=None,
                 walls=(), bodies=(), gravity=(0.0, 0.0, -9.81), box_lo=None, box_len=None,
                 skin=None, dt=None, impact_speed=1.0, max_overlap=0.3, v_max=None, thickness=1.0,
                 fracture_c=0.0, twin_repulsion=0.0, seed=0, smallest_radius=None, breakage=None,
                 fluid=None):
        if table.contact_law != spec.contact_law:
            raise ValueError(f"contact_law: table uses {table.contact_law!r}, spec {spec.contact_law!r}")
        self.spec = spec
        self.table = table
        self.thickness = float(thickness)
        self.pair_params = table.pair_params()
        radius = np.asarray(radius, dtype=float)
        n = len(radius)
        if n == 0:
            raise ValueError("radius: at least one particle is required")
        self.walls = self._wall_table(walls)
        self.bodies = self._body_table(bodies)
        self.gravity = np.asarray(gravity, dtype=float).reshape(3)
        self.box_lo = np.zeros(3) if box_lo is None else np.asarray(box_lo, dtype=float).reshape(3)
        self.box_len = np.zeros(3) if box_len is None else np.asarray(box_len, dtype=float).reshape(3)
        if (self.box_len > 0).any() != spec.periodic:
            raise ValueError("box_len: periodic lengths given iff spec.periodic is true")
        self.impact_speed = float(impact_speed)
        self.smallest_radius = None if smallest_radius is None else float(smallest_radius)
        self.max_overlap = float(max_overlap)
        self.v_max = float(v_max) if v_max is not None else max(100.0, 10.0 * self.impact_speed)
        self.state_columns = (3 if law.LAW_HAS_SPRING[spec.contact_law] else 0) + (
            3 if spec.fracture else 0)
        # tangential spring; Tavares: overlap and force one step ago, creation reference overlap
        self.wall_columns = 3 + (3 if spec.fracture == "tavares" else 0)
        self.fracture_params = np.array([fracture_c, seed, twin_repulsion], dtype=float)
        self.breakage = self._breakage_table(breakage)
        self.fluid = self._fluid(fluid)
        # lubrication reaches h_max beyond contact: the neighbour list must hold those pairs
        self.reach = self.fluid[2] * 2.0 * float(np.max(radius)) if spec.lubrication else 0.0
        # dissipated energy [J] per audit term, then the last step's power [W] per term (the loop
        # integrates trapezoidally; 0 at the start, NaN = unknown after a change of the particles)
        self.dissipation = np.zeros(2 * N_AUDIT)
        # Weibull rows [particle, partner, peak force, step]; Tavares rows [particle, specific
        # energy, step, force direction (3)]. Grows inside the loop as needed.
        self.fractures = np.zeros((64, 6 if spec.fracture == "tavares" else 4))
        self.n_fractures = np.zeros(1, dtype=np.int64)
        self.particles = self._make_particles(x, radius, material, v, w, body)
        mean_d = 2.0 * float(np.mean(radius))
        self.skin = 0.1 * mean_d if skin is None else float(skin)
        self.time = 0.0
        self.step = 0
        self.counters = np.zeros(2, dtype=np.int64)  # [list rebuilds, steps]
        nb, nw = len(self.bodies), len(self.walls)
        self.body_load = np.zeros((nb, 6))
        self.body_impulse = np.zeros((nb, 6))
        self.body_work = np.zeros(nb)
        self.wall_impulse = np.zeros((nw, 6))
        self.wall_work = np.zeros(nw)
        self.wall_hist = np.zeros((n, nw, self.wall_columns))
        self._refresh_members()
        self._rebuild_contacts(empty_contacts(n, self.state_columns))
        self._check_initial_overlaps()
        self.dt_report = self._time_step_report()
        self.dt = self.dt_report.check(float(dt)) if dt is not None else self.dt_report.recommended
        # an automatic step follows the recommendation when particles are added (fragments)
        self.automatic_dt = dt is None
        self.wall_seconds = 0.0

    # ---- construction helpers -----------------------------------------------------------------
    def _material_index(self, names):
        idx = []
        for name in np.atleast_1d(names):
            name = str(name)
            if name not in self.table.index:
                raise ValueError(f"material: unknown material {name!r}; known: {sorted(self.table.index)}")
            idx.append(self.table.index[name])
        return np.asarray(idx, dtype=np.int32)

    def _make_particles(self, x, radius, material, v, w, body, x_body0=None):
        n = len(radius)
        if (radius <= 0).any() or not np.isfinite(radius).all():
            raise ValueError(f"radius: must be > 0, got min {radius.min():g}")
        mat = self._material_index(material if np.ndim(material) else [material] * n)
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
            rigid = self.bodies[b, 7] * self.bodies[b, 4:7] if self.bodies[b, 0] == BODY_KINDS[
                "rotate"] else np.zeros(3)
            w[body == b] = rigid
        if self.spec.dim == 2:
            w[:, :2] = 0.0  # disks spin about z only
        # Kinematic particles: infinite mass and inertia (they never respond to forces).
        inv_mass = np.where(kin, 0.0, 1.0 / mass)
        inv_inertia = np.where(kin, 0.0, 1.0 / inertia)
        p = allocate(x, _vec3(v, n), w, radius, inv_mass, inv_inertia, mat, body,
                     x.copy() if x_body0 is None else x_body0, self.spec.integrator == "gear")
        p.acc[~kin] = self.gravity if self.spec.gravity else 0.0
        return p

    def _wall_table(self, walls):
        table = np.zeros((len(walls), WALL_COLUMNS))
        for k, wall in enumerate(walls):
            key = f"walls[{k}]"
            kind = wall.get("kind")
            if kind not in WALL_KINDS:
                raise ValueError(f"{key}.kind: must be one of {sorted(WALL_KINDS)}, got {kind!r}")
            axis = wall.get("normal", wall.get("axis"))
            table[k, 0] = WALL_KINDS[kind]
            table[k, 1:4] = np.asarray(wall.get("point", (0, 0, 0)), dtype=float)
            table[k, 4:7] = _unit(axis, f"{key}.axis")
            if kind != "plane":
                table[k, 7] = wall["radius"]
                if table[k, 7] <= 0:
                    raise ValueError(f"{key}.radius: must be > 0")
                table[k, 8] = wall.get("omega", 0.0)
            table[k, 9] = self._material_index([wall["material"]])[0]
        if len(walls) and not self.spec.walls:
            raise ValueError("walls: given but spec.walls is false")
        return table

    def _body_table(self, bodies):
        table = np.zeros((len(bodies), BODY_COLUMNS))
        for k, b in enumerate(bodies):
            kind = b.get("kind")
            if kind not in BODY_KINDS:
                raise ValueError(f"bodies[{k}].kind: must be one of {sorted(BODY_KINDS)}, got {kind!r}")
            table[k, 0] = BODY_KINDS[kind]
            table[k, 1:4] = np.asarray(b.get("center", (0, 0, 0)), dtype=float)
            table[k, 4:7] = _unit(b.get("axis", (0, 0, 1)), f"bodies[{k}].axis")
            table[k, 7] = float(b.get("rate", 0.0))
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
        for iw, wall in enumerate(self.walls):
            for q in np.flatnonzero(self.free):
                xi = wall_contact(wall, p.x[q, 0], p.x[q, 1], p.x[q, 2], p.radius[q])[0]
                if xi / p.radius[q] > worst:
                    worst, what = float(xi / p.radius[q]), f"particle {q} and wall {iw}"
        if worst > self.max_overlap:
            raise ValueError(
                f"initial state: {what} overlap by {worst:.3g} of the smaller radius, above "
                f"max_overlap = {self.max_overlap:g}; relax the state first (e.g. the packing "
                f"scene, or a short run with softer contacts) or place the particles apart")

    def _fluid(self, fluid):
        """[eta, h_min/d, h_max/d], validated (zeros when the scene is dry)."""
        if not self.spec.lubrication:
            if fluid:
                raise ValueError("fluid: given but spec.lubrication is false")
            return np.zeros(3)
        fluid = dict(fluid or {})
        unknown = set(fluid) - {"eta", "h_min", "h_max"}
        if unknown:
            raise ValueError(f"fluid: unknown keys {sorted(unknown)} (eta, h_min, h_max)")
        eta, h_min, h_max = fluid.get("eta", 0.0), fluid.get("h_min", 0.001), fluid.get("h_max", 0.05)
        check_lubrication_params(eta, h_min, h_max)
        return np.array([eta, h_min, h_max], dtype=float)

    def _breakage_table(self, breakage):
        """Per material: [stiffness Y/(1 - nu^2) (eq 4), damage gamma, e_min]."""
        table = np.zeros((len(self.table.materials), 3))
        if self.spec.fracture != "tavares":
            if breakage:
                raise ValueError("breakage: given but spec.fracture is not 'tavares'")
            return table
        for k, m in enumerate(self.table.materials):
            table[k, 0] = m.youngs_modulus / (1.0 - m.poisson_ratio**2)
        for name, (gamma, e_min) in (breakage or {}).items():
            k = self._material_index([name])[0]
            table[k, 1] = check_range(f"breakage[{name}].gamma", gamma, 0.0, lo_open=True)
            table[k, 2] = check_range(f"breakage[{name}].e_min", e_min, 0.0)
        return table

    def _refresh_members(self):
        self.body_members = np.flatnonzero(self.particles.body >= 0).astype(np.int64)

    def _rebuild_contacts(self, old):
        p = self.particles
        if self.spec.periodic:
            wrap_periodic(p.x, p.body, self.box_lo, self.box_len)
        self.contacts = type(old)(*build_verlet(p.x, p.radius, p.body, self.skin + self.reach,
                                                self.spec.dim,
                                                self.box_lo, self.box_len, old.start, old.nbr,
                                                old.state))
        p.x_ref[:] = p.x

    def _time_step_report(self):
        p = self.particles
        mass = np.where(p.inv_mass > 0, 1.0 / np.where(p.inv_mass > 0, p.inv_mass, 1.0), np.inf)
        radius, material, body = p.radius, p.material, p.body
        if self.smallest_radius is not None:
            # One virtual particle of the smallest possible size per free material.
            mats = np.unique(material[body < 0])
            density = np.array([self.table.materials[m].density for m in mats])
            r = np.full(len(mats), self.smallest_radius)
            radius = np.concatenate([radius, r])
            mass = np.concatenate([mass, disk_or_sphere_mass(r, density, self.spec.dim, self.thickness)])
            material = np.concatenate([material, mats])
            body = np.concatenate([body, np.full(len(mats), -1)])
        boundary = [int(m) for m in self.walls[:, 9]] + [int(m) for m in p.material[p.body >= 0]]
        report = time_step_report(self.table, self.spec, radius, mass, material, body,
                                  boundary, self.impact_speed)
        if self.spec.lubrication and self.fluid[0] > 0:
            report = TimeStepReport(report.bounds + (self._lubrication_bound(radius, mass, material,
                                                                            body),),
                                    report.hertz_contact_time, report.impact_speed)
        return report

    def _lubrication_bound(self, radius, mass, material, body):
        """Explicit stability with lubrication, from the smallest free particle (lubrication.md 4)."""
        free = body < 0
        k = int(np.argmin(np.where(free, mass, np.inf)))
        m_min, a_min, mat = float(mass[k]), float(radius[k]), int(material[k])
        p = self.pair_params[mat, mat]
        k_n, gamma_n = 0.0, 0.0
        if self.spec.contact_law != "hertz_mindlin":  # Hertz: its own contact bounds hold
            k_n = float(p[law.P_K_N])
            if self.spec.contact_law == "linear_hw":
                gamma_n = float(p[law.P_GAMMA_N])
            else:
                gamma_n = 2.0 * float(p[law.P_ZETA_N]) * math.sqrt(k_n / (0.5 * m_min))
        integrator = "gear" if self.spec.integrator == "gear" else "verlet"
        return lubrication_dt_limit(self.fluid[0], self.fluid[1] * 2.0 * a_min, a_min, m_min, k_n,
                                    gamma_n, integrator).step_bound()

    # ---- running ------------------------------------------------------------------------------
    def run(self, steps, chunk=2000, observer=None, progress=False, threads=None,
            on_fracture=None):
        """Advance ``steps`` steps in compiled chunks.

        ``observer(self)`` is called every ``chunk`` steps (the output cadence). A fracture
        decision ends a chunk early at a step boundary; ``on_fracture(self)`` then replaces the
        broken particles before the run goes on. ``threads`` defaults to numba's current setting;
        small systems run on one thread.
        """
        runner = chunk_runner(self.spec)
        progress = Progress(steps, self.dt) if progress else None
        saved = numba.get_num_threads()
        threads = saved if threads is None else int(threads)
        done = 0
        next_observation = chunk
        self._check_contact_resolution()
        try:
            while done < steps:
                n = min(next_observation, steps) - done
                numba.set_num_threads(1 if self.n_particles < SERIAL_BELOW else threads)
                t0 = time.perf_counter()
                done += self._run_chunk(runner, n)
                self.wall_seconds += time.perf_counter() - t0
                self._check_contact_resolution()
                if self.n_fractures[0]:
                    if on_fracture is None:
                        raise RuntimeError("fractures decided but no on_fracture handler given")
                    on_fracture(self)
                if done >= next_observation or done == steps:
                    next_observation += chunk
                    if progress:
                        progress.update(done, self.n_particles)
                    if observer is not None:
                        observer(self)
        finally:
            numba.set_num_threads(saved)
        if progress:
            progress.finish()

    def _run_chunk(self, runner, n):
        p, c = self.particles, self.contacts
        err = np.zeros(4, dtype=np.int64)
        out = runner(n, self.time, self.dt, p, c, self.pair_params, self.walls, self.wall_hist,
                     self.bodies, self.body_members, self.gravity, self.box_lo, self.box_len,
                     self.skin, self.spec.dim, self.max_overlap, self.v_max, self.body_load,
                     self.body_impulse, self.body_work, self.wall_impulse, self.wall_work,
                     self.counters, err, self.step, self.fracture_params, self.fractures,
                     self.n_fractures, self.breakage, self.reach, self.fluid, self.dissipation)
        done = int(out[0])
        self.contacts = type(c)(*out[1:6])
        self.fractures = out[6]
        self.step += done
        self.time += done * self.dt
        if err[0]:
            raise SimulationError(self._describe_error(err))
        return done

    def _check_contact_resolution(self):
        """Hertz contacts shorten with speed: stop, naming the speed, once a particle moves so
        fast that its impacts would be resolved by fewer steps than the refusal limit."""
        if self.dt_report.hertz_contact_time is None:
            return
        p = self.particles
        speed = float(np.sqrt((p.v[self.free] ** 2).sum(1)).max(initial=0.0))
        if len(self.walls):
            speed += float(np.abs(self.walls[:, 7] * self.walls[:, 8]).max())
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
            if self.spec.fracture:  # fragments count only beyond their reference overlap
                overlap = overlap - self._reference_overlap(slot)
            if len(pi):
                k = int(np.argmax(overlap / np.minimum(p.radius[pi], p.radius[pj])))
                i, j = int(pi[k]), int(pj[k])
            partner = f"wall {-1 - j}" if j < 0 else f"particle {j}"
            return (f"{where}: overlap between particle {i} and {partner} exceeds "
                    f"{self.max_overlap:g} of the smaller radius; reduce dt (now {self.dt:.4g} s, "
                    f"limit {self.dt_report.limit:.4g} s) or check the initial state")
        bad = ~np.isfinite(p.v).all(1) | ~np.isfinite(p.x).all(1)
        if code == ERR_NONFINITE or bad.any():
            first = int(np.flatnonzero(bad)[0]) if bad.any() else i
            return (f"{where}: particle {first} has a non-finite velocity (NaN/inf); "
                    f"{int(bad.sum())} particle(s) affected")
        if code == ERR_SPEED:
            speed = np.linalg.norm(p.v, axis=1)
            i = int(np.argmax(np.where(self.free, speed, 0.0)))
            return (f"{where}: runaway kinetic energy, particle {i} moves at {speed[i]:.4g} m/s, "
                    f"above v_max = {self.v_max:.4g} m/s")
        return f"{where}: guard code {code} on particle {i}"

    def pop_fractures(self):
        """Fracture decisions of the last chunk.

        Weibull: list of (particle, partner, peak force [N], step). Tavares: list of (particle,
        absorbed specific energy [J/kg], step, unit direction of the largest contact force).
        """
        rows = self.fractures[: int(self.n_fractures[0])].copy()
        self.n_fractures[0] = 0
        if self.spec.fracture == "tavares":
            out = []
            for r in rows:
                d = r[3:6]
                norm = np.linalg.norm(d)
                out.append((int(r[0]), float(r[1]), int(r[2]),
                            d / norm if norm > 0 else np.array([0.0, 0.0, 1.0])))
            return out
        return [(int(a), int(b), float(f), int(s)) for a, b, f, s in rows]

    def _slot(self, i, j):
        a, b = min(i, j), max(i, j)
        c = self.contacts
        row = c.nbr[c.start[a]:c.start[a + 1]]
        k = c.start[a] + int(np.searchsorted(row, b))
        if k >= c.start[a + 1] or c.nbr[k] != b:
            return None
        return k

    def _reference_overlap(self, slots):
        """Creation overlap of fragment pairs (0 for ordinary pairs) at the given list slots."""
        base = self.state_columns - 3
        state = self.contacts.state[slots]
        if self.spec.fracture == "weibull":
            return np.where(state[:, base + 1] > 0, state[:, base + 2], 0.0)
        return state[:, base + 2]

    def mark_creation_overlaps(self, indices):
        """Particles just created (Tavares progeny) may reach into their neighbours and walls: in
        every contact they have now, only overlap beyond the present one will count (seed 002
        section 2.3), the reference shrinking as the pair parts."""
        if self.spec.fracture != "tavares":
            raise ValueError("mark_creation_overlaps: spec.fracture is not 'tavares'")
        c, p = self.contacts, self.particles
        indices = np.atleast_1d(indices)
        slots = np.concatenate([np.arange(c.start[i], c.start[i + 1]) for i in indices] +
                               [c.rev_slot[c.rev_start[i]:c.rev_start[i + 1]] for i in indices])
        if len(slots):
            owner = np.searchsorted(c.start, slots, side="right") - 1
            d = p.x[owner] - p.x[c.nbr[slots]]
            for a in range(3):
                if self.box_len[a] > 0:
                    d[:, a] -= self.box_len[a] * np.floor(d[:, a] / self.box_len[a] + 0.5)
            overlap = p.radius[owner] + p.radius[c.nbr[slots]] - np.linalg.norm(d, axis=1)
            col = self.state_columns - 1
            c.state[slots, col] = np.maximum(c.state[slots, col], np.maximum(overlap, 0.0))
        for iw, wall in enumerate(self.walls):
            for i in indices:
                xi = wall_contact(wall, p.x[i, 0], p.x[i, 1], p.x[i, 2], p.radius[i])[0]
                if xi > 0:
                    self.wall_hist[i, iw, 5] = xi

    def mark_twins(self, i, j):
        """Fragments i and j were created overlapping: only overlap beyond the present one counts.

        Weibull (seed 000): the pair also gets the twin relief force until it first separates.
        Tavares (seed 002): the reference shrinks as the pair parts, and is gone once it has.
        """
        if not self.spec.fracture:
            raise ValueError("mark_twins: spec.fracture is off")
        k = self._slot(i, j)
        if k is None:
            return
        c = self.contacts
        base = self.state_columns - 3
        d = self.particles.x[i] - self.particles.x[j]
        overlap = self.particles.radius[i] + self.particles.radius[j] - np.linalg.norm(d)
        if self.spec.fracture == "weibull":
            c.state[k, base + 1] = 1.0  # twin flag
            c.state[k, base + 2] = overlap
        else:
            c.state[k, base + 2] = max(overlap, 0.0)

    def twin_partners(self, i):
        """Particles that are still twins of particle i (fragments not yet separated)."""
        c = self.contacts
        base = self.state_columns - 3
        flag = c.state[:, base + 1] if self.spec.fracture == "weibull" else c.state[:, base + 2]
        twin = flag > 0
        mine = np.arange(c.start[i], c.start[i + 1])
        theirs = c.rev_slot[c.rev_start[i]:c.rev_start[i + 1]]
        owner = np.searchsorted(c.start, theirs, side="right") - 1
        return [int(j) for j in c.nbr[mine][twin[mine]]] + [int(o) for o in owner[twin[theirs]]]

    def set_time_step(self, dt):
        """Change dt (refused above the stability limit); from now on dt is the caller's."""
        self.dt = self.dt_report.check(float(dt))
        self.automatic_dt = False

    # ---- adding and removing particles (between chunks) ---------------------------------------
    def remove_particles(self, mask):
        """Remove particles where ``mask`` is true; contact state of surviving pairs is kept."""
        keep = ~np.asarray(mask, dtype=bool)
        new_index = np.cumsum(keep) - 1
        old = self.contacts
        pairs_i = np.repeat(np.arange(len(keep)), np.diff(old.start))
        sel = keep[pairs_i] & keep[old.nbr]
        ni, nj = new_index[pairs_i[sel]], new_index[old.nbr[sel]]
        start = np.zeros(int(keep.sum()) + 1, dtype=np.int64)
        np.add.at(start, ni + 1, 1)
        relabelled = type(old)(np.cumsum(start), nj.astype(np.int32), old.state[sel],
                               old.rev_start, old.rev_slot)
        self.particles = select(self.particles, keep)
        self.wall_hist = self.wall_hist[keep]
        self._after_change(relabelled)

    def add_particles(self, x, radius, material, v=None, w=None):
        """Append free particles; the time step bound is re-evaluated (fragments shrink it).

        An automatic step (``dt=None`` at construction) becomes the new recommended step when that
        is smaller; a step the caller chose is kept while it stays within the new limit.
        """
        radius = np.asarray(radius, dtype=float)
        new = self._make_particles(x, radius, material, v, w, None)
        n_old = len(self.particles.radius)
        self.particles = concatenate(self.particles, new)
        self.wall_hist = np.concatenate([self.wall_hist,
                                         np.zeros((len(radius), len(self.walls), self.wall_columns))])
        old = self.contacts
        start = np.concatenate([old.start, np.full(len(radius), old.start[-1])])
        self._after_change(type(old)(start, old.nbr, old.state, old.rev_start, old.rev_slot))
        return np.arange(n_old, n_old + len(radius))

    def _after_change(self, relabelled):
        self._refresh_members()
        self._rebuild_contacts(relabelled)
        self.dt_report = self._time_step_report()
        # The per-contact limit (10 steps per contact) does not hold for a cluster of progeny
        # created overlapping each other (each touches several at once): at 0.95 of it a 40 m/s
        # Tavares fragmentation created energy 1.6x the impact energy (tests/test_stability.py).
        # An automatic step therefore follows the recommendation, not just the limit.
        if self.dt > self.dt_report.limit or (self.automatic_dt
                                              and self.dt > self.dt_report.recommended):
            self.dt = self.dt_report.recommended
        self.dissipation[N_AUDIT:] = np.nan  # the last step's powers belong to the old particle set

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
        return dict(zip(AUDIT_TERMS, (float(e) for e in self.dissipation[:N_AUDIT])))

    def contact_pairs(self, with_slots=False):
        """(i, j, overlap) of the particle pairs in contact now (and their list slots)."""
        p, c = self.particles, self.contacts
        i = np.repeat(np.arange(self.n_particles), np.diff(c.start))
        j = c.nbr.astype(np.int64)
        d = p.x[i] - p.x[j]
        for a in range(3):
            if self.box_len[a] > 0:
                d[:, a] -= self.box_len[a] * np.floor(d[:, a] / self.box_len[a] + 0.5)
        overlap = p.radius[i] + p.radius[j] - np.linalg.norm(d, axis=1)
        touching = overlap > 0
        if with_slots:
            return i[touching], j[touching], overlap[touching], np.flatnonzero(touching)
        return i[touching], j[touching], overlap[touching]


class Progress:
    """Progress line on stderr at most every few seconds: steps/s, simulated time, ETA."""

    def __init__(self, total, dt, every=5.0):
        self.total, self.dt, self.every = total, dt, every
        self.start = self.last = time.perf_counter()

    def update(self, done, n_particles):
        now = time.perf_counter()
        if now - self.last < self.every and done < self.total:
            return
        self.last = now
        rate = done / max(now - self.start, 1e-9)
        eta = (self.total - done) / rate if rate > 0 else math.inf
        print(f"[millsim] step {done}/{self.total}  t = {done * self.dt:.4g} s  "
              f"{rate:.3g} steps/s  {rate * n_particles:.3g} particle-steps/s  ETA {eta:.0f} s",
              file=sys.stderr, flush=True)

    def finish(self):
        elapsed = time.perf_counter() - self.start
        print(f"[millsim] done: {self.total} steps in {elapsed:.1f} s", file=sys.stderr, flush=True)
