"""The linear spring-dashpot the two linear laws share: its contact time and step bound, and its
restitution <-> damping ratio mapping in both end-of-contact conventions.

Two conventions for the end of a contact (``PhysicsSpec.convention``); in both, a head-on
collision of the pair returns the restitution asked for.
- ``clipped`` (default): the normal force never pulls, the contact ends when it reaches zero,
  before the overlap does. The damping is solved for once per restitution from the clipped
  relation (closed form for the linear laws, one ODE root for Hertz).
- ``unclipped``: the force may pull at the end (EDEM, LIGGGHTS ``limitForce off``, MercuryDPM),
  the contact ends at zero overlap; the damping is the textbook one of those codes.
"""

import math
from functools import cache

from scipy.optimize import brentq

from ...engine.integrators import DAMPING_LIMIT, GEAR_OMEGA_DT_LIMIT
from ...engine.timestep import (
    STEPS_PER_CONTACT_LIMIT,
    STEPS_PER_CONTACT_RECOMMENDED,
    StepBound,
    with_dashpot,
)


def linear_contact_time(stiffness, m_eff, damping_rate):
    """Collision time of a linear spring-dashpot, damping rate gamma (force m_eff gamma xi_dot)."""
    w0 = math.sqrt(stiffness / m_eff)
    beta = 0.5 * damping_rate
    w = math.sqrt(max(w0 * w0 - beta * beta, 0.25 * w0 * w0))
    return math.pi / w, w0


def linear_contact_bound(kn, m_eff, gamma, names, integrator):
    """(step bound, contact time) of a linear contact of stiffness kn and damping rate gamma.

    Beyond the collision time's share, the dashpot's own explicit limit: a head-on contact's
    relative normal speed decays at gamma, so gamma dt <= DAMPING_LIMIT. It binds from a damping
    ratio near 0.85 (a clipped restitution below about 0.16), where the collision time no longer
    shrinks with the damping; without it a head-on collision at e = 0.01 rebounded at 3.5 times
    its speed at the accepted step (docs/engine.md, "Time step and guards"). Its recommended
    step keeps the contacts' ratio to the limit (STEPS_PER_CONTACT_RECOMMENDED /
    STEPS_PER_CONTACT_LIMIT)."""
    t_c, w0 = linear_contact_time(kn, m_eff, gamma)
    limit = t_c / STEPS_PER_CONTACT_LIMIT
    recommended = t_c / STEPS_PER_CONTACT_RECOMMENDED
    what = f"the linear collision time {t_c:.4g} s of the {names} (m_eff = {m_eff:.4g} kg)"
    if integrator == "gear":
        limit = min(limit, GEAR_OMEGA_DT_LIMIT / w0)
        what += f" and Gear stability w0 dt <= {GEAR_OMEGA_DT_LIMIT}"
    limit, recommended, binds = with_dashpot(limit, recommended, gamma, integrator)
    if binds:
        what += f" and its dashpot gamma_N = {gamma:.4g} 1/s (gamma_N dt <= {DAMPING_LIMIT[integrator]:g})"
    return StepBound("linear_contact", what, limit, recommended), t_c


def linear_collision_time(w0, beta, clipped):
    """Contact time of a linear spring-dashpot (damping rate 2 beta): it ends at zero overlap
    (unclipped) or at zero force (clipped, Schwager & Poeschel 2007), also overdamped."""
    if beta < w0:
        w = math.sqrt(w0 * w0 - beta * beta)
        return (math.pi - (0.0 if not clipped else math.atan2(2 * beta * w, w * w - beta * beta))) / w
    if not clipped:
        return math.inf  # an overdamped unclipped contact never reaches zero overlap again
    if beta == w0:
        return 2.0 / w0
    root = math.sqrt(beta * beta - w0 * w0)
    l1, l2 = beta - root, beta + root
    return 2.0 * math.log(l2 / l1) / (l2 - l1)


def linear_restitution(zeta, clipped):
    """Restitution of a head-on collision with a linear spring-dashpot of damping ratio zeta, in
    units of w0 from its contact time t_c (``linear_collision_time``): e = exp(-zeta t_c)
    while underdamped (Schwager & Poeschel 2007, Granular Matter 9, 465, for the clipped end);
    overdamped and clipped, with the decay rates l1 < l2 = 2 zeta - l1, e = (l1 / l2) exp(-l1 t_c)
    (the same derivation with real exponents)."""
    if zeta <= 0.0:
        return 1.0
    t_c = linear_collision_time(1.0, zeta, clipped)
    if math.isinf(t_c):
        return 0.0
    if zeta <= 1.0:
        return math.exp(-zeta * t_c)
    l1 = zeta - math.sqrt(zeta * zeta - 1.0)
    return l1 / (2.0 * zeta - l1) * math.exp(-l1 * t_c)


@cache
def damping_ratio(restitution, convention="clipped"):
    """Damping ratio zeta of the linear laws whose head-on restitution is ``restitution``."""
    if restitution >= 1.0:
        return 0.0
    ln_e = math.log(restitution)
    unclipped = -ln_e / math.sqrt(math.pi**2 + ln_e**2)
    if convention == "unclipped":
        return unclipped
    # the clipped contact ends earlier and returns more: zeta lies above the unclipped one
    return brentq(lambda z: math.log(linear_restitution(z, True)) - ln_e, unclipped, 100.0,
                  xtol=1e-15, rtol=1e-15)
