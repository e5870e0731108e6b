"""Scene ``collision``: one binary impact (two particles, or a particle on a wall).

The engine-level check against analytic contact mechanics. The restitution the interaction asks
for is what a head-on collision must return in both end-of-contact conventions (laws that take a
restitution); a law that takes a damping rate (Buchholtz et al. 2000) gives it in closed form.
Contact times: each law's reference (``ContactLaw.collision_time``: closed form for the linear
laws, ballmill.md section 5, Schwager & Poeschel 2007; 2.9433 xi_max / v for elastic Hertz, a scipy
solution of the damped Hertz normal ODE otherwise). The scene writes the measured and the
reference values side by side, and the per-step overlap, normal force and relative normal
velocity.
"""

import math
from dataclasses import replace

import numpy as np

from ..engine import Guards, PhysicsSpec, Simulation
from ..engine.state import disk_or_sphere_mass
from ..models import Interaction, Material, MaterialTable
from ..models.contact import LAWS
from .base import (
    CONVENTION_PARAM,
    SOLID_PARAMS,
    TIME_STEP_PARAMS,
    Param,
    Scene,
    register,
    step_policy,
)
from .config_walls import scene_walls
from .driver import Case, Output, Series

PARAMS = (
    Param("contact_law", "hertz_mindlin", "contact law", choices=tuple(LAWS)),
    Param("dim", 3, "2 (disks) or 3 (spheres)", choices=(2, 3)),
    Param("target", "particle", "impact partner", choices=("particle", "wall")),
    Param("integrator", "verlet", "time integrator", choices=("verlet", "gear")),
    CONVENTION_PARAM,
    *SOLID_PARAMS,
    Param("normal_stiffness", 8e3, "linear spring constant (Buchholtz et al. 2000: Y = 8e6 g s-2)",
          "N m-1", 0.0, lo_open=True),
    Param("normal_damping_rate", 800.0, "gamma_N of Buchholtz et al. 2000 (linear_hw)", "s-1", 0.0),
    Param("tangential_damping_rate", 1000.0, "gamma_T of Buchholtz et al. 2000 (linear_hw)", "s-1", 0.0),
    Param("thickness", 0.01, "disk thickness for 2D masses", "m", 0.0, lo_open=True),
    Param("speed", 1.0, "relative impact speed", "m s-1", 0.0, lo_open=True),
    Param("angle", 0.0, "impact obliquity from the normal", "degree", 0.0, 90.0, hi_open=True),
    # 2000 steps per contact time where a contact bound (recommended: 50 steps) sets the step
    replace(TIME_STEP_PARAMS[0], default=0.025),
    TIME_STEP_PARAMS[1],
    Param("seed", 0, "random seed (unused: the collision is deterministic)", "1", 0),
)


def analytic(values):
    """Reference (restitution, contact time) of a head-on impact for the law and convention.

    A law that takes a restitution returns it by construction of its damping
    (``ContactLaw.row``); for a law that takes a damping rate (Buchholtz et al. 2000) it is a
    result, in closed form. The contact time is the law's reference (``ContactLaw.collision_time``:
    the closed form of the linear oscillator, or the Hertz normal ODE solved by scipy).
    """
    law = LAWS[values["contact_law"]]
    clipped = values["convention"] == "clipped"
    m = disk_or_sphere_mass(values["radius"], values["density"], values["dim"], values["thickness"])
    m_eff = float(m if values["target"] == "wall" else m / 2)
    # Rigid wall of the same material constants, or an identical partner.
    r_eff = values["radius"] if values["target"] == "wall" else values["radius"] / 2
    v = values["speed"] * math.cos(math.radians(values["angle"]))
    p = _table(values).pair_params(values["convention"])[0, 0]
    e = values["restitution"] if "restitution" in law.parameter_names else \
        law.restitution(p, m_eff, values["convention"])
    return e, law.collision_time(p, m_eff, r_eff, v, clipped)


def _table(values):
    mat = Material("particle", values["density"], values["youngs_modulus"], values["poisson_ratio"])
    inter = Interaction(restitution=values["restitution"], friction=values["friction"],
                        normal_stiffness=values["normal_stiffness"],
                        normal_damping_rate=values["normal_damping_rate"],
                        tangential_damping_rate=values["tangential_damping_rate"])
    return MaterialTable([mat], {"*": inter}, values["contact_law"])


def _check(values):
    law = LAWS[values["contact_law"]]
    if values["dim"] not in law.dims:
        raise ValueError(f"dim: {law.name} is a {law.dims[0]}D law; use dim = {law.dims[0]} or "
                         "another law")


class CollisionCase(Case):
    """One impact, stepped one step at a time (the overlap, force and normal velocity of every
    step are recorded) until the bodies have parted."""

    series = (Series("overlap", "m", "normal overlap"),
              Series("normal_force", "N", "normal contact force on particle 0"),
              Series("normal_velocity", "m s-1", "relative normal velocity (separating > 0)"))
    outputs = (
        Output("restitution", (), "1", "measured coefficient of restitution",
               "last normal velocity / first, over cos(angle) for an oblique impact"),
        Output("contact_time", (), "s", "measured contact duration",
               "from the zero crossing of the overlap (interpolated between steps) to zero "
               "overlap, interpolated (unclipped), or to the first step without normal force "
               "(clipped)"),
        Output("restitution_analytic", (), "1", "analytic coefficient of restitution"),
        Output("contact_time_analytic", (), "s", "analytic contact duration (NaN: none)"),
        Output("max_overlap", (), "m", "largest overlap"),
    )

    def __init__(self, values):
        super().__init__()
        self.values = v = values
        table = _table(v)
        spec = PhysicsSpec(dim=v["dim"], integrator=v["integrator"],
                           convention=v["convention"], gravity=False,
                           walls=v["target"] == "wall")
        r = self.r = v["radius"]
        gap = 1e-3 * r
        phi = math.radians(v["angle"])
        u = v["speed"]
        vel = np.array([-u * math.cos(phi), u * math.sin(phi), 0.0])
        if v["target"] == "wall":
            x, vs = [[r + gap, 0.0, 0.0]], [vel]
            walls = [dict(kind="plane", point=(0, 0, 0), normal=(1, 0, 0), material="particle")]
        else:
            x, vs = [[r + gap / 2, 0.0, 0.0], [-r - gap / 2, 0.0, 0.0]], [vel / 2, -vel / 2]
            walls = []
        spec, walls = scene_walls(v, spec, walls)
        self.sim = sim = Simulation(spec, table, x=x, radius=[r] * len(x), material="particle",
                                    v=vs, walls=walls, thickness=v["thickness"],
                                    step=step_policy(v, impact_speed=u),
                                    guards=Guards(max_overlap=0.9))
        self.e_ref, self.t_ref = analytic(v)
        self.m0 = 1.0 / sim.particles.inv_mass[0]
        self.max_steps = int(20 * (self.t_ref if math.isfinite(self.t_ref) else 1e3 * sim.dt)
                             / sim.dt) + 100
        self.touched = self.parted = False
        self._observe()

    def _observe(self):
        p = self.sim.particles
        if self.values["target"] == "wall":
            overlap, vn = self.r - p.x[0, 0], p.v[0, 0]
        else:
            overlap, vn = 2 * self.r - (p.x[0, 0] - p.x[1, 0]), p.v[0, 0] - p.v[1, 0]
        force = self.m0 * p.acc[0, 0]
        self.record(self.sim.time, overlap=overlap, normal_force=force, normal_velocity=vn)
        in_contact = overlap > 0 if self.values["convention"] == "unclipped" else (
            force != 0.0 or overlap > 0)
        self.touched |= in_contact
        self.parted = self.touched and not in_contact and overlap < 0

    def chunk(self):
        return 1

    def after_chunk(self):
        self._observe()

    def done(self):
        return self.parted or self.sim.step >= self.max_steps

    def progress(self):
        return min(self.sim.step / self.max_steps, 1.0), ""

    def finish(self):
        t = self.recorded_times()
        overlap, force = self.recorded("overlap"), self.recorded("normal_force")
        vn = self.recorded("normal_velocity")
        v_in = -vn[0]
        # Contact starts when the overlap crosses zero (interpolated); it ends at zero overlap or
        # at the first step with zero normal force, depending on the convention.
        k0 = int(np.argmax(overlap > 0))
        t_start = t[k0 - 1] + (t[k0] - t[k0 - 1]) * (-overlap[k0 - 1]) / (overlap[k0] - overlap[k0 - 1])
        if self.values["convention"] == "unclipped":
            k1 = k0 + int(np.argmax(overlap[k0:] <= 0))
            t_end = t[k1 - 1] + (t[k1] - t[k1 - 1]) * overlap[k1 - 1] / (overlap[k1 - 1] - overlap[k1])
        else:
            k1 = k0 + int(np.argmax(force[k0:] <= 0))
            t_end = t[k1 - 1] + (t[k1] - t[k1 - 1]) * force[k1 - 1] / (force[k1 - 1] - force[k1])
        angle = self.values["angle"]
        e_meas = vn[-1] / v_in / math.cos(math.radians(angle)) if angle else vn[-1] / v_in
        return {"restitution": e_meas, "contact_time": t_end - t_start,
                "restitution_analytic": self.e_ref, "contact_time_analytic": self.t_ref,
                "max_overlap": float(overlap.max())}


register(Scene("collision", "one binary impact (pair or wall) for analytic checks", PARAMS,
               CollisionCase, (_check,), wall_materials=lambda values: ("particle",)))
