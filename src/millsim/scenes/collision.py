"""Scene ``collision``: one binary impact (two particles, or a particle on a wall).

The engine-level check against analytic contact mechanics. The restitution the interaction asks
for is what a head-on collision must return in both end-of-contact conventions (linear_history,
hertz_mindlin); linear_hw's follows from the damping rate of Buchholtz et al. 2000 in closed form.
Contact times: closed form for the linear laws (ballmill.md section 5, Schwager & Poeschel 2007),
2.9433 xi_max / v for elastic Hertz, a scipy solution of the damped Hertz normal ODE otherwise. The
scene writes the measured and the reference values side by side, and the per-step overlap, normal
force and relative normal velocity.
"""

import math
from dataclasses import replace

import numpy as np

from ..engine import Guards, PhysicsSpec, Simulation
from ..engine.state import disk_or_sphere_mass
from ..models import Interaction, Material, MaterialTable
from ..models.contact import linear_collision_time
from ..models.materials import damping_ratio, effective_moduli, hertz_beta_term, linear_restitution
from .base import (
    CONVENTION_PARAM,
    SOLID_PARAMS,
    TIME_STEP_PARAMS,
    Param,
    Scene,
    register,
    step_policy,
)
from .driver import Case, Output, Series

HERTZ_TIME_FACTOR = 2.9433  # t_c = 2 (xi_max / v) int_0^1 dx / sqrt(1 - x^(5/2))

PARAMS = (
    Param("contact_law", "hertz_mindlin", "contact law", choices=("linear_hw", "linear_history", "hertz_mindlin")),
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

    linear_hw takes the damping rate of Buchholtz et al. 2000, so its restitution is a result:
    closed form for both conventions. linear_history and hertz_mindlin take a restitution, which
    a head-on collision returns by construction of their damping (``models.materials``); the contact
    time is the closed form of the linear oscillator, or the Hertz normal ODE solved by scipy.
    """
    law = values["contact_law"]
    clipped = values["convention"] == "clipped"
    m = disk_or_sphere_mass(values["radius"], values["density"], values["dim"], values["thickness"])
    m_eff = float(m if values["target"] == "wall" else m / 2)
    if law in ("linear_hw", "linear_history"):
        w0 = math.sqrt(values["normal_stiffness"] / m_eff)
        if law == "linear_hw":
            beta = values["normal_damping_rate"] / 2.0
        else:
            beta = damping_ratio(values["restitution"], values["convention"]) * w0
        t_c = linear_collision_time(w0, beta, clipped)
        if law == "linear_hw":
            return linear_restitution(beta / w0, clipped), t_c
        return values["restitution"], t_c
    mat = Material("p", values["density"], values["youngs_modulus"], values["poisson_ratio"])
    e_star, _ = effective_moduli(mat, mat)
    # Rigid wall of the same material constants, or an identical partner.
    r_eff = values["radius"] if values["target"] == "wall" else values["radius"] / 2
    v = values["speed"] * math.cos(math.radians(values["angle"]))
    if values["restitution"] == 1.0:
        xi_max = (15 * m_eff * v * v / (16 * e_star * math.sqrt(r_eff))) ** 0.4
        return 1.0, HERTZ_TIME_FACTOR * xi_max / v
    beta_term = hertz_beta_term(values["restitution"], values["convention"])
    return values["restitution"], hertz_reference(m_eff, r_eff, e_star, beta_term, v, clipped)[1]


def hertz_reference(m_eff, r_eff, e_star, beta_term, speed, clip):
    """Restitution and contact time of the damped Hertz normal ODE (damping beta_term sqrt(S_n
    m_eff)), solved by scipy at rtol 1e-11 in SI units, the contact ending at zero force
    (clip) or at zero overlap."""
    from scipy.integrate import solve_ivp

    def force(xi, xi_dot):
        xi = max(xi, 0.0)
        sn = 2.0 * e_star * math.sqrt(r_eff * xi)
        return (2.0 / 3.0) * sn * xi + beta_term * math.sqrt(sn * m_eff) * xi_dot

    def rhs(_, y):
        f = force(y[0], y[1])
        return [y[1], -(max(f, 0.0) if clip else f) / m_eff]

    end = (lambda _, y: force(y[0], y[1])) if clip else (lambda _, y: y[0])
    end.terminal, end.direction = True, -1
    # Start just inside contact so the end event does not fire at t = 0.
    t_guess = 3.0 * (m_eff**2 / (r_eff * e_star**2 * speed)) ** 0.2
    sol = solve_ivp(rhs, (0.0, 10 * t_guess), [speed * 1e-9 * t_guess, speed], events=end,
                    rtol=1e-11, atol=1e-16 * speed * t_guess, max_step=t_guess / 2000)
    y_end = sol.y_events[0][0]
    return -y_end[1] / speed, float(sol.t_events[0][0])


def _check(values):
    if values["dim"] == 2 and values["contact_law"] == "hertz_mindlin":
        raise ValueError("dim: hertz_mindlin is a 3D law; use dim = 3 or a linear law")


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
               "from the zero crossing of the overlap to zero overlap (unclipped) or zero normal "
               "force (clipped), both interpolated between steps"),
        Output("restitution_analytic", (), "1", "analytic coefficient of restitution"),
        Output("contact_time_analytic", (), "s", "analytic contact duration (NaN: none)"),
        Output("max_overlap", (), "m", "largest overlap"),
    )

    def __init__(self, values):
        super().__init__()
        self.values = v = values
        law = v["contact_law"]
        mat = Material("particle", v["density"], v["youngs_modulus"], v["poisson_ratio"])
        inter = Interaction(restitution=v["restitution"], friction=v["friction"],
                            normal_stiffness=v["normal_stiffness"],
                            normal_damping_rate=v["normal_damping_rate"],
                            tangential_damping_rate=v["tangential_damping_rate"])
        table = MaterialTable([mat], {"*": inter}, law)
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
               CollisionCase, (_check,)))
