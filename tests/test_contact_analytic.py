"""Binary impacts against closed-form contact mechanics (ballmill.md section 5, tavares.md 13)."""

import math

import pytest

from millsim.scenes.base import RunContext, get_scene

from helpers import progress_of

TOL = 0.005  # 0.5 %, the tolerance


def run_collision(**overrides):
    scene = get_scene("collision")
    ds, _ = scene.run(scene.resolve(overrides), RunContext())
    return ds


@pytest.mark.parametrize("convention", ["clipped", "unclipped"])
@pytest.mark.parametrize("target", ["particle", "wall"])
def test_linear_hw_restitution_and_contact_time(convention, target):
    """Law of Buchholtz et al. 2000, 2D disks: e and t_c for both end-of-contact conventions."""
    ds = run_collision(contact_law="linear_hw", dim=2, convention=convention, target=target)
    assert float(ds.restitution) == pytest.approx(float(ds.restitution_analytic), rel=TOL)
    assert float(ds.contact_time) == pytest.approx(float(ds.contact_time_analytic), rel=TOL)


def test_a_run_without_a_context_runs_in_the_default_one():
    """Scene.run(values) with no RunContext: the same case as with RunContext()."""
    scene = get_scene("collision")
    values = scene.resolve(dict(contact_law="linear_hw", dim=2))
    bare, _ = scene.run(values)
    assert float(bare.restitution) == float(run_collision(contact_law="linear_hw",
                                                          dim=2).restitution)


def test_linear_conventions_differ_as_predicted():
    """Clipping the force ends the contact earlier and gives a larger e (Schwager & Poeschel)."""
    a = run_collision(contact_law="linear_hw", dim=2, convention="unclipped")
    b = run_collision(contact_law="linear_hw", dim=2, convention="clipped")
    assert float(b.contact_time) < float(a.contact_time)
    assert float(b.restitution) > float(a.restitution)


def test_buchholtz2000_numbers_for_1cm_disks():
    """Independent numbers of ballmill.md table 5: R = 1 cm, rho = 2 g/cm3, unit thickness, pair."""
    ds = run_collision(contact_law="linear_hw", dim=2, radius=0.01, density=2000.0, thickness=0.01,
                       normal_stiffness=8e3, normal_damping_rate=800.0, convention="unclipped")
    assert float(ds.contact_time) == pytest.approx(2.034e-3, rel=2e-3)
    assert float(ds.restitution) == pytest.approx(0.443, rel=2e-3)
    ds = run_collision(contact_law="linear_hw", dim=2, radius=0.01, density=2000.0, thickness=0.01,
                       normal_stiffness=8e3, normal_damping_rate=800.0, convention="clipped")
    assert float(ds.contact_time) == pytest.approx(1.706e-3, rel=2e-3)
    assert float(ds.restitution) == pytest.approx(0.506, rel=2e-3)


@pytest.mark.parametrize("integrator", ["verlet", "gear"])
def test_linear_history_wall(integrator):
    ds = run_collision(contact_law="linear_history", target="wall", restitution=0.7,
                       integrator=integrator)
    assert float(ds.restitution) == pytest.approx(float(ds.restitution_analytic), rel=TOL)
    assert float(ds.contact_time) == pytest.approx(float(ds.contact_time_analytic), rel=TOL)


@pytest.mark.parametrize("integrator", ["verlet", "gear"])
@pytest.mark.parametrize("restitution", [0.3, 0.05, 0.01])
@pytest.mark.parametrize("law", ["linear_history", "hertz_mindlin"])
@pytest.mark.parametrize("dt_factor, rel", [(1.0, 0.1), (4.99, 0.25)])
def test_a_damped_collision_keeps_its_restitution_up_to_the_step_limit(law, integrator,
                                                                       restitution, dt_factor,
                                                                       rel):
    """A head-on collision at a wall with clipped e = 0.3, 0.05 or 0.01 (linear damping ratio
    0.36-5, Hertz beta_term 0.91-8.8) returns its restitution at the default step within 10 %
    (linear, Verlet, e = 0.01: 5.4 % off, converging at first order: 12.7, 5.4, 1.8 % at 2, 1,
    0.5 times the step) and at (just under) the largest step the engine accepts within 25 %
    (linear e = 0.3 and 0.15 there: 6 % and 21 % off with Verlet). A share of the collision time
    alone let the dashpot run past its explicit limit, rate x dt > 1 (Verlet) or 0.163 (Gear):
    for the linear law, whose collision time is capped, at the limit e = 0.05 came back 0.91
    (Gear 1.82); for Hertz, whose contact time does not see the damping, with Gear e = 0.3 came
    back 0.82 at the limit and at the default step e = 0.05 as 0.07 and 0.01 as 0.62, and at the
    limit e = 0.01 stopped the run, the sphere speeding up (issue 47, found from seed 57
    `spring_dashpot:26`)."""
    ds = run_collision(contact_law=law, target="wall", restitution=restitution,
                       integrator=integrator, dt_factor=dt_factor)
    assert float(ds.restitution_analytic) == pytest.approx(restitution, rel=1e-9)
    assert float(ds.restitution) == pytest.approx(restitution, rel=rel)


@pytest.mark.parametrize("integrator, damping_limit", [("verlet", 1.0), ("gear", 0.163)])
@pytest.mark.parametrize("restitution", [0.9, 0.05])
def test_the_hertz_step_bound_holds_the_dashpot_at_the_peak_overlap(integrator, damping_limit,
                                                                    restitution):
    """The Hertz contact bound, written out here: t_c / 10 (t_c = 2.87 (m*^2 / (R E*^2 v))^1/5)
    unless the EDEM dashpot's rate at the elastic peak overlap is faster, beta_term
    sqrt(S_n / m*) with S_n = 2 E* sqrt(R xi_max) and xi_max from (1/2) m* v^2 = (8/15) E*
    sqrt(R) xi_max^(5/2); then rate x dt <= 1 (Verlet) or 0.163 (Gear), a fifth of it
    recommended. e = 0.9 is not bound by its dashpot, e = 0.05 (beta_term 3.55) is."""
    from millsim.models import Material
    from millsim.models.contact import LAWS
    from millsim.models.contact.hertz_mindlin import hertz_beta_term

    law = LAWS["hertz_mindlin"]
    mat = Material("glass", 2500.0, 5e6, 0.3)
    row = law.parameter_row(mat, mat, {"restitution": restitution, "friction": 0.5,
                                       "rolling_friction": 0.0}, "clipped")
    m_eff, r_eff, v = 5.2e-6, 0.5e-3, 1.0
    e_star = 5e6 / (2 * (1 - 0.09))
    (_, bound), _ = law.bounds(mat, row, 1e-3, m_eff, r_eff, "pair", v, 3, integrator)
    t_c = 2.87 * (m_eff**2 / (r_eff * e_star**2 * v)) ** 0.2
    xi_max = (15 * m_eff * v**2 / (16 * e_star * math.sqrt(r_eff))) ** 0.4
    rate = hertz_beta_term(restitution, "clipped") * math.sqrt(
        2 * e_star * math.sqrt(r_eff * xi_max) / m_eff)
    dashpot = damping_limit / rate
    assert (dashpot < t_c / 10) == (restitution == 0.05)
    assert bound.limit == pytest.approx(min(t_c / 10, dashpot), rel=1e-12, abs=0.0)
    assert bound.recommended == pytest.approx(min(t_c / 50, dashpot / 5), rel=1e-12, abs=0.0)


def test_hertz_elastic_contact_time():
    """Undamped Hertz: t_c = 2.9433 xi_max / v, independent of the code."""
    for speed in (0.1, 1.0, 5.0):
        ds = run_collision(contact_law="hertz_mindlin", restitution=1.0, speed=speed)
        assert float(ds.restitution) == pytest.approx(1.0, abs=1e-3)
        assert float(ds.contact_time) == pytest.approx(float(ds.contact_time_analytic), rel=TOL)
        expected = 2.8683 * ((2500 * 4 / 3 * math.pi * 1e-9 / 2) ** 2
                             / (0.5e-3 * (5e6 / (2 * (1 - 0.09))) ** 2 * speed)) ** 0.2
        assert float(ds.contact_time_analytic) == pytest.approx(expected, rel=1e-3)


@pytest.mark.parametrize("restitution", [0.3, 0.5, 0.9])
def test_hertz_clipped_contact_time_and_speed_independence(restitution):
    """The restitution itself: tests/test_restitution.py."""
    ds = run_collision(contact_law="hertz_mindlin", restitution=restitution)
    assert float(ds.contact_time) == pytest.approx(float(ds.contact_time_analytic), rel=TOL)
    # Independent of impact speed (a property of this damping law).
    fast = run_collision(contact_law="hertz_mindlin", restitution=restitution, speed=4.0)
    assert float(fast.restitution) == pytest.approx(float(ds.restitution), rel=TOL)


@pytest.mark.parametrize("dt_factor", [0.6, 1.0])
@pytest.mark.parametrize("target", ["particle", "wall"])
def test_a_clipped_contact_ends_at_the_first_step_without_force(target, dt_factor):
    """A clipped force reaches 0 and stays there, so the clipped convention's end is the first
    recorded step without normal force: on a coarse step (50-115 steps a contact) the measured
    contact time is the analytic one (Schwager & Poeschel 2007) up to one step late, never
    more (the start, where the overlap crosses 0 at constant speed, is interpolated exactly)."""
    scene = get_scene("collision")
    ds, provenance = scene.run(scene.resolve(dict(contact_law="linear_hw", dim=2, target=target,
                                                  convention="clipped", dt_factor=dt_factor)),
                               RunContext())
    late = float(ds.contact_time) - float(ds.contact_time_analytic)
    assert 0.0 < late <= provenance["dt"]


def test_the_collision_reports_progress_below_one_until_it_is_done(monkeypatch):
    """A case's progress is the fraction done in [0, 1] (scenes/driver.py): a collision that
    parts long before its cap of twenty contact times reports fractions that grow from the
    first chunk on and stay below 1."""
    seen = [fraction for fraction, _ in progress_of(monkeypatch, "collision", {})]
    assert len(seen) > 10
    assert seen == sorted(seen)
    assert 0.0 < seen[0] and seen[-1] < 1.0
