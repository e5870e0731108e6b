"""Time step from the stiffest interaction present, and the stability limit a user step must meet.

For every pair of materials that can touch (free particles with each other, with walls and with
kinematic bodies) the smallest particles of each material set the fastest contact:

- Hertz-Mindlin: the Rayleigh time T_R = pi r sqrt(rho/G) / (0.1631 nu + 0.8766) of the smallest
  particle, and the Hertz contact time t_c = 2.87 (m*^2 / (R* E*^2 v))^(1/5) at the scene's largest
  expected impact speed v (it shrinks with v, the Rayleigh time does not).
- linear laws: the damped collision time t_c = pi / sqrt(w0^2 - beta^2), w0^2 = k / m_eff.

The recommended step resolves a contact with >= 50 steps (0.1 T_R for Hertz); the refusal limit is
10 steps per contact (0.4 T_R, EDEM's upper recommendation), and for the Gear corrector also
w0 dt <= 0.2 (it goes unstable near 0.25 with damping, see ballmill.md section 1).
"""

import math
from dataclasses import dataclass

import numpy as np

from . import contact as law

STEPS_PER_CONTACT_LIMIT = 10
STEPS_PER_CONTACT_RECOMMENDED = 50
RAYLEIGH_LIMIT = 0.4
RAYLEIGH_RECOMMENDED = 0.1
GEAR_OMEGA_DT_LIMIT = 0.2
# Explicit stability of a pure decay v' = -g v (docs/lubrication.md): g dt <= 1 for this engine's
# Verlet (dashpots see v + dt a), g dt <= 0.163 for the 6-value Gear corrector.
VERLET_DAMPING_LIMIT = 1.0
GEAR_DAMPING_LIMIT = 0.163
# Contacts with immovable partners (wall disks, lifters) that can hold one particle at once.
DASHPOT_CONTACTS = 3


class TimeStepError(ValueError):
    """A requested time step above the stability limit."""


def rayleigh_time(radius, density, shear_modulus, poisson_ratio):
    return math.pi * radius * math.sqrt(density / shear_modulus) / (0.1631 * poisson_ratio + 0.8766)


def hertz_contact_time(m_eff, r_eff, e_star, speed):
    return 2.87 * (m_eff**2 / (r_eff * e_star**2 * speed)) ** 0.2


def linear_contact_time(stiffness, m_eff, damping_rate):
    """Collision time of a linear spring-dashpot, damping rate gamma (force m_eff gamma xi_dot)."""
    w0 = math.sqrt(stiffness / m_eff)
    beta = 0.5 * damping_rate
    w = math.sqrt(max(w0 * w0 - beta * beta, 0.25 * w0 * w0))
    return math.pi / w, w0


@dataclass(frozen=True)
class StepBound:
    interaction: str
    limit: float
    recommended: float
    advice: str = ""  # the way out beyond a smaller dt, for the refusal message


def tangential_dashpot_bound(gamma_t, dim, integrator):
    """Step bound of the Haff-Werner tangential force (``linear_hw``) below its Coulomb limit.

    There F_T = -m_eff gamma_T v_t is a dashpot on the slip of the contact point, which moves
    with translation and spin: one contact with an immovable partner relaxes the slip at
    (1 + m a^2 / I) gamma_T = 3 gamma_T (disks) or 3.5 gamma_T (spheres) (a pair of free
    particles at the same rate), and a particle held by DASHPOT_CONTACTS such contacts at up to
    that many times this rate. gamma_T does not scale with the contact stiffness, so the
    collision-time bounds do not cover it. Measured (tests/test_stability.py, a centrifuged 2D
    ball mill, Gear): at 6 gamma_T dt = 0.142 the slip oscillates at the Coulomb limit and the
    charge gains energy (audit residual -1.1 % of the drum work in 0.5 s, -30 % at 0.26), at
    0.129 and below the audit closes (3e-4).
    """
    rate = DASHPOT_CONTACTS * (3.0 if dim == 2 else 3.5) * gamma_t
    g = GEAR_DAMPING_LIMIT if integrator == "gear" else VERLET_DAMPING_LIMIT
    limit = g / rate
    return StepBound(
        f"the tangential dashpot gamma_T = {gamma_t:g} 1/s of the Haff-Werner friction "
        f"(slip relaxation up to {rate:.4g} 1/s for a particle held by {DASHPOT_CONTACTS} "
        f"contacts; {integrator} needs rate x dt <= {g:g})",
        limit, 0.5 * limit, "; or lower gamma_T")


@dataclass(frozen=True)
class TimeStepReport:
    bounds: tuple
    # shortest Hertz contact time at the declared impact speed, and that speed (None: linear law)
    hertz_contact_time: float = None
    impact_speed: float = None

    def steps_per_contact(self, dt, speed):
        """Steps resolving the shortest Hertz contact at ``speed`` (t_c scales as v^-1/5)."""
        if self.hertz_contact_time is None or speed <= self.impact_speed:
            return math.inf
        return self.hertz_contact_time * (self.impact_speed / speed) ** 0.2 / dt

    @property
    def limit(self):
        return min(b.limit for b in self.bounds)

    @property
    def recommended(self):
        return min(b.recommended for b in self.bounds)

    @property
    def binding(self) -> StepBound:
        return min(self.bounds, key=lambda b: b.limit)

    def check(self, dt):
        """Return dt if it is within the limit; raise TimeStepError naming the limit otherwise."""
        if not dt > 0:
            raise TimeStepError(f"dt: must be > 0, got {dt}")
        b = self.binding
        if dt > b.limit:
            raise TimeStepError(
                f"dt: {dt:.4g} s exceeds the stability limit {b.limit:.4g} s set by {b.interaction}; "
                f"use dt <= {b.limit:.4g} s (recommended {self.recommended:.4g} s){b.advice}")
        return dt


def time_step_report(table, spec, radius, mass, material, body, boundary_materials, impact_speed):
    """Bounds for every material pair that can be in contact.

    Args:
        table: :class:`~millsim.engine.materials.MaterialTable`.
        spec: :class:`~millsim.engine.spec.PhysicsSpec`.
        radius, mass, material, body: per-particle arrays (body >= 0 marks kinematic particles).
        boundary_materials: material indices of walls and kinematic bodies.
        impact_speed: largest expected normal impact speed [m/s] (Hertz contact time).
    """
    free = body < 0
    smallest = {}
    for mat in np.unique(material[free]):
        sel = free & (material == mat)
        k = np.argmin(mass[sel])
        smallest[int(mat)] = (float(radius[sel][k]), float(mass[sel][k]))
    params = table.pair_params()
    bounds = []
    shortest = math.inf
    for a, (ra, ma) in smallest.items():
        partners = [(b, rb, mb, "particle") for b, (rb, mb) in smallest.items() if b >= a]
        partners += [(b, math.inf, math.inf, "wall/body") for b in sorted(set(boundary_materials))]
        for b, rb, mb, kind in partners:
            m_eff = 1.0 / (1.0 / ma + (0.0 if math.isinf(mb) else 1.0 / mb))
            r_eff = ra if math.isinf(rb) else ra * rb / (ra + rb)
            names = f"{table.materials[a].name}-{table.materials[b].name} {kind} contact"
            p = params[a, b]
            if spec.contact_law == "hertz_mindlin":
                mat = table.materials[a]
                t_r = rayleigh_time(ra, mat.density, mat.shear_modulus, mat.poisson_ratio)
                bounds.append(StepBound(
                    f"the Rayleigh time {t_r:.4g} s of the smallest {mat.name} particle (r = {ra:.4g} m)",
                    RAYLEIGH_LIMIT * t_r, RAYLEIGH_RECOMMENDED * t_r))
                t_c = hertz_contact_time(m_eff, r_eff, p[law.P_E_STAR], impact_speed)
                shortest = min(shortest, t_c)
                bounds.append(StepBound(
                    f"the Hertz contact time {t_c:.4g} s of the {names} at {impact_speed:g} m/s",
                    t_c / STEPS_PER_CONTACT_LIMIT, t_c / STEPS_PER_CONTACT_RECOMMENDED))
            else:
                kn = p[law.P_K_N]
                if spec.contact_law == "linear_hw":
                    gamma = p[law.P_GAMMA_N]
                    if p[law.P_GAMMA_T] > 0:
                        bounds.append(tangential_dashpot_bound(float(p[law.P_GAMMA_T]), spec.dim,
                                                               spec.integrator))
                else:
                    gamma = 2.0 * p[law.P_ZETA_N] * math.sqrt(kn / m_eff)
                t_c, w0 = linear_contact_time(kn, m_eff, gamma)
                limit = t_c / STEPS_PER_CONTACT_LIMIT
                what = f"the linear collision time {t_c:.4g} s of the {names} (m_eff = {m_eff:.4g} kg)"
                if spec.integrator == "gear":
                    limit = min(limit, GEAR_OMEGA_DT_LIMIT / w0)
                    what += f" and Gear stability w0 dt <= {GEAR_OMEGA_DT_LIMIT}"
                bounds.append(StepBound(what, limit, t_c / STEPS_PER_CONTACT_RECOMMENDED))
    if not bounds:
        raise ValueError("no free particles: nothing sets a time step")
    if spec.contact_law == "hertz_mindlin":
        return TimeStepReport(tuple(bounds), shortest, float(impact_speed))
    return TimeStepReport(tuple(bounds))
