"""Scene ``ballmill3d``: a 3D ball mill whose shell is the user's STL liner (or a cylinder), with
steel balls and ore that breaks by the Tavares model (Tavares et al. 2021).

- **Drum.** The shell is a mesh wall read from ``liner`` (default the shipped
  ``examples/meshes/ballmill_liner.stl``: 0.2 m diameter, 0.05 m long, 8 lifters), its axis y from
  0 to ``drum_length``, or with ``liner: ""`` the analytic ``cylinder_inner`` of ``drum_diameter``.
  The end walls are planes across the axis turning about their normals with the shell
  (docs/walls.md), so that charge resting on them moves with the drum and their work is drive
  work. The liner is refused (one line naming the file) when open or inverted (engine.mesh_io),
  when it does not enclose the axis or its shell is not at ``drum_diameter`` / 2, and when the
  largest ball is wider than the free chord between its lifters (ballmill3d_charge.lifter_gap).
- **Speed.** omega = n_over_nc omega_c, omega_c = sqrt(2 g / (D - d_ball)) (a ball of the mean
  diameter touching the shell is held at the top; Napier-Munn et al. 1996, Wills & Napier-Munn
  2006), the liner's lifters not counted in D; as ``ballmill2d`` subtracts the grain radius.
- **Charge.** ``filling`` is the bulk volume of the charge over the drum's volume pi D^2 L / 4, the
  bulk taken at solid fraction 0.6; its solid volume is split between balls and ore by the mass
  ratio ``ball_ore_ratio``. Sizes are uniform by number between each class's min and max
  diameter. Both are poured (engine.Pour) at constant rates over ``pour_time`` into the square
  inscribed in the lifter tips' circle, then left ``settle_time`` with the drum at rest. A filling
  whose bulk volume exceeds the hollow inside the liner is refused.
- **Physics.** Hertz-Mindlin with EDEM's standard rolling friction, the materials file's elastic
  constants (the ore's Young's modulus as measured, not softened: the Tavares energies depend on
  it) and Table 6 contact parameters (Tavares et al. 2021): ore-ore particle_particle, ore-ball and
  ore-liner particle_steel, ball-ball and ball-liner steel_steel. The engine's energy audit is on.
- **Breakage** (``breakage: true``). From the moment the drum starts, every ore particle has a
  fracture energy (eqs 1-3); every ball-ore, ore-ore and ore-liner (and end-wall) contact loads
  it (eq 4), events that do not break it damage it (eqs 5-6), and a particle that breaks is
  replaced by a progeny family (TavaresReplacement, ``first_reach``). d_min = ``d_min_ratio`` x
  the top ore size (1/20 as Tavares et al. 2021); what a family puts below it is kept as fines
  mass, spread below the parent by eq 11 in the product size distribution (as bed_impact with
  dummy_as = fines); resolved particles too small to break record their first breaking event's
  t10' (eq 13). The time step is the engine's recommended step for the feed's smallest ore and the
  particles present: it shrinks when a replacement brings smaller progeny
  (Simulation.add_particles), so a mill in which nothing has broken yet steps as fast as one
  without breakage. Records keep their interval in time (the steps per record follow dt) and the
  run ends after a fixed number of records.
- **Stages.** Pour (no fracture energies yet), settle, spin-up from rest to omega at once, and the
  milling. Time in the series and PSD records counts from the drum's start. The first
  ``transient_revolutions`` are discarded; the steady interval of the power starts at the later
  of their end and the MSER-5 truncation point of the recorded power (White 1997; as
  stirred_mill), and the power's half-width is the Student-t interval of ``ci_blocks`` block
  means over it (util.stats).
- **Observables.** Drive torque and power of shell and end walls (P = T omega exactly: a turning
  wall's torque is taken at the point its surface speed is). Toe and shoulder: the time mean of
  the solid volume in the charge's outer band (one largest-ball diameter deep inside the shell)
  per 5-degree sector; the charge's arc on the shell is the run of sectors at >= 0.5 of the
  densest one, its lower edge the toe, its upper edge the shoulder (an operational reading of the
  charge profiles of Cleary 1998 and Mishra & Rajamani 1992, with our threshold). Selection
  function per sqrt(2) size class: breakage events of parents in the class per second over the
  mean number of particles in it (Austin, Klimpel & Luckie 1984). Energy balance over the
  measured interval: drive work = audited dissipation + energy removed at replacements + change
  of kinetic, potential and (Hertz normal) elastic energy.

Papers: Tavares, Rodriguez, Sousani, Padros & Ooi (2021), Powder Technol. 392; Cleary (1998),
Minerals Eng. 11:1061; Mishra & Rajamani (1992), Appl. Math. Modelling 16:598; Austin, Klimpel &
Luckie (1984), Process Engineering of Size Reduction; Napier-Munn, Morrell, Morrison & Kojovic
(1996), Mineral Comminution Circuits; White (1997), MSER.
"""

import math

import numpy as np

from ..engine import Guards, PhysicsSpec, Pour, Simulation
from ..engine.spectra import SpectraBins
from ..models import TavaresModel
from ..models.breakage import progeny_families, tavares, tavares_materials
from ..models.breakage.replacement import TavaresReplacement
from ..models.breakage.tavares_log import TavaresLogModel
from ..util.stats import block_mean_ci, mser5
from . import ballmill3d_charge as charge
from . import ballmill3d_observables as obs
from . import ballmill3d_rates as rates
from .base import (
    TIME_STEP_PARAMS,
    DriveMark,
    Param,
    Scene,
    check_particle_memory,
    register,
    step_policy,
)
from .bed_impact import product_passing
from .config_walls import scene_walls
from .driver import Case, Output, Series

G = charge.G
LINER = "examples/meshes/ballmill_liner.stl"

PARAMS = (
    Param("n_over_nc", 0.75, "rotation speed as a fraction of the critical speed", "1", 0.0, 3.0,
          lo_open=True),
    Param("filling", 0.3, "bulk volume of the charge (at solid fraction 0.6) / drum volume", "1",
          0.0, 1.0, True, True),
    Param("ball_ore_ratio", 1.0, "mass of the balls / mass of the ore", "1", 0.0, lo_open=True),
    Param("drum_diameter", 0.2, "inner diameter of the shell (the liner's, without lifters)", "m",
          0.0, lo_open=True),
    Param("drum_length", 0.05, "drum length along its horizontal y axis", "m", 0.0, lo_open=True),
    Param("liner", LINER, "STL of the shell as a closed solid around the y axis from 0 to "
          "drum_length, turning with the drum; \"\" = the analytic cylinder of drum_diameter"),
    Param("liner_scale", 1.0, "factor from the liner STL's units to m (1e-3: mm)", "1", 0.0,
          lo_open=True),
    Param("ore_material", "copper_ore", "ore: any breakable material of materials_file"),
    Param("materials_file", tavares_materials.MATERIALS_FILE,
          "Tavares materials and Table 6 contact parameters (docs/materials.md)"),
    Param("breakage", True, "Tavares breakage of the ore on/off"),
    Param("stress_log", False, "log every stressing event of the ore and predict the breakage "
          "per size class from it (eqs 1-6) beside the counted (needs breakage; its own compiled "
          "loop)"),
    Param("spectra", True, "record collision energy spectra per contact type (engine.spectra)"),
    Param("spectra_min_energy", 1e-9, "lowest edge of the spectra's log-spaced energy bins", "J",
          0.0, lo_open=True),
    Param("spectra_max_energy", 10.0, "highest edge of the spectra's energy bins", "J", 0.0,
          lo_open=True),
    Param("spectra_bins", 40, "energy bins of the spectra (besides under- and overflow)", "1", 1),
    Param("stiffness_scale", 1.0, "Young's moduli of ore and steel x this factor (1: the materials "
          "file's; < 1 softens the contacts for a larger step, the usual DEM mill practice for "
          "power and charge motion, but it raises the loading work of slow, weight-borne "
          "contacts: docs/ballmill3d.md)", "1", 0.0, 1.0, lo_open=True),
    Param("ball_diameter_min", 0.025, "smallest steel ball", "m", 0.0, lo_open=True),
    Param("ball_diameter_max", 0.025, "largest steel ball", "m", 0.0, lo_open=True),
    Param("ore_diameter_min", 0.005, "smallest ore particle of the feed", "m", 0.0, lo_open=True),
    Param("ore_diameter_max", 0.010, "largest ore particle of the feed", "m", 0.0, lo_open=True),
    Param("d_min_ratio", 0.05, "smallest resolved progeny / largest ore size (Tavares et al. "
          "2021: 1/20)", "1", 0.0, 0.21, lo_open=True),
    Param("pour_time", 0.2, "time over which the charge is poured", "s", 0.0, lo_open=True),
    Param("settle_time", 0.2, "time the poured charge settles before the drum starts", "s", 0.0),
    Param("revolutions", 3.0, "revolutions of the drum from its start", "1", 0.0, lo_open=True),
    Param("transient_revolutions", 1.0, "first revolutions left out of the statistics", "1", 0.0),
    Param("records_per_revolution", 36, "records (series, PSD, charge profile) per revolution",
          "1", 4),
    Param("ci_blocks", 5, "blocks of the power's and rates' confidence intervals", "1", 2),
    Param("skin", 5e-4, "Verlet skin", "m", 0.0, lo_open=True),
    Param("max_overlap", 1.5, "guard: overlap / smaller radius that stops the run", "1", 0.0, 5.0,
          lo_open=True),
    *TIME_STEP_PARAMS,
    Param("seed", 1, "seed of the pour, fracture energies and progeny", "1", 0),
)


def _check(values):
    charge.check(values)
    mats = tavares_materials.load_materials(values["materials_file"])
    counts = charge.charge_counts(values, mats[values["ore_material"]].density,
                                  mats[tavares_materials.DEVICE_MATERIAL].density)
    check_particle_memory("filling", counts.balls + counts.ore)


def physics_spec(mesh, spectra):
    """The one compiled variant of the scene per shell kind and spectra on/off (breakage adds
    the model's hooks)."""
    return PhysicsSpec(dim=3, walls=True, gravity=True, rolling_friction=True, mesh_walls=mesh,
                       energy_audit=True, collision_spectra=spectra)


def _spectra_on(values):
    return values["spectra"]


def _log_on(values):
    return values["breakage"] and values["stress_log"]


# breakage predicted from the stress log against the counted (ballmill3d_rates)
RATE_OUTPUTS = (
    Output("breakage_events_predicted", ("size_class",), "1", "breakage events of particles in "
           "the class over the measured interval expected from their logged stressing events",
           "sum over particles of ln S(start) - ln S(end), S the survival of eqs 1-3, 5-6",
           when=_log_on),
    Output("breakage_events_counted", ("size_class",), "1", "breakage events of parents in the "
           "class over the measured interval", when=_log_on),
    Output("breakage_prediction_z", (), "1", "(counted - predicted) / sqrt(predicted), all "
           "classes", when=_log_on),
    Output("breakage_prediction_p_value", (), "1", "two-sided p-value of that z (normal law)",
           when=_log_on),
)


# collision energy spectra over the measured interval (engine.spectra; docs/ballmill3d.md)
SPECTRA_OUTPUTS = (
    Output("contact_type", ("contact_type",), "1", "contact type (liner: shell and end walls)",
           coord=True, when=_spectra_on),
    Output("energy_edge", ("energy_edge",), "J", "edges of the log-spaced energy bins",
           coord=True, when=_spectra_on),
    Output("energy_bin", ("energy_bin",), "J", "geometric centre of the energy bin", coord=True,
           when=_spectra_on),
    Output("impact_rate_normal", ("contact_type", "energy_bin"), "s-1", "collisions per second "
           "by the normal energy each dissipated (damping), per bin", when=_spectra_on),
    Output("impact_rate_tangential", ("contact_type", "energy_bin"), "s-1", "collisions per "
           "second by the tangential energy each dissipated (friction, tangential damping; "
           "rolling friction is booked per particle), per bin", when=_spectra_on),
    Output("collision_rate", ("contact_type",), "s-1", "collisions per second (every energy)",
           when=_spectra_on),
    Output("collision_rate_below_range", ("contact_type",), "s-1", "collisions per second whose "
           "normal energy lies below spectra_min_energy", when=_spectra_on),
    Output("collision_energy_normal", ("contact_type",), "W", "normal energy dissipated per "
           "second in the collisions that ended", when=_spectra_on),
    Output("collision_energy_tangential", ("contact_type",), "W", "tangential energy dissipated "
           "per second in the collisions that ended", when=_spectra_on),
    Output("spectra_audit_error", (), "1", "(collision energies + change of the open contacts' "
           "- audited contact dissipation) / audited, measured interval", when=_spectra_on),
)


class BallMill3DCase(Case):
    """Pour, settle, then the drum turns for ``revolutions``: records every revolution /
    records_per_revolution (series, PSD, class counts, the charge profile after the transient)."""

    # the contract's scalars power, torque and breakage_events hold the names: their series take
    # the suffix _series (a netCDF name is one variable)
    series = (Series("power_series", "W", "power the drive supplies (shell + end walls), record-interval "
                     "mean"),
              Series("torque_series", "N m", "torque the drive supplies about the axis, record-interval "
                     "mean"),
              Series("kinetic_energy", "J", "kinetic energy of balls and ore"),
              Series("n_particles", "1", "particles (balls and resolved ore)"),
              Series("breakage_events_series", "1", "cumulative breakage events"))
    time_long_name = "time since the drum started (end of the record interval)"
    outputs = (
        Output("size_class", ("size_class",), "m", "lower edge of the sqrt(2) ore size class "
               "(descending; the top class is [size_class[0], ore_diameter_max])", coord=True),
        Output("sieve", ("sieve",), "m", "sieve aperture", coord=True),
        Output("record_time", ("record_time",), "s", "time of the PSD record since the drum "
               "started", coord=True),
        *SPECTRA_OUTPUTS,
        *RATE_OUTPUTS,
        Output("power", (), "W", "mean drive power (shell + end walls), steady interval",
               "interval-mean power records after max(transient, MSER-5 start)"),
        Output("power_half_width", (), "W", "95 % half-width of the mean drive power",
               "Student t over ci_blocks block means"),
        Output("torque", (), "N m", "mean drive torque about the axis (+y, the rotation's sense), "
               "steady interval"),
        Output("critical_speed", (), "rad s-1", "critical speed sqrt(2 g / (D - d_ball)), d_ball "
               "the mean ball diameter"),
        Output("omega", (), "rad s-1", "drum angular velocity about +y"),
        Output("toe_angle", (), "rad", "charge toe: angle from the vertical below the axis, "
               "positive in the direction of rotation", "lower edge of the arc where the outer "
               "band's time-mean solid volume per sector reaches 0.5 of its largest"),
        Output("shoulder_angle", (), "rad", "charge shoulder: angle from the vertical below the "
               "axis, positive in the direction of rotation", "upper edge of that arc"),
        Output("charge_mass", (), "kg", "balls + ore at the drum's start"),
        Output("ball_mass", (), "kg", "mass of the balls"),
        Output("ore_mass_initial", (), "kg", "ore mass at the drum's start"),
        Output("fines_mass", (), "kg", "unresolved fines (below d_min) at the end"),
        Output("breakage_events", (), "1", "breakage events of the run"),
        Output("energy_balance_error", (), "1", "(drive work - dissipation - change of kinetic + "
               "potential + elastic energy) / drive work, measured interval",
               "dissipation: the engine's audit plus the energy removed at replacements"),
        Output("simulated_time", (), "s", "simulated time of the run (pour and settling "
               "included)"),
        Output("breakage_rate", ("size_class",), "s-1", "selection function: breakage events of "
               "parents in the class per second / mean number of particles in the class",
               "over the interval after the transient; NaN for an empty class"),
        Output("breakage_rate_half_width", ("size_class",), "s-1", "95 % half-width of the "
               "breakage rate", "Student t over ci_blocks block rates"),
        Output("passing_fraction", ("record_time", "sieve"), "1", "cumulative ore mass fraction "
               "passing the sieve (fines by eq 11, recorded unbreakables by eq 13)"),
    )

    def __init__(self, values):
        super().__init__()
        self.v = v = values
        self.tav = tavares_materials.load_materials(v["materials_file"], truncation="bed")
        self.ore_name = ore = v["ore_material"]
        self.mat = self.tav[ore]
        table = charge.material_table(v, self.tav)
        steel = tavares_materials.DEVICE_MATERIAL
        counts = charge.charge_counts(v, self.mat.density, self.tav[steel].density)
        D, L = v["drum_diameter"], v["drum_length"]
        inner = charge.probe_liner(v).tip_radius if v["liner"] else 0.5 * D
        self.omega_c = charge.critical_speed(D, 0.5 * (v["ball_diameter_min"]
                                                       + v["ball_diameter_max"]))
        self.omega = v["n_over_nc"] * self.omega_c
        self.d_min = progeny_families.global_min_size(v["ore_diameter_max"], v["d_min_ratio"])
        half = 0.999 * inner / math.sqrt(2.0)  # the pouring box inscribed in the lifter tips
        box = dict(lo=(-half, 0.0, -half), hi=(half, L, half))
        self.pours = [Pour(**box, count=counts.balls, rate=counts.balls / v["pour_time"],
                           material=steel, seed=v["seed"],
                           radius_range=(0.5 * v["ball_diameter_min"], 0.5 * v["ball_diameter_max"])),
                      Pour(**box, count=counts.ore, rate=counts.ore / v["pour_time"], material=ore,
                           seed=v["seed"] + 1,
                           radius_range=(0.5 * v["ore_diameter_min"], 0.5 * v["ore_diameter_max"]))]
        x, r = self.pours[0].first()
        impact = max(1.0, self.omega * 0.5 * D + math.sqrt(2 * G * D))
        # the walls of the config (scenes/config_walls.py) come after the drum's own 3
        spec, walls = scene_walls(v, physics_spec(bool(v["liner"]), v["spectra"]), charge.walls(v))
        self.sim = Simulation(
            spec, table, x=x, radius=r, material=steel, walls=walls, gravity=(0.0, 0.0, -G),
            skin=v["skin"],
            # the feed's smallest ore sets dt from the start (the pour adds it later); smaller
            # progeny shrink it when they appear
            step=step_policy(v, impact_speed=impact, smallest_radius=0.5 * v["ore_diameter_min"]),
            guards=Guards(max_overlap=v["max_overlap"]),
            spectra=SpectraBins(v["spectra_min_energy"], v["spectra_max_energy"],
                                v["spectra_bins"]) if v["spectra"] else None,
            breakage=(TavaresLogModel if v["stress_log"] else TavaresModel)(
                {ore: (self.mat.gamma, self.mat.e_min)}) if v["breakage"] else None)
        self.replace = TavaresReplacement({ore: self.mat}, d_min=self.d_min, seed=v["seed"],
                                          dummy_as="fines") if v["breakage"] else None
        self.shell_radius = 0.5 * D
        self.band = obs.BAND_WIDTH * v["ball_diameter_max"]
        self.classes = obs.size_classes(v["ore_diameter_max"], self.d_min)
        self.sieves = obs.sieves(v["ore_diameter_max"], self.d_min)
        self.fines_passing = np.zeros(len(self.sieves))
        self.period = 2 * math.pi / self.omega
        self.record_interval = self.period / v["records_per_revolution"]
        self.pour_steps = max(1, int(round(v["pour_time"] / 40 / self.sim.dt)))
        self.stage, self.settle_end = "pour", None
        # the poured particles make room by falling out of the pouring box
        self.pour_deadline = 3 * v["pour_time"] + 2 * math.sqrt(2 * D / G)
        self.removed = 0.0  # energy taken out at replacements [J]
        self.profile = np.zeros(obs.ANGLE_BINS)
        self.class_counts, self.passing = [], []
        self.event_times = []
        self.book = None  # the stress log's books (ballmill3d_rates), with stress_log

    # ---- stages --------------------------------------------------------------------------------
    def chunk(self):
        return self.pour_steps if self.stage != "mill" else self.record_steps()

    def record_left(self):
        """Simulated time to the next record [s]."""
        return self.record_interval - (self.sim.time - self.last.time)

    def record_steps(self):
        """Steps to the next record at today's dt: a record's steps, or the rest of them when
        progeny smaller than any particle before them shrank dt within its chunk."""
        return max(1, int(round(self.record_left() / self.sim.dt)))

    def after_chunk(self):
        sim, v = self.sim, self.v
        if self.stage == "pour":
            for pour in self.pours:
                pour.fill(sim)
            if all(p.done for p in self.pours):
                self.stage, self.settle_end = "settle", sim.time + v["settle_time"]
            elif sim.time > self.pour_deadline:
                left = sum(p.count - p.inserted for p in self.pours)
                raise ValueError(f"filling: {left} particles of the charge found no room in the "
                                 f"drum within {self.pour_deadline:.3g} s (3 x pour_time + two "
                                 "falls across the drum); lower filling or pour for longer")
        elif self.stage == "settle":
            if sim.time >= self.settle_end - 1e-12:
                self._start_drum()
        elif self.record_left() <= 0.5 * sim.dt * (1 + 1e-9):
            self._record()
            if self.window is None and self.mill_time() >= self.transient_end - 1e-12:
                self._open_window()
            if self.window is not None:
                p = sim.particles
                self.profile += obs.band_profile(p.x[sim.free], p.radius[sim.free],
                                                 self.shell_radius, self.band)

    def _start_drum(self):
        sim, v = self.sim, self.v
        charge.set_drum_speed(sim, self.omega)
        self.t_mill = sim.time
        self.stage = "mill"
        ore = self._ore()
        masses = sim.masses()
        self.ore_mass0 = float(masses[ore].sum())
        self.ball_mass = float(masses[sim.free].sum()) - self.ore_mass0
        if self.replace is not None:
            self.replace.assign_fracture_energies(sim, np.flatnonzero(ore))
            if v["stress_log"]:  # every ore particle is fresh from here on
                sim.breakage.take_stress_log()
                self.book = rates.StressBook(self.mat, sim.material_index(self.ore_name),
                                             self.d_min)
                self.book.register(sim)
        self.transient_end = v["transient_revolutions"] * self.period
        self.last = DriveMark(*obs.drive_state(sim), sim.time)
        self.total_records = int(round(v["revolutions"] * self.period / sim.dt
                                       / self.record_steps()))
        self.records_done = 0
        self.window = None
        if self.transient_end <= 0:
            self._open_window()
        self._psd_record()

    def _open_window(self):
        """The start of the measured interval: energy book and spectra."""
        self.window = obs.energy_state(self.sim, self.removed)
        self.spectra_start = obs.spectra_state(self.sim) if self.v["spectra"] else None
        self.t_window = self.mill_time()
        if self.book is not None:
            self.book.open(self.sim)

    def mill_time(self):
        return self.sim.time - self.t_mill

    def _ore(self):
        p = self.sim.particles
        return (p.material == self.sim.material_index(self.ore_name)) & (p.body < 0)

    def _record(self):
        sim = self.sim
        impulse, work = obs.drive_state(sim)
        span = sim.time - self.last.time
        self.record(self.mill_time(), power_series=(work - self.last.work) / span,
                    torque_series=(impulse - self.last.angular_impulse) / span,
                    kinetic_energy=sim.kinetic_energy(), n_particles=sim.n_particles,
                    breakage_events_series=len(self.replace.events) if self.replace else 0)
        self.last = DriveMark(impulse, work, sim.time)
        self.records_done += 1
        self._psd_record()

    def _psd_record(self):
        """Class counts and the product's passing mass at this time."""
        sim = self.sim
        ore = self._ore()
        d = 2.0 * sim.particles.radius[ore]
        self.class_counts.append(obs.class_counts(d, self.classes))
        t10 = sim.breakage.t10_recorded[ore] if sim.breakage is not None else np.full(len(d), np.nan)
        resolved = product_passing(d, sim.masses()[ore], np.zeros(len(d), bool), np.zeros(len(d)),
                                   t10, (), self.mat, self.sieves)
        self.passing.append((self.mill_time(), resolved + self.fines_passing))

    def on_events(self, sim):
        """Replace the broken particles; book the energy the replacement removes and the fines'
        eq 11 spread."""
        rows = sim.pop_events()  # (with stress_log, a stop may only have drained the log)
        if self.book is not None:
            self.book.add(sim.breakage.take_stress_log())
        if not rows:
            return
        before = len(self.replace.events)
        energy = sim.kinetic_energy() + obs.elastic_energy(sim)
        self.replace(sim, rows)
        if self.book is not None:
            self.book.register(sim)
        self.removed += energy - sim.kinetic_energy() - obs.elastic_energy(sim)
        for ev in self.replace.events[before:]:
            self.event_times.append(sim.time - self.t_mill)
            if ev.fines_mass > 0:
                self.fines_passing += ev.fines_mass * tavares.fines_passing(
                    ev.t10, self.sieves / ev.parent_diameter, self.mat)

    def done(self):
        return self.stage == "mill" and self.records_done >= self.total_records

    def progress(self):
        if self.stage != "mill":
            return 0.0, self.stage
        return (self.records_done / self.total_records,
                f"{self.mill_time() / self.period:.2f} rev, "
                f"{len(self.replace.events) if self.replace else 0} breakage events")

    # ---- summaries -----------------------------------------------------------------------------
    def finish(self):
        sim, v = self.sim, self.v
        t = self.recorded_times()
        power, torque = self.recorded("power_series"), self.recorded("torque_series")
        after = t > self.transient_end + 1e-12
        k0 = mser5(power[after])
        start = max(self.transient_end, float(t[after][k0] - self.period / v["records_per_revolution"])
                    if k0 > 0 else self.transient_end)
        steady = t > start + 1e-12
        p_mean, p_half = block_mean_ci(power[steady], v["ci_blocks"])
        end = obs.energy_state(sim, self.removed)
        toe, shoulder = obs.toe_shoulder(self.profile)
        events = self.replace.events if self.replace else []
        psd_t = np.array([row[0] for row in self.passing])
        rate, half = obs.selection_function(
            self.event_times, [ev.parent_diameter for ev in events], self.classes,
            self.transient_end, self.mill_time(), psd_t, np.array(self.class_counts),
            v["ci_blocks"])
        predicted = {}
        if self.book is not None:
            self.book.close(sim)
            pred, counted, z, p_value = rates.compare(
                self.book, self.event_times, [ev.parent_diameter for ev in events], self.t_window,
                self.classes)
            predicted = dict(breakage_events_predicted=pred, breakage_events_counted=counted,
                             breakage_prediction_z=z, breakage_prediction_p_value=p_value)
        spectra = {}
        if v["spectra"]:
            spectra = obs.spectra_outputs(self.spectra_start, obs.spectra_state(sim),
                                          sim.material_index(tavares_materials.DEVICE_MATERIAL),
                                          sim.material_index(self.ore_name))
        return {
            **spectra, **predicted,
            "size_class": self.classes, "sieve": self.sieves, "record_time": psd_t,
            "power": p_mean, "power_half_width": p_half,
            "torque": float(torque[steady].mean()),
            "critical_speed": self.omega_c, "omega": self.omega,
            "toe_angle": toe, "shoulder_angle": shoulder,
            "charge_mass": self.ball_mass + self.ore_mass0, "ball_mass": self.ball_mass,
            "ore_mass_initial": self.ore_mass0,
            "fines_mass": self.replace.fines_mass if self.replace else 0.0,
            "breakage_events": len(events),
            "energy_balance_error": obs.energy_balance_error(self.window, end),
            "simulated_time": sim.time,
            "breakage_rate": rate, "breakage_rate_half_width": half,
            "passing_fraction": np.array([row[1] for row in self.passing]) / self.ore_mass0,
        }

    def provenance(self):
        return {"d_min": self.d_min, "drum_start_time_s": getattr(self, "t_mill", math.nan),
                "list_rebuilds": int(self.sim.counters[0]),
                "steps_per_revolution": self.period / self.sim.dt}


register(Scene("ballmill3d", "3D ball mill with an STL liner (or cylinder), steel balls and ore "
               "breaking by the Tavares model: power, toe and shoulder, selection function, "
               "product size distribution (Tavares et al. 2021)", PARAMS, BallMill3DCase,
               (_check,), wall_materials=lambda values: (values["ore_material"],
                                                         tavares_materials.DEVICE_MATERIAL)))
