"""Stiff and extreme cases: each runs with a closed energy audit or is refused up front, naming
the limit. No case may produce NaN or runaway energy silently.

Energy audit: kinetic energy before = kinetic energy after + dissipation integrated by the loop
(normal damping, tangential force on the centre and rotational slip, lubrication) once the bodies
have separated (no elastic energy left in a contact).
"""

import numpy as np
import pytest

from millsim.engine import Interaction, Material, MaterialTable, PhysicsSpec, Simulation
from millsim.engine.timestep import TimeStepError

HERTZ = PhysicsSpec(dim=3, contact_law="hertz_mindlin", walls=True, gravity=False,
                    energy_audit=True)
WET = PhysicsSpec(dim=3, contact_law="linear_history", walls=True, gravity=False,
                  lubrication=True, energy_audit=True)
STEEL = Material("steel", 7800.0, 210e9, 0.3)
ORE = Material("ore", 2800.0, 52e9, 0.25)


def _audit_closure(sim, ke0):
    lost = sum(sim.energy_audit().values())
    return abs(ke0 - sim.kinetic_energy() - lost) / ke0


def _separated(sim):
    return len(sim.contact_pairs()[0]) == 0


def test_real_stiffness_steel_ball_on_ore_closes_energy():
    """210 GPa steel sphere onto a 52 GPa 5.5 mm ore sphere resting on nothing (no gravity),
    oblique, with friction: the step from the report resolves the stiff contact."""
    table = MaterialTable([STEEL, ORE], {"*": Interaction(restitution=0.5, friction=0.5)})
    r_ball, r = 0.044, 2.75e-3
    v0 = 2.5
    x = [[0.3 * r, 0, r + r_ball + 1e-4], [0, 0, 0]]
    sim = Simulation(HERTZ, table, x=x, radius=[r_ball, r], material=["steel", "ore"],
                     v=[[0, 0, -v0], [0, 0, 0]], w=[[0, 30.0, 0], [0, 0, 0]],
                     gravity=(0, 0, 0), impact_speed=v0)
    ke0 = sim.kinetic_energy()
    sim.run(int(2e-4 / sim.dt), chunk=500)
    assert _separated(sim)
    assert np.isfinite(sim.particles.v).all()
    assert _audit_closure(sim, ke0) < 0.01
    terms = sim.energy_audit()
    assert terms["contact_normal_damping"] > 0
    assert terms["lubrication_normal"] == terms["lubrication_tangential"] == 0.0


def test_100_m_per_s_impact_on_a_plate_closes_energy():
    table = MaterialTable([STEEL, ORE], {"*": Interaction(restitution=0.5, friction=0.5)})
    r, v0 = 2.75e-3, 100.0
    sim = Simulation(HERTZ, table, x=[[0, 0, r + 1e-4]], radius=[r], material="ore",
                     v=[[20.0, 0, -v0]], gravity=(0, 0, 0), impact_speed=v0,
                     walls=[dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="steel")])
    ke0 = sim.kinetic_energy()
    sim.run(int(2e-5 / sim.dt) + 200, chunk=200)
    assert sim.particles.v[0, 2] > 0 and np.isfinite(sim.particles.v).all()
    assert _audit_closure(sim, ke0) < 0.01


def test_impact_faster_than_declared_is_stopped_naming_the_speed():
    """A step at the limit for 1 m/s impacts, but the particle flies at 100 m/s: its Hertz contact
    would get ~6 steps (an energy error of ~10 %); the run stops before the impact and says what to
    declare."""
    from millsim.engine import SimulationError

    table = MaterialTable([STEEL, ORE], {"*": Interaction(restitution=0.5, friction=0.5)})
    r = 2.75e-3
    sim = Simulation(HERTZ, table, x=[[0, 0, r + 1e-4]], radius=[r], material="ore",
                     v=[[0, 0, -100.0]], gravity=(0, 0, 0), impact_speed=1.0,
                     dt=None, walls=[dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1),
                                          material="steel")])
    sim.set_time_step(sim.dt_report.limit)
    with pytest.raises(SimulationError, match="impacts at 100 m/s.*declare impact_speed"):
        sim.run(20000, chunk=1000)
    assert np.isfinite(sim.particles.v).all()


def test_large_initial_overlap_is_refused_up_front():
    table = MaterialTable([ORE], {"*": Interaction(restitution=0.5, friction=0.5)})
    r = 1e-3
    with pytest.raises(ValueError, match="initial state: particles 0 and 1 overlap by 0.5"):
        Simulation(HERTZ, table, x=[[0, 0, 0], [1.5 * r, 0, 0]], radius=[r, r], material="ore",
                   gravity=(0, 0, 0))


def _wet_pair(eta, dt=None, v0=0.5):
    bead = Material("bead", 6000.0, 5e6, 0.45)
    table = MaterialTable([bead], {"*": Interaction(restitution=0.5, friction=0.3,
                                                     normal_stiffness=500.0)},
                          contact_law="linear_history")
    a = 0.95e-3
    x = [[0, 0, 0], [2 * a + 0.02 * a, 0, 0]]
    return Simulation(WET, table, x=x, radius=[a, a], material="bead",
                      v=[[v0, 0.2 * v0, 0], [-v0, 0, 0]], w=[[0, 0, 50.0], [0, 0, 0]],
                      gravity=(0, 0, 0), fluid=dict(eta=eta), dt=dt)


def test_high_viscosity_step_above_the_lubrication_limit_is_refused():
    sim = _wet_pair(10.0)
    limit = sim.dt_report.limit
    assert "lubrication" in sim.dt_report.binding.interaction
    with pytest.raises(TimeStepError, match=r"eta = 10 Pa s.*h_min"):
        _wet_pair(10.0, dt=1.5 * limit)


def test_high_viscosity_pair_runs_stable_and_closes_energy():
    """eta = 10 Pa s at the recommended step: the squeeze film stops a 1 m/s approach before the
    beads touch, and what is left is the pair's rigid co-rotation, which lubrication does not damp
    (the zero mode of the resistance matrix). Kinetic energy lost = audited dissipation."""
    sim = _wet_pair(10.0)
    ke0 = sim.kinetic_energy()
    sim.run(40000, chunk=2000)
    p = sim.particles
    assert np.isfinite(p.v).all()
    terms = sim.energy_audit()
    assert terms["contact_normal_damping"] == 0.0  # never touched
    assert terms["lubrication_normal"] > 0.9 * ke0
    assert _audit_closure(sim, ke0) < 0.01
    d = p.x[0] - p.x[1]
    omega = np.cross(d, p.v[0] - p.v[1]) / (d @ d)  # orbital rate of the pair
    assert p.w[0] == pytest.approx(omega, rel=0.02, abs=1e-6)
    assert p.w[1] == pytest.approx(omega, rel=0.02, abs=1e-6)
