"""One particle against walls and kinematic bodies: the physics variants and the builder that
tests/test_wall_kinds.py and tests/test_integrators.py share (one compiled loop per variant)."""

import math

import numpy as np

from millsim.engine import PhysicsSpec, Simulation, StepPolicy
from millsim.models import Interaction, Material, MaterialTable

# (spec, contact law) pairs; the first ones other test files compile already (tests/test_dynamics.py,
# test_engine.py)
WALL_VERLET = (PhysicsSpec(dim=3, walls=True), "linear_history")
WALL_GEAR = (PhysicsSpec(dim=3, integrator="gear", walls=True), "linear_history")
# frustum and annulus walls are compiled only into runs that declare them (one more kernel)
WALL_BOUNDED = (PhysicsSpec(dim=3, walls=True, bounded_walls=True), "linear_history")
BODY_HERTZ = (PhysicsSpec(dim=3, bodies=True), "hertz_mindlin")
# translating walls likewise (one more kernel)
WALL_TRANSLATING = (PhysicsSpec(dim=3, walls=True, translating_walls=True), "linear_history")

R = 1e-3  # particle radius [m]
RHO = 2500.0
K_N = 2e3  # linear normal stiffness [N/m]
MASS = RHO * 4.0 / 3.0 * math.pi * R**3
W0 = math.sqrt(K_N / MASS)  # particle-wall contact: m_eff = m
ZERO_G = (0.0, 0.0, 0.0)


def make_sim(variant, x, v=None, *, radius=R, restitution=0.5, friction=0.0, walls=(), bodies=(),
             body=None, gravity=ZERO_G, impact_speed=1.0):
    """The one place a Simulation is built (one material "m" for particles, walls and bodies);
    ``variant``: (spec, contact law)."""
    spec, law = variant
    if law == "hertz_mindlin":
        mat = Material("m", RHO, 5e6, 0.3)
        inter = Interaction(restitution=restitution, friction=friction)
    else:
        mat = Material("m", RHO)
        inter = Interaction(restitution=restitution, friction=friction, normal_stiffness=K_N)
    table = MaterialTable([mat], {"*": inter}, law)
    n = len(x)
    return Simulation(spec, table, x=np.asarray(x, float), radius=np.broadcast_to(radius, n).copy(),
                      material="m", v=v, walls=list(walls), bodies=list(bodies), body=body,
                      gravity=gravity, step=StepPolicy(impact_speed=impact_speed))


def unit(a):
    a = np.asarray(a, dtype=float)
    return a / np.linalg.norm(a)


def perpendicular_basis(a):
    """Two unit vectors completing the unit vector a to a right-handed frame (e1, e2, a)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = unit(np.cross(a, helper))
    return e1, np.cross(a, e1)
