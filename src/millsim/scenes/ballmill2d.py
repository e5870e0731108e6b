"""Scene ``ballmill2d``: dry autogenous comminution in a rotating 2D drum with lifters
(Buchholtz et al. 2000).

Buchholtz, Freund & Poeschel, Eur. Phys. J. B 16, 169 (2000), restated in
``shared/reference/ballmill.md``. The paper's cgs constants are converted here, at the edge:
Y = 8e6 g s^-2 = 8e3 N/m, gamma_N = 800 1/s, gamma_T = 3000 1/s, mu = 0.5.

Geometry: the drum wall is a ring of rigid disks of random radii (roughness) whose inner surfaces
touch the circle of radius ``drum_radius``, plus 16 lifter bars of rigid disks; all of it rotates
clockwise at n = n_over_nc * n_c, n_c = sqrt(g / R_eff) / (2 pi) with R_eff = drum_radius -
grain_radius (the centre of a raw grain touching the wall). Disks are 2D with a thickness (masses
rho pi R^2 L); the paper's mass convention is not stated, so L = 1 cm is an assumption.

With ``fragmentation`` on: Weibull fracture per contact event at its peak force (see
:mod:`millsim.models.breakage.weibull`), two-disk split, twin relief until first separation, fragments
below the sieve radius leave as dust, and a raw grain re-enters whenever the dust mass reaches its
mass (continuous operation at constant filling). With it off (the force-chain study of section 5)
no breakage code is compiled and no breakage output is written; force chains are analysed instead.
"""

import math
from dataclasses import replace

import numpy as np

from ..engine import BYTES_PER_PARTICLE, Guards, PhysicsSpec, Simulation
from ..models import Interaction, Material, MaterialTable, WeibullModel
from ..models.breakage.weibull import Fracture, WeibullSplit
from ..util.memory import RECORD_VALUE_BYTES, check_memory
from ..util.stats import steady_rate
from .base import (
    TIME_STEP_PARAMS,
    DriveMark,
    Param,
    Scene,
    check_particle_memory,
    record_steps,
    register,
    step_policy,
)
from .driver import Case, Output, Series
from .force_chains import chain_statistics, find_chains

G = 9.81
RANDOM_PACKING_2D = 0.82  # area fraction of a random 2D disk packing (filling -> solid area)

PARAMS = (
    Param("n_over_nc", 1.0, "rotation speed as a fraction of the critical speed", "1", 0.0, 3.0, lo_open=True),
    Param("drum_radius", 0.05, "radius of the circle the wall disks' inner surfaces touch", "m", 0.0, lo_open=True),
    Param("filling", 0.4, "charge volume / drum volume (bulk, at random 2D packing)", "1", 0.0, 1.0, True, True),
    Param("n_grains", 0, "number of grains; 0 = from filling", "1", 0),
    Param("grain_radius", 2.5e-3, "raw grain radius (mean)", "m", 0.0, lo_open=True),
    Param("grain_radius_spread", 0.1, "raw radii uniform in R (1 -/+ spread)", "1", 0.0, 0.9),
    Param("sieve_radius", 0.6e-3, "fragments smaller than this leave as dust", "m", 0.0, lo_open=True),
    Param("wall_radius", 1.25e-3, "mean radius of the wall disks", "m", 0.0, lo_open=True),
    Param("lifters", 16, "number of lifter bars", "1", 0),
    Param("lifter_height", 5e-3, "radial height of a lifter bar", "m", 0.0),
    Param("density", 2000.0, "grain density (2 g/cm3)", "kg m-3", 0.0, lo_open=True),
    Param("thickness", 0.01, "disk thickness for masses (1 cm, assumed)", "m", 0.0, lo_open=True),
    Param("stiffness", 8e3, "Y, elastic constant (8e6 g s-2)", "N m-1", 0.0, lo_open=True),
    Param("gamma_n", 800.0, "normal damping rate gamma_N", "s-1", 0.0),
    Param("gamma_t", 3000.0, "tangential damping rate gamma_T", "s-1", 0.0),
    Param("friction", 0.5, "Coulomb friction coefficient", "1", 0.0),
    Param("fragmentation", True, "Weibull fragmentation on/off"),
    Param("weibull_c", 1e-9, "c of P = 1 - exp(-c R^-3 F^4); F_1/2 = (ln2 R^3/c)^(1/4)", "m3 N-4", 0.0, lo_open=True),
    Param("twin_repulsion", 1e-3, "constant force separating twin fragments (eqs 19-20)", "N", 0.0),
    Param("chain_threshold", 0.01,
          "force-chain criterion 2: sum of normal forces on a grain (1000 g cm s-2)", "N", 0.0),
    Param("integrator", "gear", "time integrator (the paper: Gear 6th order)", choices=("gear", "verlet")),
    # the paper's Gear step: t_c/25 of the smallest fragment pair (recommended: t_c/50), within
    # the tangential-dashpot limit of the Haff-Werner friction (engine.timestep)
    replace(TIME_STEP_PARAMS[0], default=2.0),
    TIME_STEP_PARAMS[1],
    Param("duration", 3.0, "simulated time", "s", 0.0, lo_open=True),
    Param("transient", 1.0, "initial time discarded from steady-state statistics", "s", 0.0),
    Param("record_interval", 0.01, "output cadence", "s", 0.0, lo_open=True),
    Param("snapshot_interval", 0.25, "size-distribution snapshot cadence", "s", 0.0, lo_open=True),
    Param("grid_cells", 24, "cells per side of the pressure / fracture maps", "1", 4),
    Param("size_classes", 12, "radius classes of the size distribution", "1", 2),
    Param("rate_blocks", 10, "blocks for the rate confidence interval", "1", 2),
    Param("seed", 1, "random seed", "1", 0),
)


def _check(values):
    if values["transient"] >= values["duration"]:
        raise ValueError("transient: must be shorter than duration")
    if values["lifter_height"] >= values["drum_radius"]:
        raise ValueError(f"lifter_height: {values['lifter_height']:g} m reaches the drum's axis; "
                         f"allowed [0, drum_radius = {values['drum_radius']:g}) m")
    # the largest raw grain must fit inside the lifters (and n_c needs drum_radius > grain_radius)
    room = values["drum_radius"] - values["lifter_height"]
    largest = values["grain_radius"] * (1 + values["grain_radius_spread"])
    if largest >= room:
        raise ValueError(f"grain_radius: the largest grain, {largest:g} m (grain_radius x (1 + "
                         f"grain_radius_spread)), does not fit in the drum; allowed grain_radius "
                         f"< (drum_radius - lifter_height) / (1 + grain_radius_spread) = "
                         f"{room / (1 + values['grain_radius_spread']):g} m")
    if values["sieve_radius"] >= values["grain_radius"] * (1 - values["grain_radius_spread"]):
        raise ValueError("sieve_radius: must be below the smallest raw grain radius")
    _check_sizes(values)


def wall_count(values):
    """Particles of the drum wall (drum_wall): the ring and the lifter bars."""
    rw, rl = values["wall_radius"], 0.5 * values["wall_radius"]
    ring = math.ceil(2 * math.pi * (values["drum_radius"] + rw) / rw)
    per_lifter = max(0, math.ceil((values["lifter_height"] + 1e-12 - rl) / rl))
    return ring + (values["lifters"] * per_lifter if values["lifter_height"] > 0 else 0)


def _check_sizes(values):
    """Upper bounds of the counts and grids from the memory of what the case keeps of them
    (util.memory), before anything is built: a refusal after the run, when the outputs are made,
    would lose it."""
    v = values
    grains, ring, wall = grain_count(v), wall_count(dict(v, lifters=0)), wall_count(v)
    per_lifter = wall_count(dict(v, lifters=1)) - ring
    # the particles are grains and wall: the larger share is named, its bound given the other
    if wall - ring > grains:
        check_memory("lifters", v["lifters"],
                     lambda n: (grains + ring + n * per_lifter) * BYTES_PER_PARTICLE,
                     "lifter bars", f"{per_lifter} particles each besides {grains + ring} "
                     f"others, {BYTES_PER_PARTICLE} B a particle")
    check_particle_memory("n_grains" if v["n_grains"] else "filling (n_grains from it)", grains,
                          others=wall)
    particles = grains + wall
    # pressure sums and counts, the fracture histogram, their quotients and the written copies
    check_memory("grid_cells", v["grid_cells"], lambda n: 10 * 8 * n**2, "cells per side",
                 "about ten maps of grid_cells^2 values, 8 B each")
    records = math.ceil(v["duration"] / v["record_interval"]) + 1
    window = v["duration"] - v["transient"]
    snap_every = max(1, round(v["snapshot_interval"] / v["record_interval"]))
    snapshots = math.ceil(window / (snap_every * v["record_interval"])) + 1
    # one size distribution per snapshot while running, stacked at the end, plus edges and bounds
    check_memory("size_classes", v["size_classes"], lambda n: 8 * n * (2 * snapshots + 8),
                 "radius classes", f"{snapshots} size snapshots of size_classes values and their "
                 "stack, 8 B each")
    check_memory("rate_blocks", v["rate_blocks"], lambda n: 5 * 8 * n, "blocks",
                 "edges, counts and rates per block, 8 B each")
    # without fragmentation every record after the transient keeps the normal-force sums and
    # pressures of all particles for the force chains
    chains = 0 if v["fragmentation"] else 2 * 8 * particles * window / v["duration"]
    per_record = (len(BallMillCase.series) + 1) * RECORD_VALUE_BYTES + chains
    check_memory("record_interval", records, lambda n: n * per_record, "records",
                 f"{per_record:.3g} B each" + (", force-chain data included" if chains else ""),
                 allowed=lambda n: f"record_interval >= {v['duration'] / max(n - 1, 1):.3g} s "
                                   f"({n} records of the duration)")


def grain_count(values):
    """Raw grains: n_grains, or the filling of the drum at random 2D packing."""
    raw_area = math.pi * values["grain_radius"] ** 2 * (1 + values["grain_radius_spread"] ** 2 / 3)
    return values["n_grains"] or int(round(values["filling"] * RANDOM_PACKING_2D * math.pi
                                           * values["drum_radius"] ** 2 / raw_area))


def critical_speed(values):
    """n_c [rev/s] = sqrt(g / R_eff) / (2 pi), R_eff = drum_radius - grain_radius."""
    return math.sqrt(G / (values["drum_radius"] - values["grain_radius"])) / (2 * math.pi)


def drum_wall(values, rng):
    """Centres and radii of the wall ring and the lifter bars (one rigid body)."""
    big = values["drum_radius"]
    rw = values["wall_radius"]
    # Centre spacing <= rw while two radii add up to >= 1.2 rw: neighbours always overlap, so
    # no fragment can slip through; inner surfaces touch the circle of radius big.
    count = math.ceil(2 * math.pi * (big + rw) / rw)
    radii = rw * rng.uniform(0.6, 1.0, count)
    phi = 2 * math.pi * np.arange(count) / count
    centres = np.column_stack([(big + radii) * np.cos(phi), (big + radii) * np.sin(phi)])
    if values["lifters"] and values["lifter_height"] > 0:
        rl = 0.5 * rw
        depth = np.arange(rl, values["lifter_height"] + 1e-12, rl)
        phi = 2 * math.pi * np.arange(values["lifters"]) / values["lifters"]
        d, f = np.meshgrid(depth, phi)
        lifter = np.column_stack([((big - d) * np.cos(f)).ravel(), ((big - d) * np.sin(f)).ravel()])
        centres = np.vstack([centres, lifter])
        radii = np.concatenate([radii, np.full(len(lifter), rl)])
    return centres, radii


def _random_grains(values, count, rng, occupied_x, occupied_r):
    """Random non-overlapping grains inside the drum, bottom first (a loose, nearly settled bed).

    Candidates are drawn below a level that rises whenever free spots run out, so the charge
    starts where it will lie instead of raining down from the whole drum.
    """
    big = values["drum_radius"] - values["lifter_height"]
    xs, rs = [], []
    ox, orad = list(occupied_x), list(occupied_r)
    level = -0.5 * big
    misses = 0
    while len(xs) < count:
        if level > big:
            raise ValueError(f"filling: could not place {count} grains without overlap; lower filling")
        r = values["grain_radius"] * rng.uniform(1 - values["grain_radius_spread"], 1 + values["grain_radius_spread"])
        rad = (big - r) * math.sqrt(rng.uniform())
        phi = rng.uniform(0, 2 * math.pi)
        p = np.array([rad * math.cos(phi), rad * math.sin(phi)])
        blocked = p[1] > level or (
            len(ox) and (np.linalg.norm(np.asarray(ox) - p, axis=1) < np.asarray(orad) + r).any())
        if blocked:
            misses += 1
            if misses > 400:
                level += 0.05 * big
                misses = 0
            continue
        xs.append(p)
        rs.append(r)
        ox.append(p)
        orad.append(r)
    return np.array(xs).reshape(-1, 2), np.array(rs)


def build(values):
    rng = np.random.default_rng(values["seed"])
    wall_x, wall_r = drum_wall(values, rng)
    n = grain_count(values)
    grains_x, grains_r = _random_grains(values, n, rng, wall_x, wall_r)
    x = np.vstack([wall_x, grains_x])
    radius = np.concatenate([wall_r, grains_r])
    body = np.concatenate([np.zeros(len(wall_r), dtype=np.int32), np.full(n, -1, dtype=np.int32)])
    n_c = critical_speed(values)
    omega = 2 * math.pi * values["n_over_nc"] * n_c
    mat = Material("grain", values["density"])
    table = MaterialTable([mat], {"*": Interaction(friction=values["friction"], normal_stiffness=values["stiffness"],
                                                   normal_damping_rate=values["gamma_n"],
                                                   tangential_damping_rate=values["gamma_t"])}, "linear_hw")
    spec = PhysicsSpec(dim=2, integrator=values["integrator"], bodies=True, normal_force_sum=True)
    # The smallest particle that can ever exist sets dt once: fragments down to the sieve size.
    r_min = values["sieve_radius"] if values["fragmentation"] else float(grains_r.min())
    sim = Simulation(spec, table, x=x, radius=radius, material="grain", body=body,
                     bodies=[dict(kind="rotate", center=(0, 0, 0), axis=(0, 0, 1), rate=-omega)],
                     gravity=(0.0, -G, 0.0), thickness=values["thickness"],
                     skin=0.5 * values["sieve_radius"],
                     step=step_policy(values, impact_speed=max(1.0, omega * values["drum_radius"]),
                                      smallest_radius=r_min),
                     guards=Guards(max_overlap=0.5),
                     breakage=WeibullModel(values["weibull_c"], values["twin_repulsion"],
                                           values["seed"]) if values["fragmentation"] else None)
    return sim, n_c, omega


def _fragmenting(values):
    return values["fragmentation"]


def _chains(values):
    return not values["fragmentation"]


class BallMillCase(Case):
    """One ball-mill run: records every ``record_interval``; after the transient, pressure and
    fracture maps, size distributions (with fragmentation) or force chains (without)."""

    series = (Series("grains", "1", "grains in the mill"),
              Series("fracture_events", "1", "cumulative fracture events"),
              Series("dust_mass", "kg", "cumulative dust removed"),
              Series("kinetic_energy", "J", "kinetic energy of the grains"),
              Series("drive_torque", "N m", "torque the drive supplies (interval mean)"),
              Series("drive_power", "W", "power the drive supplies (interval mean)"))
    outputs = (
        # CF axes: x is horizontal (X), y is vertical (Z, gravity along -y)
        Output("gx", ("gx",), "m", "map cell centre x", coord=True, cf={"axis": "X"}),
        Output("gy", ("gy",), "m", "map cell centre y", coord=True,
               cf={"axis": "Z", "positive": "up"}),
        Output("pressure", ("gy", "gx"), "Pa",
               "time-averaged grain pressure (normal forces / perimeter area)",
               "mean over the records after the transient of the grains in the cell (NaN: none)"),
        Output("mean_drive_power", (), "W", "steady-state mean drive power",
               "mean of the recorded drive power after the transient"),
        Output("n_c", (), "s-1", "critical speed (rev/s)"),
        Output("n_over_nc", (), "1", "rotation speed / critical speed"),
        # with fragmentation: the fractures, their rate and map, the size distribution
        Output("event", ("event",), "1", "fracture event index", coord=True, when=_fragmenting),
        # event_<field> for every field of a Fracture
        Output("event_time", ("event",), "s", "time of fracture", when=_fragmenting),
        Output("event_x", ("event",), "m", "x of the breaking grain", when=_fragmenting),
        Output("event_y", ("event",), "m", "y of the breaking grain", when=_fragmenting),
        Output("event_radius", ("event",), "m", "radius of the breaking grain", when=_fragmenting),
        Output("event_force", ("event",), "N", "peak normal force of the breaking contact",
               when=_fragmenting),
        Output("comminution_rate", (), "s-1", "steady-state fracture events per second",
               "fracture events after the transient over rate_blocks blocks", when=_fragmenting),
        Output("comminution_rate_ci", (), "s-1", "95% half-width (block averages)",
               "Student t over the block rates", when=_fragmenting),
        Output("fracture_frequency", ("gy", "gx"), "s-1 m-2", "fracture events per time and area",
               "events after the transient per cell, over the steady window and the cell area",
               when=_fragmenting),
        Output("snapshot", ("snapshot",), "s", "size snapshot time", coord=True,
               cf={"standard_name": "time", "axis": "T"}, when=_fragmenting),
        Output("size_class", ("size_class",), "m", "grain radius class centre", coord=True,
               cf={"bounds": "size_class_bounds"}, when=_fragmenting),
        Output("size_class_bounds", ("size_class", "bound"), "m", "grain radius class bounds",
               coord=True, when=_fragmenting),
        Output("size_distribution", ("snapshot", "size_class"), "kg",
               "grain mass per radius class", when=_fragmenting),
        Output("mass_balance_error", (), "kg", "grains + pending dust - initial grain mass",
               when=_fragmenting),
        # without: the force chains (scenes.force_chains)
        Output("chain_length", ("chain_length",), "1", "grains in the chain", coord=True,
               when=_chains),
        Output("chain_position", ("chain_position",), "1", "relative position along the chain",
               coord=True, when=_chains),
        Output("chain_count", ("chain_length",), "1", "chains per length (all records)",
               when=_chains),
        Output("chain_max_pressure", ("chain_length",), "Pa",
               "mean of the largest grain pressure in a chain", when=_chains),
        Output("chain_force_profile", ("chain_position",), "N",
               "mean normal-force sum vs position in chain", when=_chains),
    )

    def __init__(self, values):
        super().__init__()
        self.v = values
        self.sim, self.n_c, self.omega = build(values)
        sim = self.sim
        # the split draws and the refill placements share one generator (seed + 1)
        self.rng = np.random.default_rng(values["seed"] + 1)
        self.raw_mass = self.mass(values["grain_radius"])
        self.split = (WeibullSplit(values["sieve_radius"], self.mass, "grain", self.rng)
                      if values["fragmentation"] else None)
        self.initial_mass = self.grain_mass()
        self.record_steps = record_steps(values, sim.dt)
        self.total_steps = int(round(values["duration"] / sim.dt))
        self.snap_every = max(1, int(round(values["snapshot_interval"] / values["record_interval"])))
        cells = values["grid_cells"]
        self.grid_edges = np.linspace(-values["drum_radius"], values["drum_radius"], cells + 1)
        self.size_edges = np.linspace(values["sieve_radius"], values["grain_radius"] * (
            1 + values["grain_radius_spread"]), values["size_classes"] + 1)
        self.pressure_sum = np.zeros((cells, cells))
        self.pressure_n = np.zeros((cells, cells))
        self.snapshots, self.size_dist, self.chains = [], [], []
        self.last = DriveMark(sim.angular_impulse(body=0)[2], sim.work(body=0), sim.time)
        self.count = 0

    def mass(self, r):
        return self.v["density"] * math.pi * np.asarray(r) ** 2 * self.v["thickness"]

    def grain_mass(self):
        p = self.sim.particles
        return float(self.mass(p.radius[p.body < 0]).sum())

    def on_events(self, sim):
        """Split the grains that broke, then return dust as raw grains (constant filling)."""
        self.split(sim)
        while self.split.dust_pending >= self.raw_mass:
            p = sim.particles
            xy, r = _random_grains(dict(self.v, grain_radius_spread=0.0), 1, self.rng,
                                   p.x[:, :2], p.radius)
            sim.add_particles(np.column_stack([xy, np.zeros(1)]), r, "grain")
            self.split.dust_pending -= self.raw_mass

    def chunk(self):
        return min(self.record_steps, self.total_steps - self.sim.step)

    def done(self):
        return self.sim.step >= self.total_steps

    def progress(self):
        return self.sim.step / self.total_steps, f"{len(self.split.events) if self.split else 0} fractures"

    def after_chunk(self):
        s, v = self.sim, self.v
        p = s.particles
        free = p.body < 0
        impulse, work = s.angular_impulse(body=0)[2], s.work(body=0)
        span = s.time - self.last.time
        # The charge's torque on the drum about z; the drive supplies the opposite.
        self.record(s.time, grains=int(free.sum()),
                    fracture_events=len(self.split.events) if self.split else 0,
                    dust_mass=self.split.dust_total if self.split else 0.0,
                    kinetic_energy=s.kinetic_energy(),
                    drive_torque=-(impulse - self.last.angular_impulse) / span,
                    drive_power=(work - self.last.work) / span)
        self.last = DriveMark(impulse, work, s.time)
        self.count += 1
        if s.time < v["transient"]:
            return
        cells = v["grid_cells"]
        pressure = p.fn_sum / (2 * math.pi * p.radius * v["thickness"])
        ix = np.clip(np.digitize(p.x[free, 0], self.grid_edges) - 1, 0, cells - 1)
        iy = np.clip(np.digitize(p.x[free, 1], self.grid_edges) - 1, 0, cells - 1)
        np.add.at(self.pressure_sum, (iy, ix), pressure[free])
        np.add.at(self.pressure_n, (iy, ix), 1)
        if self.split and self.count % self.snap_every == 0:
            self.snapshots.append(s.time)
            mass = self.mass(p.radius[free])
            self.size_dist.append(np.histogram(p.radius[free], bins=self.size_edges, weights=mass)[0])
        if not self.split:
            i, j, _ = s.contact_pairs()
            grain = (p.body[i] < 0) & (p.body[j] < 0)
            found = find_chains(p.x[:, :2], i[grain], j[grain], p.fn_sum, v["chain_threshold"])
            self.chains.append((found, p.fn_sum.copy(), pressure))

    def finish(self):
        v = self.v
        edges = self.grid_edges
        centres = 0.5 * (edges[1:] + edges[:-1])
        data = {"gx": centres, "gy": centres}
        with np.errstate(invalid="ignore"):
            data["pressure"] = np.where(self.pressure_n > 0, self.pressure_sum
                                        / np.maximum(self.pressure_n, 1), np.nan)
        power = self.recorded("drive_power")
        steady = self.recorded_times() >= v["transient"]
        data["mean_drive_power"] = float(np.mean(power[steady])) if steady.any() else np.nan
        data["n_c"], data["n_over_nc"] = self.n_c, v["n_over_nc"]
        if self.split:
            data.update(self._fracture_outputs())
        else:
            stats = chain_statistics(self.chains)
            data.update(chain_length=stats["lengths"], chain_position=stats["position"],
                        chain_count=stats["count"], chain_max_pressure=stats["max_pressure"],
                        chain_force_profile=stats["load_profile"])
        return data

    def provenance(self):
        return {"critical_speed_rev_s": self.n_c, "rotation_rate_rad_s": self.omega}

    def _fracture_outputs(self):
        v, split = self.v, self.split
        edges = self.grid_edges
        data = {f"event_{name}": np.array([getattr(e, name) for e in split.events], dtype=float)
                for name in Fracture._fields}
        t, x, y = data["event_time"], data["event_x"], data["event_y"]
        data["event"] = np.arange(len(t))
        window = v["duration"] - v["transient"]
        rate, half, _ = steady_rate(t, v["transient"], v["duration"], v["rate_blocks"])
        data["comminution_rate"], data["comminution_rate_ci"] = rate, half
        after = t >= v["transient"]
        hist = np.histogram2d(x[after], y[after], bins=[edges, edges])[0].T
        cell_area = (edges[1] - edges[0]) ** 2
        data["fracture_frequency"] = hist / (window * cell_area)
        data["snapshot"] = np.array(self.snapshots)
        edges = self.size_edges
        data["size_class"] = 0.5 * (edges[1:] + edges[:-1])
        data["size_class_bounds"] = np.column_stack([edges[:-1], edges[1:]])
        data["size_distribution"] = np.array(self.size_dist).reshape(-1, v["size_classes"])
        data["mass_balance_error"] = self.grain_mass() + split.dust_pending - self.initial_mass
        return data


register(Scene("ballmill2d", "2D ball mill with lifters: comminution rate, maps, force chains "
               "(Buchholtz et al. 2000)", PARAMS, BallMillCase, (_check,),
               no_walls="a 2D mill of disks, whose drum and lifters are particles of a body; "
               "no wall is compiled into it"))
