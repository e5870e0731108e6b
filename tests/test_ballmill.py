"""Seed 000 fragmentation: fragment sampler, split geometry, fracture statistics, mass bookkeeping."""

import math

import numpy as np
import pytest
from scipy import stats

from millsim.breakage.weibull import (fracture_probability, rosin_rammler_cdf, rosin_rammler_radius,
                                      split_disk)
from millsim.engine import Interaction, Material, MaterialTable, PhysicsSpec, Simulation
from millsim.scenes.base import RunContext, get_scene


def test_rosin_rammler_sampler_matches_its_cdf():
    rng = np.random.default_rng(7)
    parent = 2e-3
    r = rosin_rammler_radius(parent, rng.uniform(size=20000))
    assert r.max() <= 0.75 * parent
    # KS at the 1% level: the sampler is the exact inverse of the truncated CDF.
    assert stats.kstest(r, lambda q: rosin_rammler_cdf(q, parent)).pvalue > 0.01
    # Analytic mean of the truncated law (ballmill.md section 6): 0.3286 R.
    assert r.mean() / parent == pytest.approx(0.3286, abs=0.005)


def test_split_conserves_area_and_stays_inside_the_parent():
    rng = np.random.default_rng(3)
    for _ in range(200):
        parent = rng.uniform(1e-3, 5e-3)
        center = np.array([rng.uniform(-1, 1), rng.uniform(-1, 1), 0.0])
        phi = rng.uniform(0, 2 * math.pi)
        force = np.array([math.cos(phi), math.sin(phi), 0.0])
        centres, radii = split_disk(center, parent, force, rng.uniform())
        assert (radii**2).sum() == pytest.approx(parent**2, rel=1e-14)
        assert (np.linalg.norm(centres - center, axis=1) + radii <= parent * (1 + 1e-12)).all()
        # Opened across the force: the centres line up perpendicular to it.
        assert abs(np.dot(centres[0] - centres[1], force)) < 1e-12


def _colliding_pairs(count, speed, c, dt_factor=1.0, seed=5):
    """Identical head-on disk pairs far apart: one contact event each, the same peak force."""
    r = 2e-3
    table = MaterialTable([Material("g", 2000.0)], {"*": Interaction(
        friction=0.5, normal_stiffness=8e3, normal_damping_rate=800.0, tangential_damping_rate=3000.0)},
        "linear_hw")
    spec = PhysicsSpec(dim=2, contact_law="linear_hw", gravity=False, fracture="weibull")
    x, v = [], []
    for k in range(count):
        base = np.array([0.02 * (k % 40), 0.02 * (k // 40)])
        x += [base + [-r - 1e-5, 0], base + [r + 1e-5, 0]]
        v += [[speed / 2, 0], [-speed / 2, 0]]
    sim = Simulation(spec, table, x=np.array(x), radius=np.full(2 * count, r), material="g",
                     v=np.array(v), thickness=0.01, fracture_c=c, seed=seed, impact_speed=speed)
    sim.set_time_step(sim.dt_report.recommended * dt_factor)
    broken = []

    def collect(s):
        broken.extend(s.pop_fractures())

    sim.run(int(3e-3 / sim.dt), chunk=10**6, on_fracture=collect)
    return broken, r


@pytest.mark.parametrize("dt_factor", [1.0, 0.5])
def test_fracture_decisions_follow_the_weibull_probability(dt_factor):
    """One trial per particle per contact event at its peak force; fraction within 99% CI of P."""
    count = 400
    c = 7e-9
    broken, r = _colliding_pairs(count, 1.0, c, dt_factor)
    force = broken[0][2]
    assert all(b[2] == pytest.approx(force, rel=1e-9) for b in broken)  # same peak force everywhere
    p = fracture_probability(c, r, force)
    assert 0.2 < p < 0.8  # the test is informative
    trials = 2 * count
    k = len(broken)
    assert len({b[0] for b in broken}) == k  # a particle is tried once per event
    lo, hi = stats.binom.ppf([0.005, 0.995], trials, p)
    assert lo <= k <= hi, (k, trials * p)


def test_mill_conserves_mass_with_dust_and_refill():
    scene = get_scene("ballmill2d")
    values = scene.resolve(dict(duration=0.25, transient=0.05, weibull_c=1e-8, sieve_radius=1.2e-3,
                                record_interval=0.01, snapshot_interval=0.05))
    ds, _ = scene.run(values, RunContext())
    assert int(ds.fracture_events[-1]) > 20
    assert float(ds.dust_mass[-1]) > 0
    initial = float(ds.grains[0])  # sanity: grains present throughout
    assert initial > 50
    raw = 2000.0 * math.pi * values["grain_radius"] ** 2 * values["thickness"]
    assert abs(float(ds.mass_balance_error)) < 1e-9 * raw * initial
    # Refill happened: more dust left than a raw grain's mass means grains were returned.
    assert float(ds.dust_mass[-1]) > raw


def test_force_chain_variant_carries_no_breakage_outputs():
    scene = get_scene("ballmill2d")
    values = scene.resolve(dict(fragmentation=False, drum_radius=0.04, n_grains=300, grain_radius=0.8e-3,
                                grain_radius_spread=0.375, sieve_radius=0.3e-3, wall_radius=0.6e-3,
                                lifter_height=2e-3, duration=0.3, transient=0.1, n_over_nc=0.64,
                                chain_threshold=0.01))
    ds, _ = scene.run(values, RunContext())
    assert "event_time" not in ds and "size_distribution" not in ds and "fracture_frequency" not in ds
    assert float(ds.chain_count.sum()) > 0
    assert np.isfinite(ds.pressure).any()
