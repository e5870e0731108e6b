"""Neighbour lists, determinism, guards, time-step refusal, bodies, adding and removing particles."""

import math

import numpy as np
import pytest

from millsim.engine import (
    Guards,
    PhysicsSpec,
    Simulation,
    SimulationError,
    StepPolicy,
    TimeStepError,
)
from millsim.engine.neighbours import brute_force_pairs, build_verlet
from millsim.engine.state import empty_contacts
from millsim.models import Interaction, Material, MaterialTable

from helpers import dense_bed as _dense_bed


def _table(law="hertz_mindlin", **inter):
    return MaterialTable([Material("m", 2500.0, 5e6, 0.3)], {"*": Interaction(**inter)}, law)


def _pairs(start, nbr):
    return {(i, int(j)) for i in range(len(start) - 1) for j in nbr[start[i]:start[i + 1]]}


@pytest.mark.parametrize("dim,periodic", [(3, False), (3, True), (2, False), (2, True)])
def test_verlet_list_equals_brute_force(dim, periodic):
    rng = np.random.default_rng(11)
    n, box = 400, 0.03
    x = rng.uniform(0, box, (n, 3))
    if dim == 2:
        x[:, 2] = 0
    r = rng.uniform(0.3e-3, 1.5e-3, n)  # polydisperse, overlaps allowed: geometry only
    body = np.where(rng.random(n) < 0.2, 0, -1).astype(np.int32)
    box_len = np.array([box, box, box if dim == 3 else 0.0]) if periodic else np.zeros(3)
    skin = 0.4e-3
    c = empty_contacts(n, 3)
    start, nbr, state, rev_start, rev_slot = build_verlet(x, r, body, skin, dim, np.zeros(3),
                                                          box_len, c.start, c.nbr, c.state)
    assert _pairs(start, nbr) == brute_force_pairs(x, r, body, skin, box_len)
    assert all((np.diff(nbr[start[i]:start[i + 1]]) > 0).all() for i in range(n))  # sorted rows
    # The reverse index lists every slot exactly once, under its j partner.
    assert sorted(rev_slot.tolist()) == list(range(len(nbr)))
    for j in range(n):
        assert (nbr[rev_slot[rev_start[j]:rev_start[j + 1]]] == j).all()


@pytest.mark.parametrize("periodic", [False, True])
def test_verlet_list_at_wide_size_ratios_equals_brute_force(periodic):
    """Multi-level grid: radii over a factor 40 (four levels, two empty radius classes dropped),
    particles straddling periodic faces; the list must still equal the O(N^2) one."""
    rng = np.random.default_rng(5)
    box = 0.03
    # large first: their rows hold the small neighbours, and their reach spans the periodic box
    # on the middle level (each wrapped cell must be visited once)
    r = np.concatenate([[4e-3, 5e-3, 8e-3, 10e-3], rng.uniform(0.25e-3, 0.45e-3, 600),
                        rng.uniform(2.0e-3, 2.4e-3, 40)])
    n = len(r)
    x = rng.uniform(0, box, (n, 3))
    x[:4] = [[0.001, 0.015, 0.015], [0.029, 0.029, 0.001], [0.015, 0.015, 0.015],
             [0.02, 0.0, 0.025]]
    body = np.where(rng.random(n) < 0.1, 0, -1).astype(np.int32)
    box_len = np.full(3, box) if periodic else np.zeros(3)
    skin = 0.2e-3
    c = empty_contacts(n, 3)
    start, nbr, *_ = build_verlet(x, r, body, skin, 3, np.zeros(3), box_len, c.start, c.nbr,
                                  c.state)
    expected = brute_force_pairs(x, r, body, skin, box_len)
    assert _pairs(start, nbr) == expected
    assert len(nbr) == len(expected)  # no pair listed twice
    # the large spheres do have small neighbours: the levels were searched across
    assert sum(1 for i, j in expected if min(r[i], r[j]) < 0.5e-3 and max(r[i], r[j]) > 3e-3) > 50


def test_verlet_list_over_several_front_blocks_equals_kd_tree():
    """The rebuild's front (bounding box, size classes, largest radius per level) is reduced over
    blocks of FRONT_BLOCK particles: with the largest spheres, a size class of their own, only in
    the last block, a combine that dropped a block would size that level's search by the others
    and miss their pairs. Reference: scipy's k-d tree, then the exact cut r_i + r_j + skin."""
    from scipy.spatial import cKDTree

    from millsim.engine.neighbours import FRONT_BLOCK

    rng = np.random.default_rng(17)
    n, box, skin = 3 * FRONT_BLOCK + 600, 0.04, 0.2e-3
    x = rng.uniform(0, box, (n, 3))
    r = rng.uniform(0.3e-3, 0.5e-3, n)
    large = n - 1 - np.arange(0, 80, 10)  # in the last block only
    r[large] = 4e-3
    body = -np.ones(n, dtype=np.int32)
    c = empty_contacts(n, 3)
    start, nbr, *_ = build_verlet(x, r, body, skin, 3, np.zeros(3), np.zeros(3), c.start, c.nbr,
                                  c.state)
    i, j = cKDTree(x).query_pairs(2 * r.max() + skin, output_type="ndarray").T
    d = x[i] - x[j]
    cut = r[i] + r[j] + skin
    keep = (d * d).sum(1) < cut * cut
    expected = {(int(min(a, b)), int(max(a, b))) for a, b in zip(i[keep], j[keep])}
    assert _pairs(start, nbr) == expected
    assert sum(1 for a, b in expected if b in set(large.tolist())) > 100  # they have neighbours


def test_contact_state_survives_rebuild():
    rng = np.random.default_rng(2)
    n = 200
    x = rng.uniform(0, 0.02, (n, 3))
    r = np.full(n, 1e-3)
    body = np.full(n, -1, dtype=np.int32)
    c = empty_contacts(n, 3)
    args = (r, body, 2e-4, 3, np.zeros(3), np.zeros(3))
    start, nbr, state, *_ = build_verlet(x, *args, c.start, c.nbr, c.state)
    state[:] = rng.random(state.shape)
    remember = {p: state[k].copy() for k, p in enumerate(sorted(_pairs(start, nbr)))}
    x2 = x + rng.normal(0, 5e-5, x.shape)
    s2, n2, st2, *_ = build_verlet(x2, *args, start, nbr, state)
    new_pairs = sorted(_pairs(s2, n2))
    for k, p in enumerate(new_pairs):
        if p in remember:
            np.testing.assert_array_equal(st2[k], remember[p])
        else:
            assert (st2[k] == 0).all()


def test_same_numbers_on_one_and_two_threads():
    """Fixed-block reductions: bit-identical trajectories whatever the thread count."""
    import numba

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("needs 2 threads")
    runs = []
    for threads in (1, 2):
        sim = _dense_bed(2600)  # above the serial threshold, so 2 threads really run in parallel
        sim.run(400, chunk=200, threads=threads)
        runs.append((sim.particles.x.copy(), sim.particles.w.copy(),
                     [sim.impulse(wall=k) for k in range(len(sim.walls))]))
    for a, b in zip(*runs):
        np.testing.assert_array_equal(a, b)


def test_same_seed_same_numbers():
    a, b = _dense_bed(300, seed=9), _dense_bed(300, seed=9)
    a.run(500)
    b.run(500)
    np.testing.assert_array_equal(a.particles.x, b.particles.x)


def test_time_step_above_limit_is_refused():
    spec = PhysicsSpec(dim=3, gravity=False)
    kw = dict(x=[[0, 0, 0], [3e-3, 0, 0]], radius=[1e-3, 1e-3], material="m")
    sim = Simulation(spec, _table(), **kw)
    limit = sim.dt_report.limit
    with pytest.raises(TimeStepError, match="stability limit") as info:
        Simulation(spec, _table(), step=StepPolicy(dt=1.01 * limit), **kw)
    assert "Rayleigh" in str(info.value) or "Hertz contact time" in str(info.value)
    assert f"{limit:.4g}" in str(info.value)
    with pytest.raises(TimeStepError):
        sim.set_time_step(2 * limit)
    sim.set_time_step(limit)  # the limit itself is allowed


def test_limit_shrinks_when_fragments_appear():
    spec = PhysicsSpec(dim=3, gravity=False)
    sim = Simulation(spec, _table(), x=[[0, 0, 0]], radius=[2e-3], material="m")
    before = sim.dt_report.limit
    sim.add_particles([[0.01, 0, 0]], [1e-4], "m")
    assert sim.dt_report.limit < before / 5
    assert sim.dt <= sim.dt_report.limit


def test_nan_guard_names_particle_and_step():
    spec = PhysicsSpec(dim=3, gravity=False)
    x = [[0.01 * k, 0, 0] for k in range(10)]
    sim = Simulation(spec, _table(), x=x, radius=np.full(10, 1e-3), material="m")
    sim.run(10)
    sim.particles.v[7, 0] = np.nan
    with pytest.raises(SimulationError, match=r"step 10 .*particle 7 has a non-finite"):
        sim.run(10)


def test_nan_spreading_through_contacts_is_caught_in_its_step():
    sim = _dense_bed(50)
    sim.run(10)
    sim.particles.v[7, 0] = np.nan
    with pytest.raises(SimulationError, match=r"step 10 .*non-finite"):
        sim.run(10)


@pytest.mark.parametrize("force_sum", ["records", "colour"])
def test_overlap_guard(force_sum):
    """Both force sums (the slot-record pass and the colour pass) stop on an overlap."""
    spec = PhysicsSpec(dim=3, gravity=False, force_sum=force_sum)
    sim = Simulation(spec, _table(), x=[[0, 0, 0], [3e-3, 0, 0]], radius=[1e-3, 1e-3], material="m",
                     guards=Guards(max_overlap=0.3))
    sim.particles.x[1, 0] = 1.2e-3  # jumped into overlap between chunks
    with pytest.raises(SimulationError, match=r"step \d+ .*particle 0 and particle 1.*0.3 of the smaller radius"):
        sim.run(5)


@pytest.mark.parametrize("peak", [0.74, 0.76])
def test_overlap_guard_against_the_hertz_peak_of_a_head_on_hit(peak):
    """Two equal elastic Hertz spheres meet head on at the speed whose analytic peak overlap
    (Johnson 1985, 11.2: delta = (15 m* v^2 / (16 sqrt(R*) E*))^(2/5)) is ``peak`` radii, at half
    the step limit: below the 0.75 guard the hit runs through, above it the run stops naming the
    contact's softness, not dt, as the cause."""
    radius, density, young, poisson = 1e-3, 2500.0, 5e6, 0.3
    m_eff = density * 4.0 / 3.0 * math.pi * radius**3 / 2
    r_eff, e_eff = radius / 2, young / (2 * (1 - poisson**2))
    speed = math.sqrt((peak * radius) ** 2.5 * 16 * math.sqrt(r_eff) * e_eff / (15 * m_eff))
    half = speed / 2
    sim = Simulation(PhysicsSpec(dim=3, gravity=False), _table(restitution=1.0, friction=0.0),
                     x=[[0, 0, 0], [2.1e-3, 0, 0]], radius=[radius, radius], material="m",
                     v=[[half, 0, 0], [-half, 0, 0]], guards=Guards(max_overlap=0.75),
                     step=StepPolicy(impact_speed=speed))
    sim.set_time_step(dt=0.5 * sim.dt_report.limit)
    steps = int(3 * 2.94 * peak * radius / speed / sim.dt)  # past the contact (t_c = 2.94 delta/v)
    if peak < 0.75:
        sim.run(steps)
        assert sim.particles.v[0, 0] == pytest.approx(-half, rel=1e-3)  # elastic rebound
    else:
        with pytest.raises(SimulationError, match=r"particle 0 and particle 1 exceeds 0.75 of the "
                           r"smaller radius; dt is 0.5 of its limit, so not the "
                           r"cause: the contact is too soft"):
            sim.run(steps)


def test_runaway_speed_guard():
    spec = PhysicsSpec(dim=3, gravity=False)
    sim = Simulation(spec, _table(), x=[[0, 0, 0]], radius=[1e-3], material="m", v=[[300.0, 0, 0]],
                     guards=Guards(v_max=100.0))
    with pytest.raises(SimulationError, match="runaway kinetic energy, particle 0"):
        sim.run(5)


@pytest.mark.parametrize("speed", [150.0, 250.0])
def test_the_default_speed_guard_is_ten_times_a_fast_impact_speed(speed):
    """Guards' documented default v_max is max(100 m/s, 10 x the impact speed): at an impact
    speed of 20 m/s the limit is 200 m/s, so a free particle at 150 m/s flies on and one at
    250 m/s stops the run."""
    sim = Simulation(PhysicsSpec(dim=3, gravity=False), _table(), x=[[0, 0, 0]], radius=[1e-3],
                     material="m", v=[[speed, 0, 0]], step=StepPolicy(impact_speed=20.0))
    if speed < 200.0:
        sim.run(5)
        assert sim.particles.v[0, 0] == speed
    else:
        with pytest.raises(SimulationError, match="runaway kinetic energy, particle 0"):
            sim.run(5)


def test_potential_energy_is_minus_m_g_dot_x_and_zero_without_gravity():
    """Two spheres of 2500 kg/m^3, one above the origin and one below, under g = (0, 0, -9.81):
    E = sum m g z, from their volumes; the same spheres without gravity hold none."""
    x, radius = [[0.0, 0.0, 0.3], [0.1, 0.0, -0.2]], [1e-3, 2e-3]
    mass = 2500.0 * 4.0 / 3.0 * math.pi * np.array(radius) ** 3
    with_g = Simulation(PhysicsSpec(dim=3), _table(), x=x, radius=radius, material="m",
                        gravity=(0.0, 0.0, -9.81))
    assert with_g.potential_energy() == pytest.approx(9.81 * (0.3 * mass[0] - 0.2 * mass[1]),
                                                      rel=1e-12)
    without = Simulation(PhysicsSpec(dim=3, gravity=False), _table(), x=x, radius=radius,
                         material="m")
    assert without.potential_energy() == 0.0


def test_remove_particles_keeps_contact_history():
    sim = _dense_bed(300)
    sim.run(1500)
    p_before = {}
    i, j, _ = sim.contact_pairs()
    c = sim.contacts
    slot = {(int(a), int(b)): k for a in range(sim.n_particles) for k, b in
            zip(range(c.start[a], c.start[a + 1]), c.nbr[c.start[a]:c.start[a + 1]])}
    for a, b in zip(i, j):
        p_before[(int(a), int(b))] = c.state[slot[(int(a), int(b))]].copy()
    remove = np.zeros(sim.n_particles, bool)
    remove[::7] = True
    new_index = np.cumsum(~remove) - 1
    sim.remove_particles(remove)
    c = sim.contacts
    slot = {(int(a), int(b)): k for a in range(sim.n_particles) for k, b in
            zip(range(c.start[a], c.start[a + 1]), c.nbr[c.start[a]:c.start[a + 1]])}
    kept = [(a, b) for (a, b) in p_before if not remove[a] and not remove[b]]
    assert len(kept) > 50
    for a, b in kept:
        np.testing.assert_array_equal(c.state[slot[(new_index[a], new_index[b])]], p_before[(a, b)])
    sim.run(100)  # and the run goes on


def test_kinematic_body_carries_weight_and_follows_its_motion():
    """A sphere resting on a static 'anvil' body: the body receives m g; a rotating body's
    particles follow the prescribed rotation exactly."""
    spec = PhysicsSpec(dim=3, bodies=True)
    r = 1e-3
    anvil = [[dx, dy, -r] for dx in (-1e-3, 1e-3) for dy in (-1e-3, 1e-3)]
    x = anvil + [[0, 0, 0.8e-3]]
    spinner = [[0.02, 0, 0], [0.02 + 3e-3, 0, 0]]
    x = np.array(x + spinner)
    body = [0, 0, 0, 0, -1, 1, 1]
    bodies = [dict(kind="rotate", center=(0, 0, 0), axis=(0, 0, 1), rate=0.0),
              dict(kind="rotate", center=(0.02, 0, 0), axis=(0, 0, 1), rate=10.0)]
    sim = Simulation(spec, _table(restitution=0.3, friction=0.5), x=x, radius=np.full(7, r),
                     material="m", body=body, bodies=bodies)
    sim.run(int(0.15 / sim.dt), chunk=2000)
    # settled: the force the anvil receives, as its impulse over a further 0.05 s
    j0, t0 = sim.impulse(body=0), sim.time
    sim.run(int(0.05 / sim.dt), chunk=2000)
    load = (sim.impulse(body=0) - j0) / (sim.time - t0)
    m = sim.masses()[4]
    assert load[2] == pytest.approx(-m * 9.81, rel=1e-3)
    assert np.abs(load[:2]).max() < 1e-3 * m * 9.81
    theta = 10.0 * sim.time
    expected = np.array([0.02 + 3e-3 * math.cos(theta), 3e-3 * math.sin(theta), 0])
    np.testing.assert_allclose(sim.particles.x[6], expected, atol=1e-12)


def test_smallest_radius_hint_sets_the_bound_from_the_start():
    """A scene that will create fragments down to r_min gets their step bound before they exist."""
    spec = PhysicsSpec(dim=3, gravity=False)
    hinted = Simulation(spec, _table(), x=[[0, 0, 0]], radius=[2e-3], material="m",
                        step=StepPolicy(smallest_radius=1e-4))
    grown = Simulation(spec, _table(), x=[[0, 0, 0]], radius=[2e-3], material="m")
    grown.add_particles([[0.01, 0, 0]], [1e-4], "m")
    assert hinted.dt_report.limit == pytest.approx(grown.dt_report.limit, rel=1e-12)
    hinted.add_particles([[0.01, 0, 0]], [1e-4], "m")
    assert hinted.dt_report.limit == pytest.approx(grown.dt_report.limit, rel=1e-12)


def test_fast_approach_from_outside_the_skin_is_caught_by_the_list():
    """Two spheres start 5.5 skins apart (not in the list) and close at 0.5 m/s: the list must be
    rebuilt once any particle has moved half a skin, so that the pair is listed before the surfaces
    meet; a list rebuilt later lets them interpenetrate unseen (no force, then an overlap far beyond
    the guard). The rebound is then the head-on one: restitution e by the law's definition."""
    spec = PhysicsSpec(dim=3, gravity=False)
    r, skin, v = 1e-3, 2e-4, 0.25
    e = 0.8
    sim = Simulation(spec, _table(restitution=e, friction=0.0),
                     x=[[0, 0, 0], [2 * r + 5.5 * skin, 0, 0]], radius=[r, r], material="m",
                     v=[[v, 0, 0], [-v, 0, 0]], skin=skin)
    steps = int(2 * (5.5 * skin / (2 * v)) / sim.dt)  # twice the time to close the gap
    sim.run(steps, chunk=steps)
    assert sim.particles.v[0, 0] == pytest.approx(-e * v, rel=0.02)
    assert sim.particles.v[1, 0] == pytest.approx(e * v, rel=0.02)


@pytest.mark.parametrize("seed", [0, 1])
def test_pair_pass_order_takes_every_slot_once_touching_first(seed):
    """The pair pass takes every slot once with its particle; in each of its ranges of equal
    size (in slot order) the touching slots first, then the others, each in slot order."""
    from millsim.engine.loop import pair_pass_order

    rng = np.random.default_rng(seed)
    rows = rng.integers(0, 12, 1000) * (np.arange(1000) < 700)  # long rows first, then none
    start = np.concatenate([[0], np.cumsum(rows)]).astype(np.int64)
    touching = rng.random(start[-1]) < 0.6
    slots, n_ranges = start[-1], 7
    slot, owner = pair_pass_order(start, touching, n_ranges)
    assert np.array_equal(owner, np.repeat(np.arange(1000), rows)[slot])
    for r in range(n_ranges):
        lo, hi = r * slots // n_ranges, (r + 1) * slots // n_ranges
        part = slot[lo:hi]
        assert np.array_equal(np.sort(part), np.arange(lo, hi))  # the range's slots, once each
        flags = touching[part]
        assert (np.diff(flags.astype(int)) <= 0).all()  # touching first
        assert (np.diff(part[flags]) > 0).all() and (np.diff(part[~flags]) > 0).all()
