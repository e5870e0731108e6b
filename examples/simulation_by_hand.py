"""Driving the engine from Python: a Simulation built by hand, without a scene.

Three glass spheres are dropped from three heights onto a floor (a plane wall) under gravity.
The script checks the free fall against z0 - g t^2 / 2 while nothing touches, then lets the
spheres bounce until they rest and checks that each rests on the floor, its centre one radius up
less the overlap m g / k_n of the linear spring that carries its weight.

    .venv/bin/python examples/simulation_by_hand.py

The first run compiles the step loop of this physics (the spec and the contact law below; ~20-60
s), later runs load it from the kernel cache. Units are SI throughout. The pieces:

- ``PhysicsSpec``: the switches the step loop is compiled with (3D, walls, gravity);
- ``MaterialTable``: the materials and the constants of each contact pair, and the contact law;
- ``Simulation``: particles (positions, radii, materials, velocities), walls, gravity, the time
  step policy; ``run(steps)`` advances it, ``particles`` holds the state (``x``, ``v``, ``w``).

A scene (``src/millsim/scenes/``, or your own: examples/my_scene.py) wraps the same calls in
parameters, recorded series and a case file.
"""

import math

import numpy as np

from millsim.engine import PhysicsSpec, Simulation, StepPolicy
from millsim.models import Interaction, Material, MaterialTable

RADIUS = 1e-3  # [m]
DENSITY = 2500.0  # [kg m-3]
K_N = 2e3  # linear normal stiffness [N m-1]
G = 9.81  # [m s-2]
HEIGHTS = (0.004, 0.006, 0.008)  # initial centre heights above the floor [m]


def build():
    spec = PhysicsSpec(dim=3, walls=True)  # gravity is on by default
    glass = Material("glass", DENSITY)
    # one interaction for every pair ("*"): particle-particle and particle-wall
    table = MaterialTable([glass], {"*": Interaction(restitution=0.5, friction=0.3,
                                                     normal_stiffness=K_N)}, "linear_history")
    # side by side, 4 radii apart: they never touch each other
    x = [[4 * RADIUS * k, 0.0, z] for k, z in enumerate(HEIGHTS)]
    floor = dict(kind="plane", point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), material="glass")
    # impact_speed: the fastest impact expected (sqrt(2 g h) from the top height), which the
    # time step is chosen to resolve
    impact = math.sqrt(2 * G * max(HEIGHTS))
    return Simulation(spec, table, x=x, radius=[RADIUS] * len(x), material="glass",
                      walls=[floor], gravity=(0.0, 0.0, -G), step=StepPolicy(impact_speed=impact))


def main():
    sim = build()
    print(f"{sim.n_particles} particles, dt = {sim.dt:.3g} s")

    # free fall until just before the lowest sphere reaches the floor
    t_fall = 0.9 * math.sqrt(2 * (HEIGHTS[0] - RADIUS) / G)
    sim.run(int(t_fall / sim.dt))
    z = sim.particles.x[:, 2]
    z_exact = np.array(HEIGHTS) - 0.5 * G * sim.time**2
    print(f"free fall: t = {sim.time:.4f} s, largest |z - (z0 - g t^2/2)| = "
          f"{np.abs(z - z_exact).max():.2e} m")

    # bounce until at rest (e = 0.5: each bounce keeps a quarter of the energy)
    sim.run(int(0.5 / sim.dt))
    mass = DENSITY * 4.0 / 3.0 * math.pi * RADIUS**3
    z_rest = RADIUS - mass * G / K_N
    speed = np.linalg.norm(sim.particles.v, axis=1).max()
    print(f"at rest: t = {sim.time:.3f} s, largest |z - (R - m g / k_n)| = "
          f"{np.abs(sim.particles.x[:, 2] - z_rest).max():.2e} m, largest speed {speed:.2e} m/s")


if __name__ == "__main__":
    main()
