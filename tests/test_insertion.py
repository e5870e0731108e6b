"""Pouring a charge (engine.insertion.Pour, issue 17 item 3): the schedule rate x time, no
particle placed overlapping another or a wall, sizes drawn from the asked distribution (KS and
chi-square tests at 99 % confidence, fixed seeds), congestion carried over without biasing the
sizes, the same charge from the same seed, and one-line refusals of bad pours.
"""

import math

import numpy as np
import pytest
from scipy import stats
from scipy.spatial import cKDTree

from millsim.engine import PhysicsSpec, Pour, Simulation, StepPolicy
from millsim.models import Interaction, Material, MaterialTable

# linear law with walls: the variant tests/test_wall_kinds.py compiles already
SPEC = PhysicsSpec(dim=3, walls=True)
BOX = 0.02
RATE = 20000.0


def _table():
    return MaterialTable([Material("m", 2500.0)], {"*": Interaction(
        restitution=0.5, friction=0.3, normal_stiffness=2e3)}, "linear_history")


def _walls():
    return [dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="m"),
            dict(kind="plane", point=(0, 0, 0), normal=(1, 0, 0), material="m"),
            dict(kind="plane", point=(BOX, 0, 0), normal=(-1, 0, 0), material="m"),
            dict(kind="plane", point=(0, 0, 0), normal=(0, 1, 0), material="m"),
            dict(kind="plane", point=(0, BOX, 0), normal=(0, -1, 0), material="m")]


def _pour(**changes):
    values = dict(lo=(0.0, 0.0, 0.02), hi=(BOX, BOX, 0.03), count=300, rate=RATE, material="m",
                  radius_range=(0.5e-3, 1e-3), seed=3, velocity=(0.0, 0.0, -0.5))
    values.update(changes)
    return Pour(**values)


def _assert_clear(sim, new, pour):
    """The particles just placed overlap nothing and lie inside the region."""
    p = sim.particles
    tree = cKDTree(p.x)
    for i in new:
        for j in tree.query_ball_point(p.x[i], p.radius[i] + 2e-3):
            if j != i:
                assert np.linalg.norm(p.x[i] - p.x[j]) >= p.radius[i] + p.radius[j]
        assert (p.x[i] >= pour.lo + p.radius[i]).all() and (p.x[i] <= pour.hi - p.radius[i]).all()


def _run(pour, t_end=0.02, chunk_t=1e-3):
    x, r = pour.first()
    sim = Simulation(SPEC, _table(), x=x, radius=r, material="m", walls=_walls(),
                     step=StepPolicy(dt=2e-6))
    steps = int(round(chunk_t / sim.dt))
    fills = []
    while sim.time < t_end:
        new = pour.fill(sim)
        _assert_clear(sim, new, pour)
        fills.append((sim.time, sim.n_particles, pour.backlog))
        sim.run(steps, chunk=steps)
    return sim, fills


def test_pour_follows_its_schedule_and_places_nothing_overlapping():
    pour = _pour()
    sim, fills = _run(pour)
    for t, n, backlog in fills:
        # the k-th particle is due at k / rate after the first
        assert n + backlog == min(300, math.floor(RATE * t + 1e-9) + 1)
    assert pour.done and sim.n_particles == 300
    assert sum(backlog for *_, backlog in fills) == 0  # the region never congested


def test_poured_sizes_follow_the_asked_distributions():
    """Uniform radii: Kolmogorov-Smirnov against U(0.5, 1) mm; discrete radii 1 mm : 0.5 mm at
    number fractions 0.2 : 0.8: chi-square. Both at 99 % (fixed seeds: a sound sampler fails with
    probability 0.01 over seeds, a biased one, e.g. one that drops large sizes that do not fit,
    fails)."""
    sim, _ = _run(_pour())
    r = sim.particles.radius
    assert stats.kstest(r, stats.uniform(0.5e-3, 0.5e-3).cdf).pvalue > 0.01
    sim, _ = _run(_pour(radius_range=None, radii=(1e-3, 0.5e-3), fractions=(0.2, 0.8), seed=4))
    r = sim.particles.radius
    counts = [np.sum(r == 1e-3), np.sum(r == 0.5e-3)]
    assert sum(counts) == 300
    assert stats.chisquare(counts, [0.2 * 300, 0.8 * 300]).pvalue > 0.01


def test_congested_region_carries_over_without_biasing_sizes():
    """A region a few particles wide, poured a hundred times faster than it clears: the fills
    fall behind (backlog), place nothing overlapping, and catch up as the charge falls out."""
    pour = _pour(lo=(0.008, 0.008, 0.02), hi=(0.012, 0.012, 0.024), count=60, rate=2e6,
                 radius_range=(0.5e-3, 1e-3), velocity=(0.0, 0.0, -0.5))
    sim, fills = _run(pour, t_end=0.05)
    assert max(backlog for *_, backlog in fills) > 0
    assert pour.done and sim.n_particles == 60
    assert stats.kstest(sim.particles.radius, stats.uniform(0.5e-3, 0.5e-3).cdf).pvalue > 0.01


def test_a_pour_not_yet_filled_is_behind_by_nothing():
    """backlog counts the particles due at the last fill that did not fit: none before the first
    fill, also after the first particle is placed for the Simulation (seed 57, `insertion:82`)."""
    pour = _pour()
    assert pour.backlog == 0
    pour.first()
    assert pour.backlog == 0


def test_same_seed_same_charge():
    a, _ = _run(_pour(), t_end=0.005)
    b, _ = _run(_pour(), t_end=0.005)
    np.testing.assert_array_equal(a.particles.x, b.particles.x)
    np.testing.assert_array_equal(a.particles.radius, b.particles.radius)


@pytest.mark.parametrize("changes,message", [
    (dict(hi=(BOX, BOX, 0.01)), r"pour.hi: must exceed lo on every axis"),
    (dict(radii=(1e-3,)), r"pour: give radii \(with fractions\) or radius_range, not both"),
    (dict(radius_range=(1e-3, 0.5e-3)), r"pour.radius_range: need 0 < min <= max"),
    (dict(radius_range=None, radii=(1e-3, 2e-3), fractions=(1.0,)), r"pour.fractions: one"),
    (dict(radius_range=None, radii=(1e-3, 2e-3), fractions=(0.0, 0.0)), r"pour.fractions: one"),
    (dict(radius_range=None, radii=(1e-3, 0.0)), r"pour.radii: must be > 0"),
    (dict(radius_range=(1e-3, 6e-3)), r"pour: the region .* is narrower than the largest"),
    (dict(rate=0.0), r"pour.rate"),
    (dict(count=0), r"pour.count"),
])
def test_bad_pour_refused_naming_the_key(changes, message):
    with pytest.raises(ValueError, match=message):
        _pour(**changes)
