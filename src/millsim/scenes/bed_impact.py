"""Scene ``bed_impact``: a steel ball dropped on an unconfined bed of 5.5 mm particles
(Tavares et al. 2021).

Tavares, Rodriguez, Sousani, Padros & Ooi (2021), section 3.1-3.2 and 4.2 (Figs 20-23):

- **Bed.** Hexagonal monolayers of 0-4 rings around a central particle (1, 7, 19, 37, 61
  particles), or beds of several such layers stacked in the hollows of the layer below (ABA...,
  hexagonal close packing), held by a cylindrical holder (the experiments' paper ribbon) that is
  removed at the first contact of the ball with the bed. Particles are spheres of one size
  (5.5 mm, the middle of the 4.75-6.3 mm test class) on a steel anvil (the plane z = 0).
- **Ball.** 88 mm steel ball of 2.78 kg; its density is set so that the sphere has exactly that
  mass (7791 kg/m3, 0.1 % below the 7800 of Table 5). It starts ``ball_gap`` above the bed with
  the speed that brings it to v = sqrt(2 E / m) at contact (3.05 J -> 1.481 m/s; the experiments
  used 1.0-2.5 m/s, 1.39-8.69 J).
- **Physics.** Hertz-Mindlin with the Table 5 elastic constants and the Table 6 contact
  parameters (restitution, static and rolling friction, EDEM standard rolling friction), gravity,
  the Tavares model with Emax/E50 = 100 (beds), d_min = 1/20 of the top size, cs = 0, kappa = 1,
  progeny families with dummy spheres (Tavares et al. 2021, section 2.2-3.2). The time step is
  the engine's recommended step for the smallest sphere that can ever exist (d_min), so it never
  changes.

Two stages. (1) The bed settles under gravity on the anvil, inside the holder, with breakage off
(no damage while settling). (2) A new Simulation starts from the settled positions, velocities
and spins (tangential contact springs restart at zero) with the ball, breakage on and the holder
in place; the holder is removed at the first ball-bed contact by widening it to 1 km (an analytic
wall cannot be deleted from a running Simulation; a 1 km cylinder touches nothing). The run ends
when the ball has rebounded and left the bed for ``release_time``, or after ``max_time`` of
contact. Rebounds of the ball onto the bed are not simulated.

Outputs (SI, per case): broken mass (mass passing 4.75 mm: resolved progeny below 4.75 mm, dummy
spheres and unresolved fines), capture radius (largest radial distance from the ball's axis of an
original bed particle that broke), the product size distribution on a sqrt(2) sieve series (dummy
spheres and fines spread below their size by eq 11), time series of the ball and the particle
count, an energy book and every breakage event.
"""

import math
from typing import NamedTuple

import numpy as np

from ..engine import Guards, PhysicsSpec, Simulation, SimulationError
from ..models import Interaction, Material, MaterialTable, TavaresModel
from ..models.breakage import progeny_families, tavares, tavares_materials
from ..models.breakage.replacement import BREAKAGE_AT, TavaresReplacement
from ..models.breakage.replacement import product_passing as replacement_passing
from .base import TIME_STEP_PARAMS, Param, Scene, record_steps, register, step_policy
from .config_walls import scene_walls
from .driver import Case, Output, Series

G = 9.81
BROKEN_SIEVE = 4.75e-3  # m: "mass of material passing the initial narrow size" (4.75-6.3 mm)
# sqrt(2) test-sieve series [m], 6.3 mm down to 38 um (Fig. 23 of the paper reaches 0.1 mm)
SIEVES = np.array([6.3, 4.75, 3.35, 2.36, 1.7, 1.18, 0.85, 0.6, 0.425, 0.3, 0.212, 0.15, 0.106,
                   0.075, 0.053, 0.038]) * 1e-3
X_MIN = tavares.SIEVE_RATIO ** -tavares.STANDARD_CLASSES  # dummy size / parent size

# One compiled variant for the whole scene (and its tests).
SPEC = PhysicsSpec(dim=3, walls=True, gravity=True, rolling_friction=True)

PARAMS = (
    Param("material", "copper_ore", "bed material: any breakable one of materials_file"),
    Param("rings", 3, "rings of particles around the central one in each layer", "1", 0, 10),
    Param("layers", 1, "layers of particles (1 = monolayer; more are held by the holder)", "1", 1, 10),
    Param("particle_diameter", 5.5e-3, "bed particle diameter", "m", 0.0, lo_open=True),
    Param("spacing", 1.02, "centre distance of neighbours in a layer / particle diameter", "1", 1.0, 3.0),
    Param("impact_energy", 3.05, "kinetic energy of the ball at first contact, m v^2/2", "J", 0.0, 100.0,
          lo_open=True),
    Param("ball_diameter", 0.088, "steel ball diameter", "m", 0.0, lo_open=True),
    Param("ball_mass", 2.78, "steel ball mass (sets the ball's density)", "kg", 0.0, lo_open=True),
    Param("ball_gap", 2e-4, "initial gap between ball and bed top", "m", 0.0, lo_open=True),
    Param("particle_steel_rolling_friction", 0.01,
          "rolling friction particle-steel (Table 6: 0.01; the paper's sensitivity run: 0.33)", "1",
          0.0),
    Param("breakage_at", "first_reach", "when a particle breaks: first_reach (absorbed energy of the "
          "event reaches E) or end_of_loading (when the event ends, t10' from its whole energy)",
          choices=BREAKAGE_AT),
    Param("dummy_as", "spheres",
          "dummy class of the families: spheres (Tavares et al. 2021) or unresolved fines",
          choices=("spheres", "fines")),
    Param("d_min_ratio", 0.05,
          "global minimum progeny size / particle diameter (Tavares et al. 2021: 1/20)", "1",
          0.0, 0.21, lo_open=True),
    Param("holder_gap", 0.02, "clearance between holder and outer particles / particle diameter", "1", 0.0),
    Param("settle_time", 0.004, "settling time of the bed before the drop (breakage off)", "s", 0.0),
    Param("release_time", 2e-4, "end: time the rebounding ball has been clear of the bed", "s", 0.0,
          lo_open=True),
    Param("max_time", 0.02, "end at the latest this long after first contact", "s", 0.0, lo_open=True),
    Param("record_interval", 2e-5, "time-series cadence", "s", 0.0, lo_open=True),
    *TIME_STEP_PARAMS,
    Param("max_overlap", 1.5, "guard: overlap / smaller radius that stops the run (small unbreakable "
          "fragments nipped by the ball reach ~0.6-1)", "1", 0.0, 5.0, lo_open=True),
    Param("v_max", 1000.0, "guard: particle speed that stops the run (small fragments released from "
          "heavy compression are fast)", "m s-1", 0.0, lo_open=True),
    Param("materials_file", tavares_materials.MATERIALS_FILE, "Tavares materials and Table 6 contact "
          "parameters (docs/materials.md)"),
    Param("seed", 1, "seed of fracture energies, families and arrangements (replicates)", "1", 0),
)


def _check(values):
    if values["layers"] > 1 and values["rings"] < 1:
        raise ValueError("rings: a bed of several layers needs at least 1 ring")
    if values["record_interval"] > values["max_time"]:
        raise ValueError(f"record_interval: {values['record_interval']:g} s is longer than the "
                         f"impact (max_time); allowed (0, {values['max_time']:g}] s")
    # a bad materials file or material is refused before any job runs
    tavares_materials.check_material(values["materials_file"], values["material"])


# ---- geometry ---------------------------------------------------------------------------------
def hex_layer(rings, spacing):
    """Centres (n, 2) of a hexagonal monolayer: a central site and ``rings`` rings around it.

    n = 1 + 3 k (k + 1): 1, 7, 19, 37, 61 for k = 0..4; nearest neighbours ``spacing`` apart.
    """
    pts = [(q, r) for q in range(-rings, rings + 1) for r in range(-rings, rings + 1)
           if max(abs(q), abs(r), abs(q + r)) <= rings]
    pts.sort(key=lambda qr: (max(abs(qr[0]), abs(qr[1]), abs(qr[0] + qr[1])), qr))
    q, r = np.array(pts, dtype=float).T
    return np.column_stack([spacing * (q + 0.5 * r), spacing * r * math.sqrt(3.0) / 2.0])


def _inside_hexagon(xy, rings, spacing, tol=1e-9):
    """Points inside the hexagon spanned by the outer ring's corner sites."""
    R = rings * spacing
    corners = [(R * math.cos(a), R * math.sin(a)) for a in np.arange(6) * math.pi / 3]
    inside = np.ones(len(xy), dtype=bool)
    for k in range(6):
        (x0, y0), (x1, y1) = corners[k], corners[(k + 1) % 6]
        cross = (x1 - x0) * (xy[:, 1] - y0) - (y1 - y0) * (xy[:, 0] - x0)
        inside &= cross >= -tol * R
    return inside


def bed_positions(rings, layers, diameter, spacing):
    """Centres (n, 3) of the bed: layer A = the hexagonal monolayer on the anvil; layers B (odd)
    sit in the hollows of A inside the same hexagon (ABA... stacking), each a small gap above the
    height at which it would touch the layer below (it settles)."""
    s = spacing * diameter
    a = hex_layer(rings, s)
    shift = np.array([0.5 * s, 0.5 * s / math.sqrt(3.0)])
    big = hex_layer(rings + 1, s) + shift
    b = big[_inside_hexagon(big, rings, s)]
    dz = math.sqrt(max(diameter**2 - s**2 / 3.0, 0.0)) + 0.01 * diameter
    out = []
    for k in range(layers):
        xy = a if k % 2 == 0 else b
        out.append(np.column_stack([xy, np.full(len(xy), 0.5 * diameter + k * dz)]))
    return np.concatenate(out)


def ball_speed(energy, mass):
    """v = sqrt(2 E / m) [m/s]."""
    return math.sqrt(2.0 * energy / mass)


def ball_density(mass, diameter):
    return mass / (math.pi / 6.0 * diameter**3)


def sphere_mass(density, d):
    return density * math.pi / 6.0 * np.asarray(d, dtype=float) ** 3


# ---- materials ----------------------------------------------------------------------------------
def material_table(values, tav):
    contacts = tavares_materials.load_contacts(values["materials_file"])
    name, ore, steel = values["material"], tav[values["material"]], tav["steel"]

    def inter(key, **override):
        c = {**contacts[key], **override}
        return Interaction(restitution=c["restitution"], friction=c["static_friction"],
                           rolling_friction=c["rolling_friction"])

    mats = [Material(name, ore.density, ore.young, ore.poisson),
            Material("steel", ball_density(values["ball_mass"], values["ball_diameter"]),
                     steel.young, steel.poisson)]
    return MaterialTable(mats, {
        "*": inter("particle_particle"),
        (name, "steel"): inter("particle_steel",
                               rolling_friction=values["particle_steel_rolling_friction"]),
        ("steel", "steel"): inter("steel_steel"),
    }, "hertz_mindlin")


# ---- bookkeeping of progeny ---------------------------------------------------------------------
class _Tracker:
    """Wraps the replacement handler and keeps one row per breakage event. The per-particle
    bookkeeping (the original bed particle each one comes from, its generation, whether it is a
    dummy sphere and the t10' of the event that made it, for eq 11) are the simulation's tags,
    which the replacement hands on to the progeny."""

    def __init__(self, replace, mat):
        self.replace, self.mat = replace, mat
        self.event_rows = []  # a BedEvent per breakage event

    def __call__(self, sim):
        before = len(self.replace.events)
        ball_xy = sim.particles.x[0, :2].copy()
        self.replace(sim)
        parent = self.replace.last_parent_tags
        for ev, gen, origin in zip(self.replace.events[before:], parent["generation"],
                                   parent["origin"]):
            radial = float(np.hypot(*(ev.position[:2] - ball_xy)))
            self.event_rows.append(BedEvent(ev.time, *ev.position, radial, gen, origin,
                                            ev.parent_diameter, ev.specific_energy,
                                            ev.fracture_energy, ev.t10, ev.progeny, ev.fines_mass,
                                            sphere_mass(self.mat.density, ev.parent_diameter)))


class BedEvent(NamedTuple):
    """One breakage event of the bed (written as the event_<field> variables of the case file)."""

    time: float  # [s]
    x: float  # centre of the broken particle [m]
    y: float
    z: float
    radial: float  # horizontal distance of the broken particle from the ball's axis [m]
    generation: int  # 0: an original bed particle, 1: its progeny, ...
    origin: int  # index of the original bed particle it comes from
    parent_diameter: float  # [m]
    specific_energy: float  # absorbed, of the breaking event [J kg-1]
    fracture_energy: float  # (damaged) fracture energy it reached [J kg-1]
    t10: float  # t10' of the event [%]
    progeny: int  # progeny spheres, dummy spheres included
    fines_mass: float  # unresolved fines of the event [kg]
    parent_mass: float  # [kg]


def product_passing(sizes, masses, dummy, dummy_t10, t10_recorded, events, mat, sieves=SIEVES):
    """Mass [kg] passing each sieve: resolved spheres by size, resolved-unbreakable ones that
    recorded a breaking event by eq 13; dummy spheres and unresolved fines spread below their size
    by eq 11 (``tavares.fines_passing``: the family's eq 10 curve at their t10' below x_min)."""
    res = ~dummy
    passing = replacement_passing(sizes[res], masses[res], t10_recorded[res], mat, sieves)
    for d, m, t10 in zip(sizes[dummy], masses[dummy], dummy_t10[dummy]):
        # x relative to the parent: the dummy is x_min of its parent
        parent = d / X_MIN
        passing += m * tavares.fines_passing(t10, sieves / parent, mat)
    for ev in events:
        if ev.fines_mass > 0:
            passing += ev.fines_mass * tavares.fines_passing(ev.t10, sieves / ev.parent_diameter,
                                                             mat)
    return passing


# ---- the run ------------------------------------------------------------------------------------
class BedImpactCase(Case):
    """Settle the bed (breakage off), then drop the ball: fine chunks until the first contact
    (the holder of a multi-layer bed is taken away then), records every ``record_interval``;
    done once the ball has rebounded clear for ``release_time`` or after ``max_time``."""

    series = (Series("ball_z", "m", "height of the ball centre"),
              Series("ball_vz", "m s-1", "vertical velocity of the ball"),
              Series("ball_force", "N", "vertical force of bed and anvil on the ball"),
              Series("n_particles", "1", "bed particles and fragments (resolved spheres)"),
              Series("bed_kinetic_energy", "J", "kinetic energy (translation) of bed particles and fragments"),
              Series("ball_energy", "J", "kinetic + potential (z = 0) energy of the ball"),
              Series("broken_events", "1", "cumulative breakage events"),
              Series("max_fragment_speed", "m s-1", "largest speed of a bed particle or fragment"))
    outputs = (
        Output("sieve", ("sieve",), "m", "sieve aperture", coord=True),
        Output("event", ("event",), "1", "breakage event index", coord=True),
        # event_<field> for every field of a BedEvent
        Output("event_time", ("event",), "s", "time of the breakage event"),
        Output("event_x", ("event",), "m", "x of the broken particle"),
        Output("event_y", ("event",), "m", "y of the broken particle"),
        Output("event_z", ("event",), "m", "z of the broken particle"),
        Output("event_radial", ("event",), "m",
               "horizontal distance of the broken particle from the ball's axis"),
        Output("event_generation", ("event",), "1", "0 = an original bed particle, 1 = its progeny, ..."),
        Output("event_origin", ("event",), "1", "index of the original bed particle it comes from"),
        Output("event_parent_diameter", ("event",), "m", "diameter of the broken particle"),
        Output("event_specific_energy", ("event",), "J kg-1",
               "absorbed specific energy of the breaking event"),
        Output("event_fracture_energy", ("event",), "J kg-1", "(damaged) fracture energy it reached"),
        Output("event_t10", ("event",), "%", "t10' of the event (family grid value)"),
        Output("event_progeny", ("event",), "1", "progeny spheres (dummy spheres included)"),
        Output("event_fines_mass", ("event",), "kg", "unresolved fines of the event (dummy_as = fines)"),
        Output("event_parent_mass", ("event",), "kg", "mass of the broken particle"),
        Output("bed_mass", (), "kg", "initial bed mass (particles x sphere mass)"),
        Output("n_bed_particles", (), "1", "particles in the bed"),
        Output("broken_mass", (), "kg", "mass passing 4.75 mm after impact (broken mass)",
               "resolved spheres by size, dummies and fines by eq 11, unbreakable records by eq 13"),
        Output("broken_fraction", (), "1", "broken mass / bed mass"),
        Output("capture_radius", (), "m",
               "largest distance from the ball's axis of an original bed particle that broke"),
        Output("touched_radius", (), "m", "largest distance from the ball's axis of a particle the "
               "ball touched (recorded cadence)"),
        Output("broken_particles", (), "1", "original bed particles that broke"),
        Output("breakage_events", (), "1", "breakage events (all generations)"),
        Output("unbreakable_records", (), "1", "resolved-unbreakable particles that reached their "
               "fracture energy (eq 13 applied)"),
        Output("unbreakable_recorded_mass", (), "kg",
               "their mass, spread by eq 13 in the product distribution"),
        Output("fines_mass", (), "kg", "unresolved fines (dummy_as = fines)"),
        Output("dummy_mass", (), "kg", "mass of the dummy spheres (fines below x_min of their parent)"),
        Output("mass_balance_error", (), "kg", "resolved + fines - initial bed mass"),
        Output("impact_speed", (), "m s-1", "ball speed at first contact"),
        Output("ball_energy_initial", (), "J", "ball kinetic + potential energy at the start"),
        Output("ball_energy_final", (), "J", "ball kinetic + potential energy at the end"),
        Output("breakage_energy", (), "J", "absorbed energy of the breaking events (sum of Ek')",
               "specific energy x parent mass, summed over the events"),
        Output("settle_kinetic_energy", (), "J", "bed kinetic energy left after settling"),
        Output("contact_time", (), "s", "time from first contact to the end of the run"),
        Output("first_contact_time", (), "s", "time of the first ball-bed contact (holder removed)"),
        Output("passing", ("sieve",), "kg", "bed mass passing the sieve"),
        Output("passing_fraction", ("sieve",), "1", "cumulative fraction passing (incl. fines)"),
    )

    def __init__(self, values):
        super().__init__()
        self.values = values
        self.tav = tavares_materials.load_materials(values["materials_file"], truncation="bed")
        self.mat = self.tav[values["material"]]
        self.table = material_table(values, self.tav)
        d = values["particle_diameter"]
        self.r = r = 0.5 * d
        self.d_min = progeny_families.global_min_size(d, values["d_min_ratio"])
        self.v0 = ball_speed(values["impact_energy"], values["ball_mass"])
        self.x_bed = bed_positions(values["rings"], values["layers"], d, values["spacing"])
        self.n_bed = len(self.x_bed)
        self.walls = [dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="steel")]
        self.holder = values["layers"] > 1
        if self.holder:
            radius_h = float(np.hypot(self.x_bed[:, 0], self.x_bed[:, 1]).max()) + r \
                + values["holder_gap"] * d
            self.walls.append(dict(kind="cylinder_inner", point=(0, 0, 0), axis=(0, 0, 1),
                                   radius=radius_h, material="steel"))
        self.spec, self.walls = scene_walls(values, SPEC, self.walls)
        self.skin = 0.1 * d
        # The drop's step follows from the sizes, not the positions: it (dt above the limit) and
        # the record interval against it are checked on the unsettled bed, before the settling.
        still = np.zeros((self.n_bed, 3))
        record_steps(values, self._drop_simulation(self.x_bed, still, still)[0].dt)
        # stage 1: settle (breakage off: every fracture energy stays infinite)
        self.sim = self.settle = Simulation(self.spec, self.table, x=self.x_bed,
                                            radius=np.full(self.n_bed, r),
                                            material=values["material"], walls=self.walls,
                                            skin=self.skin, breakage=TavaresModel({}))
        self.settle_steps = int(round(values["settle_time"] / self.settle.dt))
        self.settle_left = self.settle_steps
        self.dropping = False
        self.t_contact = self.t_clear = None
        self.finished = False
        self.touched_radial = 0.0
        if self.settle_steps == 0:
            self._drop()

    def _drop_simulation(self, x_set, v_set, w_set):
        """The drop: the ball just above the bed at ``x_set``; (Simulation, ball centre)."""
        values, r = self.values, self.r
        name, mat = values["material"], self.mat
        Rb = 0.5 * values["ball_diameter"]
        top = float((x_set[:, 2] + r).max())
        gap = self.gap = values["ball_gap"]
        self.v_start = math.sqrt(max(self.v0**2 - 2.0 * G * gap, 0.0))
        x_ball = np.array([0.0, 0.0, top + gap + Rb])
        sim = Simulation(
            self.spec, self.table, x=np.vstack([x_ball, x_set]),
            radius=np.concatenate([[Rb], np.full(self.n_bed, r)]),
            material=["steel"] + [name] * self.n_bed,
            v=np.vstack([[0.0, 0.0, -self.v_start], v_set]), w=np.vstack([np.zeros(3), w_set]),
            walls=self.walls, skin=self.skin,
            step=step_policy(values, impact_speed=max(self.v0, 1.0),
                             smallest_radius=0.5 * self.d_min),
            guards=Guards(max_overlap=values["max_overlap"], v_max=values["v_max"]),
            breakage=TavaresModel({name: (mat.gamma, mat.e_min)}),
            # particle 0 is the ball (origin -1)
            tags={"origin": np.arange(self.n_bed + 1) - 1,
                  "generation": np.zeros(self.n_bed + 1, dtype=int),
                  "dummy": np.zeros(self.n_bed + 1, dtype=bool),
                  "event_t10": np.zeros(self.n_bed + 1)})
        return sim, x_ball

    def _drop(self):
        """Stage 2: the ball above the settled bed."""
        values, settle = self.values, self.settle
        name, mat = values["material"], self.mat
        p = settle.particles
        self.settle_ke = settle.kinetic_energy()
        sim, x_ball = self._drop_simulation(p.x.copy(), p.v.copy(), p.w.copy())
        self.sim = sim
        self.replace = TavaresReplacement({name: mat}, d_min=self.d_min, seed=values["seed"],
                                          dummy_as=values["dummy_as"],
                                          breakage_at=values["breakage_at"])
        self.replace.assign_fracture_energies(sim, np.arange(1, self.n_bed + 1))
        self.tracker = _Tracker(self.replace, mat)
        self.bed_mass0 = self.replace.resolved_mass(sim)
        self.m_ball = 1.0 / sim.particles.inv_mass[0]
        self.e_ball0 = 0.5 * self.m_ball * self.v_start**2 + self.m_ball * G * x_ball[2]
        self.record_steps = record_steps(values, sim.dt)
        self.probe = max(1, self.record_steps // 20)  # finer chunks until the first contact
        self.dropping = True
        self._observe()

    def _ball_contacts(self):
        q = self.sim.particles
        dist = np.linalg.norm(q.x[1:] - q.x[0], axis=1)
        return np.flatnonzero(dist < q.radius[1:] + q.radius[0]) + 1

    def _observe(self):
        s, m_ball = self.sim, self.m_ball
        q = s.particles
        m = s.masses()
        vb = q.v[0]
        self.record(s.time, ball_z=float(q.x[0, 2]), ball_vz=float(vb[2]),
                    ball_force=float(m_ball * (q.acc[0, 2] + G)), n_particles=s.n_particles - 1,
                    bed_kinetic_energy=float(0.5 * (m[1:] * (q.v[1:] ** 2).sum(1)).sum()),
                    ball_energy=0.5 * m_ball * float(vb @ vb) + m_ball * G * float(q.x[0, 2]),
                    broken_events=len(self.replace.events),
                    max_fragment_speed=float(np.linalg.norm(q.v[1:], axis=1).max()))
        hit = self._ball_contacts()
        if len(hit):
            rad = np.hypot(*(q.x[hit, :2] - q.x[0, :2]).T)
            self.touched_radial = max(self.touched_radial, float(rad.max()))

    def on_events(self, sim):
        self.tracker(sim)

    def chunk(self):
        if not self.dropping:
            return min(max(1, self.settle_steps // 4), self.settle_left)
        return self.probe if self.t_contact is None else self.record_steps

    def after_chunk(self):
        if not self.dropping:
            self.settle_left -= self.chunk()
            if self.settle_left == 0:
                self._drop()
            return
        sim, values = self.sim, self.values
        hit = self._ball_contacts()
        if self.t_contact is None:
            if len(hit):
                self.t_contact = sim.time
                if self.holder:
                    sim.disable_wall(1)
            elif sim.time > 10 * (self.gap / max(self.v_start, 1e-3)) + 0.01:
                raise SimulationError(
                    "bed_impact: the ball never reached the bed in the probes every "
                    f"record_interval / 20 = {self.probe * sim.dt:.3g} s; a smaller "
                    "record_interval probes finer")
            if sim.step % self.record_steps < self.probe:
                self._observe()
            return
        self._observe()
        rebounding = sim.particles.v[0, 2] > 0
        if len(hit) or not rebounding:
            self.t_clear = None
        elif self.t_clear is None:
            self.t_clear = sim.time
        if self.t_clear is not None and sim.time - self.t_clear >= values["release_time"]:
            self.finished = True
        if sim.time - self.t_contact >= values["max_time"]:
            self.finished = True

    def done(self):
        return self.finished

    def progress(self):
        if self.t_contact is None:
            return 0.0, "falling"
        return (min((self.sim.time - self.t_contact) / self.values["max_time"], 1.0),
                f"{self.sim.n_particles - 1} particles, {len(self.replace.events)} breakage events")

    def finish(self):
        sim, mat, replace, tracker = self.sim, self.mat, self.replace, self.tracker
        bed_mass0, n_bed, settle_ke, t_contact = self.bed_mass0, self.n_bed, self.settle_ke, self.t_contact
        v0, e_ball0 = self.v0, self.e_ball0
        touched_radial = [self.touched_radial]
        q = sim.particles
        bed = np.arange(1, sim.n_particles)
        sizes = 2.0 * q.radius[bed]
        masses = sim.masses()[bed]
        dummy = sim.tags["dummy"][bed]
        dummy_t10 = sim.tags["event_t10"][bed]
        events = tracker.event_rows
        fines = replace.fines_mass
        total = float(masses.sum() + fines)
        t10_recorded = sim.breakage.t10_recorded[bed]
        passing = product_passing(sizes, masses, dummy, dummy_t10, t10_recorded, events, mat)
        passing_total = product_passing(sizes, masses, dummy, dummy_t10, t10_recorded, events, mat,
                                        np.array([BROKEN_SIEVE]))[0]
        broken_mass = float(passing_total)
        gen0 = [ev for ev in events if ev.generation == 0]
        capture = max((ev.radial for ev in gen0), default=0.0)
        broken_originals = len({int(ev.origin) for ev in events})
        absorbed = float(sum(ev.specific_energy * ev.parent_mass for ev in events))
        data = {"sieve": SIEVES, "event": np.arange(len(events))}
        data.update({f"event_{name}": np.array([getattr(ev, name) for ev in events], dtype=float)
                     for name in BedEvent._fields})
        scalars = {
            "bed_mass": bed_mass0,
            "n_bed_particles": n_bed,
            "broken_mass": broken_mass,
            "broken_fraction": broken_mass / bed_mass0,
            "capture_radius": capture,
            "touched_radius": touched_radial[0],
            "broken_particles": broken_originals,
            "breakage_events": len(events),
            "unbreakable_records": len(replace.records),
            "unbreakable_recorded_mass": float(masses[np.isfinite(t10_recorded)].sum()),
            "fines_mass": fines,
            "dummy_mass": float(masses[dummy].sum()),
            "mass_balance_error": total - bed_mass0,
            "impact_speed": v0,
            "ball_energy_initial": e_ball0,
            "ball_energy_final": self.recorded("ball_energy")[-1],
            "breakage_energy": absorbed,
            "settle_kinetic_energy": settle_ke,
            "contact_time": sim.time - t_contact,
            "first_contact_time": t_contact,
        }
        data.update({key: float(value) for key, value in scalars.items()})
        data["passing"] = passing
        data["passing_fraction"] = passing / bed_mass0
        return data

    def provenance(self):
        values = self.values
        return {"settle_dt": self.settle.dt, "settle_steps": self.settle_steps,
                "impact_steps": self.sim.step, "d_min": self.d_min,
                "ball_density": ball_density(values["ball_mass"], values["ball_diameter"]),
                "holder_radius": float(self.walls[1]["radius"]) if self.holder else 0.0}


register(Scene("bed_impact", "steel ball dropped on a particle bed, Tavares breakage "
               "(Tavares et al. 2021)", PARAMS, BedImpactCase, (_check,),
               wall_materials=lambda values: (values["material"], "steel")))
