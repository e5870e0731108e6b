"""The rays a liner is checked by (scenes/liner_rays.py), against a liner whose distances from
the axis are known in closed form: a square tube, half-width a over the lower half of its length
and b over the upper half."""

import math

import numpy as np
import pytest

from millsim.engine.mesh_io import box_mesh
from millsim.scenes.liner_rays import axis_rays

LENGTH, THICK = 0.04, 0.005


def _square_tube(half, y0, y1):
    """Four slabs around the y axis: a hollow of half-width ``half`` from y0 to y1."""
    h, t = half, THICK
    slabs = [((h, y0, -h - t), (h + t, y1, h + t)), ((-h - t, y0, -h - t), (-h, y1, h + t)),
             ((-h, y0, h), (h, y1, h + t)), ((-h, y0, -h - t), (h, y1, -h))]
    parts = [box_mesh(lo, hi) for lo, hi in slabs]
    vertices = np.vstack([v for v, _ in parts])
    faces = np.vstack([f + 8 * k for k, (_, f) in enumerate(parts)])
    return vertices, faces


@pytest.mark.parametrize("rays, heights", [(36, 4), (360, 10)])
def test_the_rays_sample_every_direction_and_both_halves_evenly(rays, heights):
    """A ray at angle theta from the axis meets a square hollow of half-width w at
    w / max(|cos theta|, |sin theta|). Over a fan of equal angles the mean of w / d is then the
    mean of max(|cos|, |sin|) over a turn, 2 sqrt(2) / pi, to the quadrature error of a function
    with kinks (0.25 % with 36 rays; a fan bunched in one direction gives up to 1, 11 % more),
    and equally spaced heights see each half of the tube equally often."""
    a, b = 0.02, 0.03
    lower, upper = _square_tube(a, 0.0, LENGTH / 2), _square_tube(b, LENGTH / 2, LENGTH)
    vertices = np.vstack([lower[0], upper[0]])
    faces = np.vstack([lower[1], upper[1] + len(lower[0])])
    dist = axis_rays("tube.stl", vertices, faces, LENGTH, rays, heights, "")
    assert dist.shape == (heights, rays)
    width = np.where(np.arange(heights) < heights / 2, a, b)[:, None]
    np.testing.assert_allclose((width / dist).mean(axis=1), 2 * math.sqrt(2) / math.pi, rtol=5e-3)
    assert ((dist > 0.9 * a) & (dist < 1.5 * a)).sum(axis=0).tolist() == [heights // 2] * rays
