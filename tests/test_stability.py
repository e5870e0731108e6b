"""Stiff and extreme cases: each runs with a closed energy audit or is refused up front, naming
the limit. No case may produce NaN or runaway energy silently.

Energy audit: kinetic energy before = kinetic energy after + dissipation integrated by the loop
(normal damping, tangential force on the centre and rotational slip, lubrication) once the bodies
have separated (no elastic energy left in a contact).
"""

import numpy as np
import pytest

from millsim.engine import PhysicsSpec, Simulation, StepPolicy, TimeStepError
from millsim.models import Interaction, Lubrication, Material, MaterialTable, TavaresModel

from one_particle import BODY_HERTZ, make_sim

# The contact law comes with the material table (hertz_mindlin unless it names another), the
# lubrication with the Simulation's fluid: the dry Hertz cases and the wet pair share one spec.
HERTZ = PhysicsSpec(dim=3, walls=True, gravity=False, energy_audit=True)
WET = HERTZ
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
                     gravity=(0, 0, 0), step=StepPolicy(impact_speed=v0))
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
                     v=[[20.0, 0, -v0]], gravity=(0, 0, 0), step=StepPolicy(impact_speed=v0),
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
                     v=[[0, 0, -100.0]], gravity=(0, 0, 0), step=StepPolicy(impact_speed=1.0),
                     walls=[dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1),
                                 material="steel")])
    sim.set_time_step(dt=sim.dt_report.limit)
    with pytest.raises(SimulationError, match="impacts at 100 m/s.*declare impact_speed"):
        sim.run(20000, chunk=1000)
    assert np.isfinite(sim.particles.v).all()


@pytest.mark.parametrize("declared, refused", [(1.01, False), (0.99, True)])
def test_a_kinematic_body_adds_its_speed_to_the_impact_speed_the_guard_checks(declared, refused):
    """Issue 47, seed 57 (`guards:55`): a free sphere at 0.1 m/s and a body sphere carried at
    0.25 m/s (rate 25 rad/s, arm 0.01 m) can close at 0.35 m/s at most. With the step at its
    limit for a declared impact speed, 1 % above 0.35 m/s passes and 1 % below stops the run
    naming 0.35 m/s (the limit's 10 steps per contact shrink by (0.99)^(1/5))."""
    from millsim.engine import SimulationError

    rate, arm, u_free = 25.0, 0.01, 0.1
    sim = make_sim(BODY_HERTZ, [[arm, 0.0, 0.0], [0.0, 0.05, 0.0]], v=[[0, 0, 0], [u_free, 0, 0]],
                   body=[0, -1], bodies=[dict(kind="rotate", center=(0, 0, 0), axis=(0, 0, 1),
                                              rate=rate)],
                   impact_speed=declared * (rate * arm + u_free))
    sim.set_time_step(dt=sim.dt_report.limit)
    if refused:
        with pytest.raises(SimulationError, match=r"impacts at 0\.35 m/s"):
            sim.run(30, chunk=10)
    else:
        sim.run(30, chunk=10)
        assert np.linalg.norm(sim.particles.v[0]) == pytest.approx(rate * arm, rel=1e-12)


def test_turning_plane_counts_its_surface_speed_at_the_particles():
    """A plane turning at 1000 rad/s under a particle 0.1 m off its axis moves at 100 m/s there:
    the same refusal as a 100 m/s particle (a plane has no radius to take the speed from)."""
    from millsim.engine import SimulationError

    table = MaterialTable([STEEL, ORE], {"*": Interaction(restitution=0.5, friction=0.5)})
    r = 2.75e-3
    sim = Simulation(HERTZ, table, x=[[0.1, 0, r + 1e-4]], radius=[r], material="ore",
                     gravity=(0, 0, 0), step=StepPolicy(impact_speed=1.0),
                     walls=[dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), omega=1000.0,
                                 material="steel")])
    sim.set_time_step(dt=sim.dt_report.limit)
    with pytest.raises(SimulationError, match="impacts at 100 m/s.*declare impact_speed"):
        sim.run(2000, chunk=1000)


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
                      gravity=(0, 0, 0), fluid=Lubrication(eta), step=StepPolicy(dt=dt))


def test_high_viscosity_step_above_the_lubrication_limit_is_refused():
    sim = _wet_pair(10.0)
    limit = sim.dt_report.limit
    assert sim.dt_report.binding.kind == "lubrication"
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


# ------------------------------------------------------------------------------------------------
# fragments down to 1/20 of the parent size (Tavares breakage, Tavares et al. 2021)
# ------------------------------------------------------------------------------------------------

TAVARES = HERTZ  # with breakage=TavaresModel(...)


def _hertz_elastic_energy(sim):
    """Normal elastic energy [J] of the Hertz contacts (8/15 E* sqrt(R*) xi^5/2), pairs and walls,
    counting only overlap beyond the creation reference of progeny. The tangential springs' energy
    is not added: the audit's tangential terms already hold it (they integrate the tangential
    force's whole power)."""
    from millsim.engine.kinematics import W_MATERIAL
    from millsim.engine.walls import wall_contact
    from millsim.models.contact import hertz_mindlin as law

    p, pp = sim.particles, sim.pair_params
    base = sim.layout.spring  # the breakage model's columns follow the contact law's
    i, j, overlap, slot = sim.contact_pairs(with_slots=True)
    xi = np.maximum(overlap - sim.breakage.reference_overlap(sim.contacts.state[slot, base:]), 0.0)
    r_eff = p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j])
    e = float((8 / 15 * pp[p.material[i], p.material[j], law.P_E_STAR] * np.sqrt(r_eff)
               * xi**2.5).sum())
    for iw, wall in enumerate(sim.walls):
        for q in range(sim.n_particles):
            ref = sim.breakage.reference_overlap(sim.wall_hist[q, iw:iw + 1, base:])[0]
            xw = wall_contact(wall, *p.x[q], p.radius[q])[0] - ref
            if xw > 0:
                e += 8 / 15 * pp[p.material[q], int(wall[W_MATERIAL]), law.P_E_STAR] * np.sqrt(
                    p.radius[q]) * xw**2.5
    return e


def _ore_on_plate(v0, seed=3):
    from millsim.models.breakage.replacement import TavaresReplacement
    from millsim.models.breakage.tavares_materials import load_materials

    mats = load_materials(truncation="single_particle")
    ore, steel = mats["copper_ore"], mats["steel"]
    table = MaterialTable([Material("copper_ore", ore.density, ore.young, ore.poisson),
                           Material("steel", steel.density, steel.young, steel.poisson)],
                          {"*": Interaction(restitution=0.39, friction=0.5)})
    r = 2.75e-3
    replace = TavaresReplacement({"copper_ore": ore}, d_min=2 * r / 20, seed=seed)
    # automatic dt (no smallest_radius): it has to follow the fragments as they appear
    sim = Simulation(TAVARES, table, x=[[0, 0, 1.02 * r]], radius=[r], material="copper_ore",
                     v=[[0, 0, -v0]], gravity=(0, 0, 0), step=StepPolicy(impact_speed=v0),
                     walls=[dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="steel")],
                     breakage=TavaresModel({"copper_ore": (ore.gamma, 0.0)}))
    replace.assign_fracture_energies(sim, [0])
    return sim, replace, ore


def test_fragments_down_to_a_twentieth_of_the_parent_close_the_energy_audit():
    """A 5.5 mm copper-ore sphere hits a steel plate at 40 m/s and breaks; its progeny break
    again within the same impact (their fracture energies capped at 30 J/kg, the model's own
    2,700-16,000 J/kg for these sizes would need > 50 m/s, below), down to d_min = parent/20.

    - dt follows the smallest particle: no ``smallest_radius`` is declared, each replacement
      re-evaluates the bounds and the automatic step follows the recommendation;
    - energy: impact energy = kinetic + dissipated (audit) + elastic + energy removed at the
      replacements, the latter measured around each handler call as the drop of kinetic +
      elastic energy (the parent's contact springs vanish, fragments keep only its rigid motion);
      within 1 %.
    """
    v0 = 40.0
    sim, replace, ore = _ore_on_plate(v0)
    r0, dt0, ke0 = sim.particles.radius[0], sim.dt, sim.kinetic_energy()
    removed, dts = [0.0], []

    def on_events(s):
        before = s.kinetic_energy() + _hertz_elastic_energy(s)
        replace(s)
        finite = np.isfinite(s.breakage.e_frac)
        s.breakage.e_frac[finite] = np.minimum(s.breakage.e_frac[finite], 30.0)
        removed[0] += before - s.kinetic_energy() - _hertz_elastic_energy(s)
        dts.append(s.dt)

    while sim.time < 1e-4:
        sim.run(2000, chunk=2000, on_events=on_events)
    p = sim.particles
    assert np.isfinite(p.x).all() and np.isfinite(p.v).all()
    d_min, d_small = 2 * r0 / 20, 2 * p.radius.min()
    assert len(replace.events) >= 10
    assert d_min <= d_small < 1.1 * d_min  # a second generation reached the resolved minimum
    # the step followed the fragments: 0.1 of the Rayleigh time of the smallest one
    from millsim.engine.timestep import RAYLEIGH_RECOMMENDED
    from millsim.models.contact.hertz_mindlin import rayleigh_time

    mat = sim.table.materials[0]
    t_r = rayleigh_time(p.radius.min(), mat.density, mat.shear_modulus, mat.poisson_ratio)
    assert sim.dt <= RAYLEIGH_RECOMMENDED * t_r * (1 + 1e-12) and sim.dt < dt0 / 5
    assert dts == sorted(dts, reverse=True)
    ke = sim.kinetic_energy()
    assert ke < ke0  # no runaway: the fragments carry less than the impact brought
    lost = sum(sim.energy_audit().values()) + _hertz_elastic_energy(sim) + removed[0]
    assert removed[0] > 0.05 * ke0
    assert abs(ke0 - ke - lost) / ke0 < 0.01


def test_fragments_squeezed_beyond_the_overlap_guard_stop_the_run_naming_the_pair():
    """At 60 m/s with the model's own fracture energies, small progeny are squeezed between large
    ones beyond 0.3 of their radius (Hertz is outside its range there): the run stops at that
    step naming the pair and the limit, with a finite state."""
    from millsim.engine import SimulationError

    sim, replace, _ = _ore_on_plate(60.0)
    with pytest.raises(SimulationError, match=r"overlap between particle \d+ and particle \d+ "
                                              r"exceeds 0.3 of the smaller radius"):
        sim.run(20000, chunk=2000, on_events=replace)
    assert len(replace.events) >= 2
    assert np.isfinite(sim.particles.x).all() and np.isfinite(sim.particles.v).all()


# ------------------------------------------------------------------------------------------------
# 4000 rpm: the stirred mill with lubrication (the LabStar LS1 paper)
# ------------------------------------------------------------------------------------------------

def test_stirred_mill_at_4000_rpm_closes_its_energy_balance():
    """The full-size LS1 agitator (scale 1: disk radius 34 mm, tip speed 14.2 m/s; its disk
    built of 2 mm spheres instead of 0.9 mm, 655 instead of 7,248, to keep the test small) in a
    periodic slice with 400 beads and eta = 0.05 Pa s, a quarter revolution from rest: agitator
    work = d(kinetic + potential + elastic) + dissipation (contact and lubrication), within 1 %;
    the beads stay below the tip speed. The same spec variant as tests/test_stirred_mill.py."""
    from millsim.scenes import stirred_mill as sm
    from millsim.scenes.base import get_scene

    values = get_scene("stirred_mill").resolve(dict(scale=1.0, slice=True, n_beads=400, rpm=4000,
                                                    eta=0.05, seed=3,
                                                    agitator_particle_radius=2e-3))
    sim, g = sm.build(values)
    assert sim.fluid is not None and g["tip_speed"] == pytest.approx(14.24, rel=1e-3)
    k_n = g["k_n"]
    k_t = k_n * values["tangential_stiffness_ratio"]
    start = sm.energy_state(sim, k_n, k_t)
    sim.run(int(round(0.25 * 60 / 4000 / sim.dt)), chunk=500)
    end = sm.energy_state(sim, k_n, k_t)
    d, _, rel = sm.energy_balance(start, end)
    assert np.isfinite(sim.particles.v).all()
    assert d["lubrication_normal"] + d["lubrication_tangential"] > 0.1 * d["work"]
    assert abs(rel) < 0.01
    speed = np.linalg.norm(sim.particles.v[sim.free], axis=1)
    assert 0.5 * g["tip_speed"] < speed.max() < g["tip_speed"]


def test_stirred_mill_at_4000_rpm_refuses_a_step_above_the_lubrication_limit():
    """eta = 1 Pa s at the dry step (1e-5 s): refused up front, naming eta and h_min."""
    from millsim.scenes import stirred_mill as sm
    from millsim.scenes.base import get_scene

    values = get_scene("stirred_mill").resolve(dict(scale=0.3, slice=True, n_beads=50, rpm=4000,
                                                    eta=1.0, dt=1e-5))
    with pytest.raises(TimeStepError, match=r"eta = 1 Pa s.*h_min"):
        sm.build(values)


# ------------------------------------------------------------------------------------------------
# ball mill at 2 n/n_c (Buchholtz et al. 2000, 2D)
# ------------------------------------------------------------------------------------------------

def test_ball_mill_at_twice_the_critical_speed_closes_its_energy_balance():
    """A 3 cm drum with 74 grains of 2 mm spun up from rest at 2 n/n_c (the charge centrifuges):
    drum work = d(kinetic + potential + elastic) + dissipation within 1 %, no NaN.

    Run without fragmentation: the audit covers the linear_hw contact (normal dashpot, the
    Haff-Werner tangential force on centre and rotational slip), not the Weibull twin relief
    (its dashpot and the constant separating force are outside it) nor the energy a split
    removes. The audit variant of the scene's physics is compiled here (energy_audit on)."""
    import dataclasses

    from millsim.engine.kinematics import B_AXIS, B_CENTER, B_RATE
    from millsim.scenes import ballmill2d as bm
    from millsim.scenes.base import get_scene

    values = get_scene("ballmill2d").resolve(dict(fragmentation=False, n_over_nc=2.0,
                                                  drum_radius=0.03, grain_radius=2e-3,
                                                  sieve_radius=0.5e-3, lifter_height=3e-3,
                                                  wall_radius=1e-3))
    scene, _, omega = bm.build(values)
    p, b = scene.particles, scene.bodies[0]
    sim = Simulation(dataclasses.replace(scene.spec, energy_audit=True), scene.table,
                     x=p.x.copy(), radius=p.radius.copy(), material="grain", body=p.body.copy(),
                     bodies=[dict(kind="rotate", center=b[B_CENTER], axis=b[B_AXIS], rate=b[B_RATE])],
                     gravity=scene.gravity, thickness=scene.thickness, skin=scene.skin,
                     step=scene.policy, guards=scene.guards)
    assert sim.dt == scene.dt and scene.guards.max_overlap == 0.5
    # the scene's step is capped by the Haff-Werner tangential dashpot (Gear), not t_c / 25
    assert sim.dt_report.binding.kind == "tangential_dashpot"
    assert scene.dt == pytest.approx(sim.dt_report.limit)
    k_n = scene.table.pair_params()[0, 0, 0]

    def state(s):
        elastic = 0.5 * k_n * float((s.contact_pairs()[2] ** 2).sum())
        return np.array([s.work(body=0), s.kinetic_energy(), s.potential_energy(), elastic,
                         sum(s.energy_audit().values())])

    a = state(sim)
    sim.run(int(round(0.25 / sim.dt)), chunk=5000)
    d = state(sim) - a
    assert np.isfinite(sim.particles.v).all()
    assert d[0] > 0 and d[4] > 0.3 * d[0]
    assert abs(d[0] - d[1:].sum()) / d[0] < 0.01
    # centrifuged: the grains go round with the drum (mean angular speed about its axis)
    free = sim.free
    x, v = sim.particles.x[free], sim.particles.v[free]
    rate = (x[:, 0] * v[:, 1] - x[:, 1] * v[:, 0]) / (x[:, 0] ** 2 + x[:, 1] ** 2)
    assert np.median(rate) == pytest.approx(-omega, rel=0.1)


def test_ball_mill_step_above_the_tangential_dashpot_limit_is_refused():
    """Gear with the Haff-Werner gamma_T = 3000 1/s at t_c / 25 of the raw grains (1.4e-5 s,
    where a resting charge gains energy: audit residual -30 % of the drum work in 0.5 s) is
    refused up front, naming the dashpot."""
    from millsim.scenes import ballmill2d as bm
    from millsim.scenes.base import get_scene

    values = get_scene("ballmill2d").resolve(dict(fragmentation=False, n_over_nc=2.0,
                                                  drum_radius=0.03, grain_radius=2e-3,
                                                  sieve_radius=0.5e-3, lifter_height=3e-3,
                                                  wall_radius=1e-3, dt=1.4e-5))
    with pytest.raises(TimeStepError, match=r"tangential dashpot gamma_T = 3000 1/s"):
        bm.build(values)
