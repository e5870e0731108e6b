"""Property-based checks (hypothesis) of the geometric kernels against brute force written here:
the closest point of a triangle (dense barycentric sampling), the distance to a frustum sheet
(dense sampling of the surface of revolution), the cells a neighbour search visits along an axis
(every point within reach falls in one of them), the pour's clearance (pairwise distances), and
a drawn cylinder wall and a drawn frustum about any axis (the distance of its vertices from the
axis line, their position along it).

Derandomized and few examples: deterministic and cheap in CI; the kernels are the compiled ones,
called from Python.
"""

import math

import numpy as np
from hypothesis import Phase, example, given, settings
from hypothesis import strategies as st

from millsim.engine import PhysicsSpec, Simulation
from millsim.engine.insertion import Pour
from millsim.engine.kinematics import FRUSTUM, WALL_COLUMNS
from millsim.engine.mesh import EDGE_AB, EDGE_AC, EDGE_BC, FACE, closest_on_triangle
from millsim.engine.neighbours import _cell_index, _cell_range
from millsim.engine.wall_geometry import WallTessellator
from millsim.engine.walls import wall_contact_bounded
from millsim.models import Interaction, Material, MaterialTable

from helpers import PourCharge

# no explain phase: it traces every line a failing example runs (slow, and memory-hungry with
# numpy arrays of this size)
CHEAP = settings(max_examples=40, deadline=None, derandomize=True,
                 phases=[Phase.explicit, Phase.reuse, Phase.generate, Phase.shrink])
coord = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
point = st.tuples(coord, coord, coord)


# ---- closest point of a triangle --------------------------------------------------------------

def _sampled_triangle(tri, k=300):
    """Points of the triangle on a barycentric grid of spacing 1/k (corners and edges included)."""
    i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
    keep = i + j <= k
    u, v = i[keep] / k, j[keep] / k
    return tri[0] + u[:, None] * (tri[1] - tri[0]) + v[:, None] * (tri[2] - tri[0])


@CHEAP
@given(a=point, b=point, c=point, y=st.tuples(*[st.floats(-2.0, 2.0)] * 3))
def test_closest_point_of_a_triangle_is_the_nearest_point_of_it(a, b, c, y):
    tri = np.array([a, b, c], float)
    area2 = np.linalg.norm(np.cross(tri[1] - tri[0], tri[2] - tri[0]))
    if area2 < 0.05:  # a sliver: its sampling would say little
        return
    y = np.asarray(y)
    q0, q1, q2, region = closest_on_triangle(tri, *y)
    q = np.array([q0, q1, q2])
    # q lies in the triangle: barycentric coordinates >= 0 and q in its plane
    m = np.column_stack([tri[1] - tri[0], tri[2] - tri[0]])
    uv, *_ = np.linalg.lstsq(m, q - tri[0], rcond=None)
    assert np.abs(m @ uv - (q - tri[0])).max() < 1e-12
    assert uv.min() > -1e-12 and uv.sum() < 1 + 1e-12
    # no sampled point is nearer; the nearest sample is within the grid's spacing
    d = np.linalg.norm(y - q)
    samples = np.linalg.norm(_sampled_triangle(tri) - y, axis=1)
    longest = max(np.linalg.norm(tri[i] - tri[i - 1]) for i in range(3))
    assert d <= samples.min() + 1e-12
    assert d >= samples.min() - 2.0 * longest / 300
    # the region named: a vertex is a corner, an edge a point on that edge, the face inside
    if region == FACE:
        assert uv.min() > -1e-12
    elif region in (EDGE_AB, EDGE_AC, EDGE_BC):
        ends = {EDGE_AB: (0, 1), EDGE_AC: (0, 2), EDGE_BC: (1, 2)}[region]
        e = tri[ends[1]] - tri[ends[0]]
        assert np.linalg.norm(np.cross(e, q - tri[ends[0]])) < 1e-12 * (1 + np.dot(e, e))
    else:
        assert np.abs(tri[region - 1] - q).max() == 0.0


# ---- distance to a frustum sheet --------------------------------------------------------------

def _axis(theta, phi):
    return np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi),
                     math.cos(theta)])


@CHEAP
@given(z0=st.floats(-0.5, 0.5), r0=st.floats(0.0, 0.6), dz=st.floats(-0.5, 0.5),
       r1=st.floats(0.0, 0.6), theta=st.floats(0.0, math.pi), phi=st.floats(0.0, 2 * math.pi),
       x=point)
def test_frustum_distance_is_the_distance_to_the_nearest_point_of_the_sheet(z0, r0, dz, r1, theta,
                                                                            phi, x):
    if math.hypot(dz, r1 - r0) < 0.05:  # a degenerate sheet (a circle): refused by Simulation
        return
    axis, p = _axis(theta, phi), np.array([0.1, -0.2, 0.05])
    wall = np.zeros(WALL_COLUMNS)
    wall[0], wall[1:4], wall[4:7] = FRUSTUM, p, axis
    wall[11:15] = z0, r0, z0 + dz, r1
    r = 0.3
    out = wall_contact_bounded(wall, *x, r)
    dist = r - out[0]
    n = np.array(out[1:4])
    # brute force: the sheet sampled along its meridian segment and around the axis
    e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    s = np.linspace(0.0, 1.0, 401)[:, None]
    ang = np.linspace(0.0, 2 * math.pi, 1441)[None, :]
    z, rad = z0 + s * dz, r0 + s * (r1 - r0)
    pts = (p[None, None] + z[..., None] * axis
           + (rad * np.cos(ang))[..., None] * e1 + (rad * np.sin(ang))[..., None] * e2)
    best = np.linalg.norm(pts - np.asarray(x), axis=2).min()
    spacing = math.hypot(dz, r1 - r0) / 400 + 2 * math.pi * max(r0, r1) / 1440
    assert dist <= best + 1e-12
    assert dist >= best - spacing
    # the normal points from the sheet to the centre: x - dist n is on the sheet
    assert abs(np.linalg.norm(n) - 1.0) < 1e-12
    foot = np.asarray(x) - dist * n - p
    h = foot @ axis
    rho = np.linalg.norm(foot - h * axis)
    t = ((h - z0) * dz + (rho - r0) * (r1 - r0)) / (dz * dz + (r1 - r0) ** 2)
    assert -1e-9 <= t <= 1 + 1e-9
    assert math.hypot(h - (z0 + t * dz), rho - (r0 + t * (r1 - r0))) < 1e-9


# ---- the cells a neighbour search visits ------------------------------------------------------

@CHEAP
@given(ncell=st.integers(1, 12), size=st.floats(0.1, 2.0), reach=st.floats(0.0, 5.0),
       fa=st.floats(-0.2, 1.2), periodic=st.booleans())
def test_the_cells_visited_hold_every_point_within_reach(ncell, size, reach, fa, periodic):
    """Along one axis of a grid of ncell cells from lo = -0.3: every point xb within ``reach``
    of xa (min image when periodic; 401 of them) lies in a visited cell, and no cell is visited
    twice. The ends are a hair inside: a pair at exactly the reach is not listed (d < cut), and
    wrapping it rounds either way."""
    lo, box = -0.3, ncell * size
    xa = lo + fa * box
    xb = xa + np.linspace(-1.0, 1.0, 401) * reach * (1.0 - 1e-9)
    if periodic:  # positions live in the box
        xa, xb = lo + (xa - lo) % box, lo + (xb - lo) % box
    first, count = _cell_range(xa, reach, lo, size, ncell, periodic)
    visited = [(first + k) % ncell if periodic else first + k for k in range(count)]
    assert len(set(visited)) == len(visited)
    assert all(0 <= c < ncell for c in visited)
    assert {_cell_index(b, lo, size, ncell) for b in xb} <= set(visited)


# ---- the pour's clearance ---------------------------------------------------------------------

@CHEAP
@given(existing=st.lists(st.tuples(st.floats(-0.6, 1.6), st.floats(-0.6, 1.6),
                                   st.floats(-0.6, 1.6), st.floats(0.01, 0.6)), max_size=6),
       rmin=st.floats(0.02, 0.1), spread=st.floats(1.0, 2.0), gap=st.floats(0.0, 0.05),
       seed=st.integers(0, 1000))
def test_poured_spheres_clear_every_sphere_by_the_gap(existing, rmin, spread, gap, seed):
    """Existing spheres (some larger than the poured, some with centres outside the region)
    and the poured ones: every pair at least ``gap`` apart."""
    ex = np.array([e[:3] for e in existing]).reshape(-1, 3)
    er = np.array([e[3] for e in existing])
    charge = PourCharge(ex, er, time=1.0)
    pour = Pour(lo=(0, 0, 0), hi=(1, 1, 1), count=60, rate=60.0, material="m",
                radius_range=(rmin, rmin * spread), gap=gap, seed=seed, start=0.0, attempts=20)
    pour.fill(charge)
    x, r = charge.particles.x, charge.particles.radius
    new = np.arange(len(er), len(r))
    assert pour.inserted == len(new) > 0
    d = np.linalg.norm(x[new, None] - x[None], axis=2) - r[new, None] - r[None]
    d[np.arange(len(new)), new] = np.inf
    assert d.min() >= gap - 1e-12
    assert (x[new] - r[new, None] >= -1e-12).all() and (x[new] + r[new, None] <= 1 + 1e-12).all()


# ---- drawn walls: a cylinder about any axis -----------------------------------------------------

unit_axis = st.tuples(coord, coord, coord).filter(lambda a: 0.1 < np.linalg.norm(a))


def _drawn(x, walls, bounded=False):
    """The snapshot's drawing (12 segments a circle) of ``walls`` around one sphere at x."""
    sim = Simulation(PhysicsSpec(dim=3, walls=True, bounded_walls=bounded), MaterialTable(
        [Material("m", 2500.0)], {"*": Interaction(normal_stiffness=1e3)}, "linear_history"),
        x=[x], radius=[1e-3], material="m", walls=walls, gravity=(0, 0, 0))
    return WallTessellator(segments=12)(sim)


@CHEAP
@given(axis=unit_axis)
@example(axis=(1.0, 1.0, 0.0))  # diagonal in xy: the frame's helper vector must not lie along it
@example(axis=(0.95, 0.0, 0.1))  # past the switch of helper at |a_x| = 0.9
def test_a_drawn_cylinder_lies_at_its_radius_about_any_axis(axis):
    """The snapshot's drawing of a cylinder wall (engine.wall_geometry.WallTessellator): every
    vertex at the radius from the axis line and the vertices spread round it (brute force: the
    distance from the line, and the angle between two of them), for axes drawn at random and
    two at the helper vector's edge cases (issue 47, seed 54 `wall_geometry:51`: a helper
    [1, 1, 0] draws NaN for the axis along it)."""
    a = np.asarray(axis) / np.linalg.norm(axis)
    point, radius = np.array([0.1, -0.2, 0.3]), 0.05
    drawn = _drawn(point + 0.01 * np.cross(a, [0.3, 0.5, 0.7]),
                   [dict(kind="cylinder_inner", point=tuple(point), axis=tuple(a), radius=radius,
                         material="m")])["points"]
    off = drawn - point
    across = off - (off @ a)[:, None] * a
    np.testing.assert_allclose(np.linalg.norm(across, axis=1), radius, rtol=1e-9)
    # twelve directions round the axis, 30 degrees apart
    angles = np.degrees(np.arctan2(np.cross(across[0], across) @ a, across @ across[0]))
    step = np.round(angles / 30.0)
    np.testing.assert_allclose(angles, 30.0 * step, atol=1e-6)
    assert set((step % 12).astype(int)) == set(range(12))


@CHEAP
@given(axis=unit_axis, z0=st.floats(-0.05, 0.05), r0=st.sampled_from([0.0, 0.01, 0.03]),
       dz=st.floats(0.005, 0.05), r1=st.sampled_from([0.0, 0.02]))
@example(axis=(0.0, 0.0, 1.0), z0=0.02, r0=0.0, dz=0.03, r1=0.02)  # a cone's tip off the point
def test_a_drawn_frustum_lies_on_its_sheet_about_any_axis(axis, z0, r0, dz, r1):
    """The drawing of a frustum wall (a cone where a radius is 0): every vertex lies on one of
    its rims, at axial position z0 or z0 + dz from the wall's point and at that rim's radius
    from the axis line (brute force: the projections), both rims present."""
    if r0 == 0.0 and r1 == 0.0:
        r1 = 0.02
    a = np.asarray(axis) / np.linalg.norm(axis)
    point = np.array([0.1, -0.2, 0.3])
    drawn = _drawn(point + 0.5 * (2 * z0 + dz) * a,
                   [dict(kind="frustum", point=tuple(point), axis=tuple(a), start=(z0, r0),
                         end=(z0 + dz, r1), material="m")], bounded=True)["points"]
    off = drawn - point
    along = off @ a
    across = np.linalg.norm(off - along[:, None] * a, axis=1)
    start = np.isclose(along, z0, rtol=0, atol=1e-12)
    end = np.isclose(along, z0 + dz, rtol=0, atol=1e-12)
    assert (start | end).all() and start.any() and end.any()
    np.testing.assert_allclose(across[start], r0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(across[end], r1, rtol=0, atol=1e-12)


@CHEAP
@given(axis=unit_axis)
@example(axis=(0.0, 0.0, 1.0))  # a drum about z, the usual set-up
def test_a_plane_drawn_inside_a_drum_reaches_across_the_drum(axis):
    """A plane along a drum's axis (a lifter face, a flat bottom) is drawn as a rectangle over
    the drawn extent, which must take in the drum's cross-section and not only the particles
    and its axis point: with one small particle on the axis, every point of the drum's circle
    projects into the drawn rectangle (brute force: the circle's points in the rectangle's own
    coordinates). Issue 47, seed 54 `wall_geometry:157` (the extent without the cylinder's
    radius draws the plane 2 mm wide inside a 0.1 m drum)."""
    a = np.asarray(axis) / np.linalg.norm(axis)
    point, radius = np.array([0.1, -0.2, 0.3]), 0.05
    n = np.cross(a, [0.3, 0.5, 0.7])
    n /= np.linalg.norm(n)
    drawn = _drawn(point, [dict(kind="cylinder_inner", point=tuple(point), axis=tuple(a),
                                radius=radius, material="m"),
                           dict(kind="plane", point=tuple(point - 0.5 * radius * n),
                                normal=tuple(n), material="m")])
    corners = drawn["points"][np.unique(drawn["cells"][drawn["wall"] == 1])]  # in drawing order
    assert len(corners) == 4
    e1 = corners[1] - corners[0]
    e2 = corners[3] - corners[0]
    assert abs(e1 @ e2) < 1e-12 and abs(e1 @ n) < 1e-12 and abs(e2 @ n) < 1e-12  # a rectangle
    u = np.cross(n, a)  # with n, the drum's cross-section
    phi = np.linspace(0.0, 2.0 * math.pi, 360, endpoint=False)
    circle = point + radius * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * n)
    rel = circle - corners[0]
    s, t = rel @ e1 / (e1 @ e1), rel @ e2 / (e2 @ e2)
    assert s.min() >= -1e-9 and s.max() <= 1 + 1e-9 and t.min() >= -1e-9 and t.max() <= 1 + 1e-9
