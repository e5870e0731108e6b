"""The 2D ball mill's start (scenes/ballmill2d.py), no run: the grain count from the filling and
where the first grains are placed, against the area and the level worked out here."""

import math

import numpy as np

from millsim.scenes import ballmill2d as bm


def test_the_grain_count_fills_the_drum_at_random_2d_packing():
    """filling x 0.82 (random 2D disk packing) x pi R^2 over the mean grain area, the radii
    uniform on r (1 +- s): E[pi r^2] = pi r^2 (1 + s^2 / 3), by quadrature here."""
    values = dict(drum_radius=0.05, filling=0.4, n_grains=0, grain_radius=2.5e-3,
                  grain_radius_spread=0.5)
    r = 2.5e-3 * np.linspace(0.5, 1.5, 200_001)
    mean_area = math.pi * float(np.mean(r**2))
    assert bm.grain_count(values) == round(0.4 * 0.82 * math.pi * 0.05**2 / mean_area)
    assert bm.grain_count(dict(values, n_grains=17)) == 17


def test_the_first_grains_lie_below_half_the_radius_and_reach_up_to_it():
    """Grains are drawn below a level that starts half the free radius below the axis and
    rises only when spots run out: a few small grains all lie below it, spread over its
    segment (some higher than 0.7 of the radius below the axis; a grain above that line has
    about even odds, so 30 miss it with odds 1e-9)."""
    values = dict(drum_radius=0.05, lifter_height=5e-3, grain_radius=1e-3, grain_radius_spread=0.1)
    free = 0.05 - 5e-3
    x, r = bm._random_grains(values, 30, np.random.default_rng(4), np.zeros((0, 2)), np.zeros(0))
    y = np.asarray(x)[:, 1]
    assert len(y) == 30
    assert y.max() <= -0.5 * free
    assert y.max() > -0.7 * free
    gap = np.linalg.norm(np.asarray(x)[:, None] - np.asarray(x)[None], axis=2)
    np.fill_diagonal(gap, np.inf)
    assert (gap >= np.add.outer(r, r) * (1 - 1e-12)).all()
    assert np.hypot(*np.asarray(x).T).max() <= free - np.min(r) * (1 - 1e-12)
    assert ((r >= 0.9e-3) & (r <= 1.1e-3)).all()
