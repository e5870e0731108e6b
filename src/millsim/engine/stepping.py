"""The time-step policy of a Simulation: what the step is chosen from (engine.timestep) and the
particles it is set for. Functions of the Simulation; its methods call them."""

from dataclasses import dataclass

import numpy as np

from ..util.validation import check_range
from .kinematics import W_MATERIAL
from .state import disk_or_sphere_mass
from .timestep import time_step_report


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


def step_particles(sim):
    """(radius, mass, material, body) of the particles the step is set for: those present and,
    with a policy's smallest_radius, one virtual particle of that size per free material."""
    p = sim.particles
    mass = np.where(p.inv_mass > 0, 1.0 / np.where(p.inv_mass > 0, p.inv_mass, 1.0), np.inf)
    radius, material, body = p.radius, p.material, p.body
    if sim.policy.smallest_radius is not None:
        # One virtual particle of the smallest possible size per free material.
        mats = np.unique(material[body < 0])
        density = np.array([sim.table.materials[m].density for m in mats])
        r = np.full(len(mats), sim.policy.smallest_radius)
        radius = np.concatenate([radius, r])
        mass = np.concatenate([mass, disk_or_sphere_mass(r, density, sim.spec.dim,
                                                         sim.thickness)])
        material = np.concatenate([material, mats])
        body = np.concatenate([body, np.full(len(mats), -1)])
    return radius, mass, material, body


def sim_time_step_report(sim):
    """The time-step report (engine.timestep) of the particles, walls, bodies and fluid now."""
    radius, mass, material, body = step_particles(sim)
    p = sim.particles
    boundary = [int(m) for m in sim.walls[:, W_MATERIAL]] + [int(m) for m in
                                                            p.material[p.body >= 0]]
    boundary += [int(m) for mesh in sim._mesh_geometry for m in np.unique(mesh[3])]
    extra = sim.fluid.step_bounds(smallest_for_fluid(sim, radius, mass, material, body)) \
        if sim.fluid else ()
    return time_step_report(sim.law, sim.table.materials, sim.pair_params, sim.spec.dim,
                            sim.spec.integrator, radius, mass, material, body, boundary,
                            sim.policy.impact_speed, extra)


def smallest_for_fluid(sim, radius, mass, material, body):
    """(radius, mass, k_n, gamma_n, integrator) of the lightest free particle (lubrication.md
    4: with the contact spring and dashpot of a pair of them)."""
    k = int(np.argmin(np.where(body < 0, mass, np.inf)))
    m_min, a_min, mat = float(mass[k]), float(radius[k]), int(material[k])
    k_n, gamma_n = sim.law.stiffness_and_damping(sim.pair_params[mat, mat], 0.5 * m_min)
    return a_min, m_min, k_n, gamma_n, sim.spec.integrator


def set_time_step(sim, dt=None, dt_factor=None):
    """Simulation.set_time_step."""
    if (dt is None) == (dt_factor is None):
        raise ValueError("set_time_step: give dt or dt_factor")
    policy = StepPolicy(dt, 1.0 if dt_factor is None else dt_factor, sim.policy.impact_speed,
                        sim.policy.smallest_radius)
    dt_new = sim.dt_report.check(dt if dt is not None else policy.dt_factor
                                 * sim.dt_report.recommended)
    sim.policy, sim.dt = policy, dt_new
