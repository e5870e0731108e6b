"""Scene ``silo``: a flat-bottomed silo poured full, then discharged through its orifice.

Spheres are poured into a cylindrical silo whose bottom is closed by a gate (``engine.Pour``: a
charge poured at a rate instead of a lattice start), left to settle, and the gate is taken away:
the bottom is then an annulus around the orifice (``annulus`` wall, PhysicsSpec.bounded_walls).
Particles that have fallen a few diameters below the orifice leave the run and are counted as
discharged. The mass flow rate of the steady part of the discharge is compared with Beverloo's
correlation (Beverloo, Leniger & van de Velde 1961, Chem. Eng. Sci. 15:260):

    W = C rho_b sqrt(g) (D - k d)^(5/2),   C = 0.58, k = 1.5 (their fit; Nedderman 1992, ch. 10)

with the bulk density rho_b measured in the settled charge. Beverloo's law holds for a flow rate
independent of the fill height, orifices of more than ~6 particle diameters and silos wider than
~2.5 orifices; C and k depend on friction and particle shape (C 0.55-0.65 for spheres), so the
comparison is a check of magnitude and scaling, not of a fourth digit.
"""

import math

import numpy as np

from ..engine import Guards, PhysicsSpec, Pour, Simulation
from ..models import Interaction, Material, MaterialTable
from ..util.stats import slope_interval
from .base import (
    SOLID_PARAMS,
    TIME_STEP_PARAMS,
    Param,
    Scene,
    check_particle_memory,
    register,
    step_policy,
)
from .config_walls import scene_walls
from .driver import Case, Output, Series

BEVERLOO_C, BEVERLOO_K = 0.58, 1.5
G = 9.81
GATE, BOTTOM, SHELL = 0, 1, 2  # wall indices

PARAMS = (
    Param("n", 3000, "spheres poured", "1", 2),
    *SOLID_PARAMS,
    Param("silo_radius", 0.018, "inner radius of the silo", "m", 0.0, lo_open=True),
    Param("orifice_diameter", 0.010, "diameter of the central orifice in the flat bottom", "m",
          0.0, lo_open=True),
    Param("pour_height", 0.09, "top of the pouring region above the bottom", "m", 0.0,
          lo_open=True),
    Param("pour_time", 0.1, "time over which the n spheres are poured", "s", 0.0, lo_open=True),
    Param("settle_time", 0.3, "time left to settle after the last sphere is in", "s", 0.0),
    Param("discharge_time", 0.8, "longest discharge simulated after the gate opens", "s", 0.0,
          lo_open=True),
    Param("record_interval", 0.005, "discharged mass recorded every", "s", 0.0, lo_open=True),
    *TIME_STEP_PARAMS,
    Param("seed", 1, "random seed of the pour", "1", 0),
)


def _check(values):
    r, rs, d_or = values["radius"], values["silo_radius"], values["orifice_diameter"]
    if not d_or < 2.0 * rs:
        raise ValueError(f"orifice_diameter: must be below the silo diameter {2 * rs:g} m")
    if not d_or > 2.0 * r:
        raise ValueError(f"orifice_diameter: {d_or:g} m does not pass a sphere of diameter "
                         f"{2 * r:g} m")
    if not values["pour_height"] > 6.0 * r:
        raise ValueError(f"pour_height: must exceed 6 radii ({6 * r:g} m)")
    check_particle_memory("n", values["n"])


def beverloo(bulk_density, orifice, diameter):
    """Beverloo's mass flow rate [kg/s] through a circular orifice of a flat-bottomed silo."""
    return BEVERLOO_C * bulk_density * math.sqrt(G) * max(orifice - BEVERLOO_K * diameter,
                                                         0.0) ** 2.5


class SiloCase(Case):
    """Pour, settle, open the gate and discharge; the discharged mass every ``record_interval``."""

    series = (Series("discharged_mass", "kg", "mass discharged through the orifice"),)
    outputs = (
        Output("flow_rate", (), "kg s-1", "mass flow rate of the steady discharge (10-60 % of the "
               "charge out)", "least-squares slope of the discharged mass over those records"),
        Output("flow_rate_ci_lo", (), "kg s-1", "95% interval of the fitted slope, lower",
               "Student t on the slope's standard error"),
        Output("flow_rate_ci_hi", (), "kg s-1", "95% interval of the fitted slope, upper"),
        Output("steady_records", (), "1", "records in the steady fit"),
        Output("solid_fraction", (), "1", "solid fraction of the settled charge (core)",
               "sphere volume in a cylinder 4 radii clear of the walls and the free surface"),
        Output("bulk_density", (), "kg m-3", "bulk density of the settled charge"),
        Output("fill_height", (), "m", "height of the settled charge"),
        Output("beverloo_flow_rate", (), "kg s-1", f"Beverloo et al. (1961), C = {BEVERLOO_C}, "
               f"k = {BEVERLOO_K}, at the measured bulk density"),
        Output("flow_rate_over_beverloo", (), "1", "simulated / Beverloo flow rate"),
        Output("discharged_fraction", (), "1", "fraction of the charge discharged in the run"),
        Output("particles_left", (), "1", "spheres still in the silo at the end"),
    )

    def __init__(self, values):
        super().__init__()
        self.v = v = values
        r, rs = v["radius"], v["silo_radius"]
        mat = Material("grain", v["density"], v["youngs_modulus"], v["poisson_ratio"])
        table = MaterialTable([mat], {"*": Interaction(restitution=v["restitution"],
                                                       friction=v["friction"])}, "hertz_mindlin")
        spec = PhysicsSpec(dim=3, walls=True, bounded_walls=True)
        half = (rs - r) / math.sqrt(2.0)  # the pouring box inscribed in the silo's section
        self.pour = Pour(lo=(-half, -half, 2.0 * r), hi=(half, half, v["pour_height"]),
                         count=v["n"], rate=v["n"] / v["pour_time"], material="grain", radii=(r,),
                         gap=0.05 * r, seed=v["seed"])
        x, radius = self.pour.first()
        walls = [dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="grain"),
                 dict(kind="annulus", point=(0, 0, 0), normal=(0, 0, 1), radius=rs + 2.0 * r,
                      inner_radius=0.5 * v["orifice_diameter"], material="grain"),
                 dict(kind="cylinder_inner", point=(0, 0, 0), axis=(0, 0, 1), radius=rs,
                      material="grain")]
        impact = math.sqrt(2.0 * G * v["pour_height"])
        spec, walls = scene_walls(v, spec, walls)
        self.sim = sim = Simulation(spec, table, x=x, radius=radius, material="grain",
                                    walls=walls, gravity=(0.0, 0.0, -G),
                                    step=step_policy(v, impact_speed=2.0 * impact),
                                    guards=Guards(v_max=20.0 * impact))
        sim.disable_wall(BOTTOM)  # the gate closes the whole bottom while the silo fills
        self.mass = float(sim.masses()[0])
        self.exit_z = -6.0 * r  # below this a particle has left the silo
        self.stage, self.stage_end = "pour", None
        self.discharged, self.open_time, self.charge = 0.0, None, None

    def chunk(self):
        return max(1, int(round(self.v["record_interval"] / self.sim.dt)))

    def after_chunk(self):
        sim, v = self.sim, self.v
        if self.stage == "pour":
            self.pour.fill(sim)
            if self.pour.done:
                self.stage, self.stage_end = "settle", sim.time + v["settle_time"]
        elif self.stage == "settle":
            if sim.time >= self.stage_end:
                self.charge = self._charge()
                sim.disable_wall(GATE)
                sim.enable_wall(BOTTOM)
                self.stage, self.open_time = "discharge", sim.time
                self.stage_end = sim.time + v["discharge_time"]
                self.record(0.0, discharged_mass=0.0)
        else:
            out = sim.particles.x[:, 2] < self.exit_z
            left = sim.n_particles - int(out.sum())
            if out.any() and left >= 1:
                self.discharged += self.mass * int(out.sum())
                sim.remove_particles(out)
            self.record(sim.time - self.open_time, discharged_mass=self.discharged)
            if sim.time >= self.stage_end or left <= max(1, v["n"] // 10):
                self.stage = "done"

    def _charge(self):
        """Solid fraction of the settled charge away from the walls and its free surface."""
        p = self.sim.particles
        r, rs = self.v["radius"], self.v["silo_radius"]
        top = float(p.x[:, 2].max())
        lo, hi, rad = 4.0 * r, top - 4.0 * r, rs - 4.0 * r
        if hi <= lo:
            raise ValueError("n: the settled charge is too shallow to measure its bulk density "
                             "(pour more spheres)")
        inside = (p.x[:, 2] > lo) & (p.x[:, 2] < hi) & (np.hypot(p.x[:, 0], p.x[:, 1]) < rad)
        volume = 4.0 / 3.0 * math.pi * (p.radius[inside] ** 3).sum()
        return {"solid_fraction": volume / (math.pi * rad**2 * (hi - lo)), "height": top + r}

    def done(self):
        return self.stage == "done"

    def progress(self):
        if self.stage == "pour":
            return 0.1 * self.pour.inserted / self.v["n"], "pouring"
        if self.stage == "settle":
            return 0.1, "settling"
        if self.stage == "discharge":
            return 0.2 + 0.8 * min(1.0, self.discharged / (0.9 * self.mass * self.v["n"])), \
                "discharging"
        return 1.0, ""

    def finish(self):
        v = self.v
        t = np.asarray(self.recorded_times(), dtype=float)
        m = np.asarray(self.recorded("discharged_mass"), dtype=float)
        total = self.mass * v["n"]
        # the steady part: after the first 10 % of the charge has left (the gate's transient),
        # before 60 % (the fill height then matters less than it will near the end)
        steady = (m >= 0.1 * total) & (m <= 0.6 * total)
        rate = lo = hi = math.nan
        if steady.sum() >= 3:
            rate, half = slope_interval(t[steady], m[steady])
            lo, hi = rate - half, rate + half
        bulk = self.charge["solid_fraction"] * v["density"]
        predicted = beverloo(bulk, v["orifice_diameter"], 2.0 * v["radius"])
        return {"flow_rate": rate, "flow_rate_ci_lo": lo, "flow_rate_ci_hi": hi,
                "steady_records": int(steady.sum()),
                "solid_fraction": self.charge["solid_fraction"], "bulk_density": bulk,
                "fill_height": self.charge["height"], "beverloo_flow_rate": predicted,
                "flow_rate_over_beverloo": rate / predicted if predicted > 0 else math.nan,
                "discharged_fraction": self.discharged / total,
                "particles_left": self.sim.n_particles}

    def provenance(self):
        return {"open_time_s": self.open_time, "n_particles_poured": self.v["n"]}


register(Scene("silo", "flat-bottomed silo poured full and discharged through its orifice: mass "
               "flow rate against Beverloo's correlation", PARAMS, SiloCase, (_check,),
               wall_materials=lambda values: ("grain",)))
