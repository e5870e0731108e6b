"""What the stirred mill measures (scenes/stirred_observables.py), on states set by hand: the
springs' stored energy against 1/2 k xi^2 per contact; which collisions the Sampler counts and in
which region, and which beads its coarse-grained slab sees in which cell, against the regions and
cells worked out here from the positions alone."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from millsim.scenes.stirred_observables import CG_FIELDS, Sampler, elastic_energy

from one_particle import K_N, WALL_VERLET, make_sim

R, LENGTH, CELLS = 0.04, 0.09, 8
# three disks 30 mm apart along x, 6 mm thick: the slab runs from the middle disk's back face
# (x = 48 mm) halfway to the next disk (x = 60 mm)
GEOMETRY = dict(chamber_radius=R, disk_x=np.array([0.015, 0.045, 0.075]), disk_thickness=0.006,
                pitch=0.03, length=LENGTH, x_lo=0.0)


class _Mill:
    """What Sampler reads of a Simulation: particles (x, v, w, body), the pairs in contact."""

    def __init__(self, x, body, pairs, v=None, w=None):
        n = len(x)
        self.particles = SimpleNamespace(x=np.asarray(x, float), body=np.asarray(body),
                                         v=np.zeros((n, 3)) if v is None else np.asarray(v, float),
                                         w=np.zeros((n, 3)) if w is None else np.asarray(w, float))
        self.n_particles = n
        self.free = self.particles.body < 0
        self.pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)

    def contact_pairs(self):
        i, j = self.pairs.T
        return i, j, np.full(len(i), 1e-6)


def _region(mid):
    """Equal-volume rings of the empty cylinder (rho^2 / R^2 in thirds), thirds of the length."""
    ring = min(int(3 * (mid[1] ** 2 + mid[2] ** 2) / R**2), 2)
    return 3 * ring + min(int(3 * mid[0] / LENGTH), 2)


def test_new_bead_collisions_are_counted_once_in_the_region_of_their_midpoint():
    """A bead pair near the axis in the front third, one in the outer ring at the back, and a
    bead against a member of the agitator (body 0): two collisions, one in each region of a
    midpoint; at the next sample the same contacts are not new."""
    x = [(0.010, 0.001, 0.002), (0.010, 0.003, 0.002),  # inner ring, front
         (0.080, 0.0, 0.035), (0.082, 0.0, 0.037),  # outer ring, back
         (0.050, 0.02, 0.0), (0.050, 0.022, 0.0)]  # the agitator and a bead
    sim = _Mill(x, body=[-1, -1, -1, -1, 0, -1], pairs=[(0, 1), (2, 3), (4, 5)])
    sampler = Sampler(dict(cg_cells=CELLS, slice=False), GEOMETRY)
    sampler.sample(sim, 1e-3)
    expected = np.zeros(9)
    for a, b in ((0, 1), (2, 3)):
        expected[_region(0.5 * (np.array(x[a]) + np.array(x[b])))] += 1
    assert sorted(np.flatnonzero(expected)) == [0, 8]
    np.testing.assert_array_equal(sampler.collisions, expected)
    sampler.sample(sim, 1e-3)
    np.testing.assert_array_equal(sampler.collisions, expected)
    assert sampler.window_time == pytest.approx(2e-3)


@pytest.mark.parametrize("mirror", [False, True])
def test_the_slab_sees_the_beads_between_a_disk_and_the_midplane_in_their_cells(mirror):
    """Beads in the slab behind the middle disk (and, in a slice, the mirror slab in front of
    it) are sampled in the (z, y) cell of 2 R / cells each, with their speed; beads outside
    the slab are not. Cells counted here by floor((y + R) / (2 R / cells))."""
    width = 2 * R / CELLS
    geometry = GEOMETRY
    if mirror:  # one disk at x = 0 in a periodic slice
        geometry = dict(GEOMETRY, disk_x=np.array([0.0]), x_lo=-0.015, length=0.03)
    face = geometry["disk_x"][len(geometry["disk_x"]) // 2] + 0.003
    inside_x = [face + 0.001, face + 0.011] + ([-(face + 0.004)] if mirror else [])
    outside_x = [face - 0.001, face + 0.013]
    yz = [(-0.031, 0.017), (0.006, -0.038), (0.025, 0.025), (0.0, 0.0)]
    x = [(xi, y, z) for xi, (y, z) in zip(inside_x + outside_x, yz + yz)]
    v = [(0.0, 0.3 * (k + 1), 0.4 * (k + 1)) for k in range(len(x))]
    sim = _Mill(x, body=np.full(len(x), -1), pairs=[], v=v)
    sampler = Sampler(dict(cg_cells=CELLS, slice=mirror), geometry)
    sampler.sample(sim, 1e-3)
    samples = np.zeros((CELLS, CELLS))
    speed = np.zeros((CELLS, CELLS))
    for k in range(len(inside_x)):
        iy, iz = (math.floor((c + R) / width) for c in yz[k])
        samples[iz, iy] += 1
        speed[iz, iy] += 0.5 * (k + 1)
    np.testing.assert_array_equal(sampler.cg[CG_FIELDS.index("cg_samples")], samples)
    np.testing.assert_allclose(sampler.cg[CG_FIELDS.index("cg_speed")], speed, rtol=1e-12)


def test_the_springs_store_half_k_xi_squared_for_pairs_planes_and_both_cylinders():
    """Linear springs: 1/2 k_n xi^2 per contact, a pair, the floor, a drum's shell from inside
    and a shaft from outside, each pressed in by its own overlap at construction (no step)."""
    r = 1e-3
    walls = [dict(kind="plane", point=(0, 0, -0.015), normal=(0, 0, 1), material="m"),
             dict(kind="cylinder_inner", point=(0, 0, 0), axis=(1, 0, 0), radius=0.02, material="m"),
             dict(kind="cylinder_outer", point=(0, 0, 0), axis=(1, 0, 0), radius=0.004,
                  material="m")]
    xi = (1e-5, 2e-5, 3e-5, 4e-5)  # pair, floor, shell, shaft
    x = [(0.0, 0.008, 0.008), (0.0, 0.008, 0.008 + 2 * r - xi[0]),
         (0.01, 0.0, -0.015 + r - xi[1]),
         (0.02, 0.0, 0.02 - r + xi[2]),
         (0.03, 0.0, 0.004 + r - xi[3])]
    sim = make_sim(WALL_VERLET, x, walls=walls)
    normal, tangential = elastic_energy(sim, K_N, 0.5 * K_N)
    assert normal == pytest.approx(0.5 * K_N * sum(v**2 for v in xi), rel=1e-9)
    assert tangential == 0.0
