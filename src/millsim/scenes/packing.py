"""Scene ``packing``: N spheres settled in a walled box, or tumbling in a rotating drum.

The engine's throughput case (same geometry and material as the LIGGGHTS baseline in
``shared/reference/peers.md`` part B): a settling stage at a coarse step, then the timed stage at
``dt``. The drum variant adds a spin-up stage and reports the torque and power the shell delivers.
A settled state from another code (CSV with a header: x, y, z and optionally vx..., omegax...)
can replace the settling stage, so both codes start from the same bed.
"""

import math

import numpy as np

from ..engine import PhysicsSpec, Simulation, StepPolicy
from ..engine.mesh import signed_clearance
from ..engine.mesh_io import read_mesh
from ..engine.spec import FORCE_SUMS
from ..models import Interaction, Material, MaterialTable
from .base import CONVENTION_PARAM, SOLID_PARAMS, Param, Scene, check_particle_memory, register
from .config_walls import scene_walls
from .driver import Case, Output, Series
from .liner_rays import axis_rays

PARAMS = (
    Param("n", 10000, "number of spheres", "1", 1),
    Param("container", "box", "box: walled square box open at the top; drum: rotating cylinder",
          choices=("box", "drum")),
    *SOLID_PARAMS,
    CONVENTION_PARAM,
    Param("rolling_friction", 0.0, "rolling friction coefficient (EDEM standard)", "1", 0.0),
    Param("box_width", 0.044, "box side (box)", "m", 0.0, lo_open=True),
    Param("drum_radius", 0.04, "drum inner radius (drum)", "m", 0.0, lo_open=True),
    Param("drum_length", 0.04, "drum length along its horizontal y axis (drum)", "m", 0.0, lo_open=True),
    Param("drum_omega", 9.5, "drum angular velocity (drum)", "rad s-1"),
    Param("liner", "", "STL of the drum's shell as a closed solid around the axis along y from "
          "y = 0 to drum_length (container=drum only; docs/engine.md): a mesh wall turning with "
          "the drum instead of the cylinder of drum_radius, which must match its shell within 5 % "
          "(the lattice start stays inside drum_radius, clear of the liner)"),
    Param("liner_scale", 1.0, "factor from the liner STL's units to m (1e-3: mm)", "1", 0.0,
          lo_open=True),
    Param("integrator", "verlet", "time integrator", choices=("verlet", "gear")),
    Param("force_sum", "records", "how contacts become particle forces (engine.spec.PhysicsSpec)",
          choices=FORCE_SUMS),
    Param("skin", 2e-4, "Verlet skin", "m", 0.0, lo_open=True),
    Param("settle_dt", 1e-5, "time step of the settling and spin-up stages", "s", 0.0, lo_open=True),
    Param("settle_steps", 25000, "settling steps (skipped with init_file)", "1", 0),
    Param("spinup_steps", 20000, "drum spin-up steps at settle_dt (drum)", "1", 0),
    Param("dt", 1e-6, "time step of the timed stage", "s", 0.0, lo_open=True),
    Param("steps", 20000, "steps of the timed stage", "1", 1),
    Param("record_every", 1000, "output cadence of the timed stage", "steps", 1),
    Param("init_file", "", "settled state to start from (CSV: x,y,z[,vx,vy,vz][,omegax,omegay,omegaz])"),
    Param("seed", 12345, "random seed of the lattice jitter", "1", 0),
)

LATTICE = 2.2  # lattice spacing in radii, as in the LIGGGHTS baseline (2.2 mm for r = 1 mm)
JITTER = 0.09  # lattice jitter in radii
# A liner is probed by rays from the drum's axis: this many directions at each of LINER_HEIGHTS
# heights; its shell (the farthest first hit) must lie within LINER_MATCH of drum_radius, where
# the lattice start is placed (a polygon's mid-face lies cos(pi / sides) inside its circle).
LINER_RAYS, LINER_HEIGHTS, LINER_MATCH = 72, 5, 0.05


def _check(values):
    check_particle_memory("n", values["n"])


def _check_liner(values):
    """``liner`` only where it is the shell (container=drum), and then a solid around the drum's
    axis from y = 0 to drum_length whose shell lies at drum_radius: a valid solid elsewhere, or
    one in mm read as m, would run with the charge falling out of it or start outside it."""
    liner, scale = values["liner"], values["liner_scale"]
    if liner and values["container"] != "drum":
        raise ValueError(f"liner: {liner!r}: container={values['container']} takes no liner (it "
                         "replaces the shell of container=drum)")
    if not liner:
        if scale != 1.0:
            raise ValueError(f"liner_scale: {scale:g} given without a liner")
        return
    vertices, faces = read_mesh(liner, scale)
    radius, length, r = values["drum_radius"], values["drum_length"], values["radius"]
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    span = ("the liner spans " + ", ".join(f"{axis} [{a:.4g}, {b:.4g}]"
                                           for axis, a, b in zip("xyz", lo, hi)) + " m")
    if not 0.2 * radius < (hi - lo).max() < 20 * radius:  # mm read as m, or the reverse
        span = f"units? liner_scale is {scale:g} (1e-3: a file in mm); {span}"
    if lo[1] > r or hi[1] < length - r:
        raise ValueError(f"liner: {liner}: does not run along the drum's axis from y = 0 to "
                         f"drum_length = {length:g} m (to within the sphere radius); {span}")
    dist = axis_rays(liner, vertices, faces, length, LINER_RAYS, LINER_HEIGHTS, span)
    shell = float(dist.max())
    if abs(radius - shell) > LINER_MATCH * shell:
        raise ValueError(f"liner: {liner}: its shell lies {shell:.4g} m from the axis but "
                         f"drum_radius is {radius:g} m (the lattice start fills drum_radius): set "
                         f"drum_radius within {LINER_MATCH:.0%} of it; {span}")


def _lattice(values, rng):
    r = values["radius"]
    a = LATTICE * r
    if values["container"] == "box":
        per_side = max(1, int(values["box_width"] / a))
        layers = math.ceil(values["n"] / per_side**2)
        g = np.stack(np.meshgrid(np.arange(per_side), np.arange(per_side), np.arange(layers),
                                 indexing="ij"), -1).reshape(-1, 3)
        g = g[np.lexsort((g[:, 0], g[:, 1], g[:, 2]))][: values["n"]]
        x = (g + 0.5) * a
    else:
        big = values["drum_radius"] - r
        span = np.arange(-big + r, big - r + 1e-12, a)
        along = np.arange(r * 1.1, values["drum_length"] - r * 1.1 + 1e-12, a)
        g = np.stack(np.meshgrid(span, along, span, indexing="ij"), -1).reshape(-1, 3)
        g = g[np.hypot(g[:, 0], g[:, 2]) < big - 0.2 * r]
        if values["liner"]:  # clear of the liner's lifters
            vertices, faces = read_mesh(values["liner"], values["liner_scale"])
            tri = vertices[faces]
            normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            normal /= np.linalg.norm(normal, axis=1)[:, None]
            g = g[signed_clearance(tri, normal, np.ascontiguousarray(g)) > 1.3 * r]
        if len(g) < values["n"]:
            raise ValueError(f"n: {values['n']} spheres do not fit in the drum (room for {len(g)})")
        # Fill from the bottom: the settled charge starts where it will lie.
        x = g[np.lexsort((g[:, 0], g[:, 1], g[:, 2]))][: values["n"]]
    return x + rng.uniform(-JITTER * r, JITTER * r, x.shape)


def _walls(values):
    if values["container"] == "box":
        w = values["box_width"]
        return [dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="grain"),
                dict(kind="plane", point=(0, 0, 0), normal=(1, 0, 0), material="grain"),
                dict(kind="plane", point=(w, 0, 0), normal=(-1, 0, 0), material="grain"),
                dict(kind="plane", point=(0, 0, 0), normal=(0, 1, 0), material="grain"),
                dict(kind="plane", point=(0, w, 0), normal=(0, -1, 0), material="grain")]
    shell = (dict(kind="mesh", file=values["liner"], scale=values["liner_scale"],
                  point=(0, 0, 0), axis=(0, 1, 0), omega=0.0, material="grain")
             if values["liner"] else
             dict(kind="cylinder_inner", point=(0, 0, 0), axis=(0, 1, 0),
                  radius=values["drum_radius"], omega=0.0, material="grain"))
    return [shell,
            dict(kind="plane", point=(0, 0, 0), normal=(0, 1, 0), material="grain"),
            dict(kind="plane", point=(0, values["drum_length"], 0), normal=(0, -1, 0), material="grain")]


def read_state(path):
    """Positions, velocities, spins from a CSV with a header (x, y, z[, vx, vy, vz][, omegax, ...]),
    e.g. a LIGGGHTS dump converted by bench/liggghts.py. SI units, drum axis through the origin."""
    data = np.genfromtxt(path, delimiter=",", names=True)
    names = data.dtype.names
    missing = {"x", "y", "z"} - set(names)
    if missing:
        raise ValueError(f"init_file: columns {sorted(missing)} missing in {path}")

    def cols(keys):
        return np.column_stack([data[k] for k in keys]) if set(keys) <= set(names) else None

    return cols(("x", "y", "z")), cols(("vx", "vy", "vz")), cols(("omegax", "omegay", "omegaz"))


def build(values):
    """The settled-or-lattice Simulation of this scene (shared with the throughput benchmark)."""
    rng = np.random.default_rng(values["seed"])
    mat = Material("grain", values["density"], values["youngs_modulus"], values["poisson_ratio"])
    table = MaterialTable([mat], {"*": Interaction(restitution=values["restitution"],
                                                   friction=values["friction"],
                                                   rolling_friction=values["rolling_friction"])},
                          "hertz_mindlin")
    spec = PhysicsSpec(dim=3, integrator=values["integrator"], convention=values["convention"],
                       rolling_friction=values["rolling_friction"] > 0, walls=True,
                       force_sum=values["force_sum"],
                       mesh_walls=bool(values["liner"]) and values["container"] == "drum")
    v = w = None
    if values["init_file"]:
        x, v, w = read_state(values["init_file"])
    else:
        x = _lattice(values, rng)
    radius = np.full(len(x), values["radius"])
    spec, walls = scene_walls(values, spec, _walls(values))
    return Simulation(spec, table, x=x, radius=radius, material="grain", v=v, w=w, walls=walls,
                      skin=values["skin"], step=StepPolicy(dt=values["settle_dt"]))


def _drum(values):
    return values["container"] == "drum"


class PackingCase(Case):
    """Settle (box or drum), spin the drum up, then the timed stage at ``dt``: kinetic energy,
    contacts per particle and bed height every ``record_every`` steps; the drum's torque and
    power over the timed stage."""

    series = (Series("kinetic_energy", "J", "kinetic energy of the spheres"),
              Series("contacts_per_particle", "1", "particle-particle contacts per particle"),
              Series("bed_top", "m", "highest sphere centre"))
    outputs = (
        Output("particle_steps_per_second", (), "s-1", "throughput of the timed stage",
               "particles x steps / timed_wall_time"),
        Output("timed_wall_time", (), "s", "wall time of the timed stage (compiled loop only)"),
        Output("shell_torque", (), "N m", "mean torque of the charge on the shell about its axis "
               "(the drive supplies the opposite)", "angular impulse over the timed stage / its "
               "duration", when=_drum),
        Output("shell_power", (), "W", "mean power the shell puts into the charge",
               "work over the timed stage / its duration", when=_drum),
    )

    def __init__(self, values):
        super().__init__()
        self.v = values
        self.sim = build(values)
        self.drum = _drum(values)
        # stages: (name, steps, record cadence)
        self.plan = [("timed", values["steps"], values["record_every"])]
        if self.drum and values["spinup_steps"]:
            self.plan.insert(0, ("spinup", values["spinup_steps"], 5000))
        if not values["init_file"] and values["settle_steps"]:
            self.plan.insert(0, ("settle", values["settle_steps"], 5000))
        self.total = sum(steps for _, steps, _ in self.plan)
        self.stage = -1
        self._next_stage()

    def _next_stage(self):
        self.stage += 1
        if self.stage == len(self.plan):
            return
        name, self.left, _ = self.plan[self.stage]
        sim = self.sim
        if self.drum and name != "settle":
            sim.set_wall(0, omega=self.v["drum_omega"])
        if name == "timed":
            sim.set_time_step(self.v["dt"])
            self.t_start, self.work_start = sim.time, sim.work(wall=0)
            self.angular_start = sim.angular_impulse(wall=0)
            self.timed_wall = sim.wall_seconds

    def chunk(self):
        return min(self.plan[self.stage][2], self.left)

    def after_chunk(self):
        sim = self.sim
        self.left -= self.chunk()
        if self.plan[self.stage][0] == "timed":
            i, _, _ = sim.contact_pairs()
            self.record(sim.time, kinetic_energy=sim.kinetic_energy(),
                        contacts_per_particle=2.0 * len(i) / sim.n_particles,
                        bed_top=float(sim.particles.x[sim.free, 2].max()))
        if self.left == 0:
            self._next_stage()

    def done(self):
        return self.stage == len(self.plan)

    def progress(self):
        if self.done():
            return 1.0, ""
        done = sum(steps for _, steps, _ in self.plan[:self.stage]) + (
            self.plan[self.stage][1] - self.left)
        return done / self.total, self.plan[self.stage][0]

    def finish(self):
        sim, v = self.sim, self.v
        timed_wall = sim.wall_seconds - self.timed_wall
        elapsed = sim.time - self.t_start
        data = {"particle_steps_per_second": sim.n_particles * v["steps"] / timed_wall,
                "timed_wall_time": timed_wall}
        if self.drum:
            data["shell_torque"] = (sim.angular_impulse(wall=0) - self.angular_start)[1] / elapsed
            data["shell_power"] = (sim.work(wall=0) - self.work_start) / elapsed
        return data

    def provenance(self):
        return {"list_rebuilds": int(self.sim.counters[0]), "n_particles": self.sim.n_particles}


register(Scene("packing", "spheres settled in a box or tumbling in a rotating drum (benchmark case)",
               PARAMS, PackingCase, (_check, _check_liner),
               wall_materials=lambda values: ("grain",)))
