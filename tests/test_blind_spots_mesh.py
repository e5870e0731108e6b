"""Blind spots of the triangle-mesh walls (issue 47), against closed forms and analytic walls.

Written against behaviour that holds whatever feature (edge, vertex) owns a contact:
- one-sided faces: a sphere whose centre is behind a face's plane does not touch it (the
  documented rule of engine/mesh.py): inside a deep slab, just under its top, it moves in a
  straight line at constant velocity;
- a moving mesh asks for new candidate triangles as it travels: a plate rising fast, or a paddle
  turning, into a resting sphere strikes it (rebound at (1 + e) times the surface's speed, e the
  declared restitution) instead of passing through;
- simultaneous contacts keep their own history: a sphere sliding along a V-groove whose faces'
  normals are 40 degrees apart (both face contacts count, their normals within the 45 degrees
  that match a slot) moves as between the two analytic planes.
The spec variants are those of tests/test_mesh_walls.py (no new compiled loop).
"""

import math

import numpy as np
import pytest
import trimesh
from test_mesh_walls import RHO, R, make_sim, mesh_wall

from millsim.engine import PhysicsSpec
from millsim.engine.mesh_io import box_mesh

MASS = RHO * 4.0 / 3.0 * math.pi * R**3
MESH_SPEC = PhysicsSpec(dim=3, walls=True, mesh_walls=True)
PLAIN_SPEC = PhysicsSpec(dim=3, walls=True)
TRANSLATING_MESH = PhysicsSpec(dim=3, walls=True, mesh_walls=True, translating_walls=True)
E = 0.5  # restitution of test_mesh_walls.make_sim
NO_GRAVITY = (0.0, 0.0, 0.0)


def slab(cells, half, depth):
    """A closed slab [-half, half]^2 x [-depth, 0] whose top is cut into cells x cells squares
    (two triangles each) and whose sides match its edge vertices (tests/test_mesh_walls.py)."""
    s = np.linspace(-half, half, cells + 1)
    gx, gy = np.meshgrid(s, s, indexing="ij")
    top = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)])
    bottom = top.copy()
    bottom[:, 2] = -depth
    nb = len(top)

    def idx(i, j):
        return i * (cells + 1) + j

    faces = []
    for i in range(cells):
        for j in range(cells):
            a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
            faces += [(a, b, c), (a, c, d), (a + nb, c + nb, b + nb), (a + nb, d + nb, c + nb)]
    ring = ([idx(i, 0) for i in range(cells)] + [idx(cells, j) for j in range(cells)]
            + [idx(i, cells) for i in range(cells, 0, -1)] + [idx(0, j) for j in range(cells, 0, -1)])
    for k in range(len(ring)):
        a, b = ring[k], ring[(k + 1) % len(ring)]
        faces += [(a, a + nb, b + nb), (a, b + nb, b)]
    return np.vstack([top, bottom]), np.array(faces)


def v_groove(half_angle_deg, width, length, depth):
    """A prism along y whose top is a V: faces rising from the line x = z = 0 at the given angle,
    outward normals (-+sin a, 0, cos a); each long face cut into 16 pieces along y."""
    a = math.radians(half_angle_deg)
    h = width * math.tan(a)
    section = [(-width, -depth), (width, -depth), (width, h), (0.0, 0.0), (-width, h)]
    ys = np.linspace(-length, length, 17)
    vertices = np.array([(x, y, z) for y in ys for (x, z) in section])
    k = len(section)
    faces = []
    for s in range(len(ys) - 1):
        for e in range(k):
            a0, a1 = s * k + e, s * k + (e + 1) % k
            faces += [(a0, a1, a1 + k), (a0, a1 + k, a0 + k)]
    for s, flip in ((0, True), (len(ys) - 1, False)):  # end caps: a fan from the V's bottom
        c = s * k + 3
        for e in (4, 0, 1):
            tri = (c, s * k + e, s * k + (e + 1) % k)
            faces.append(tri[::-1] if flip else tri)
    faces = np.array(faces)
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    return vertices, faces if mesh.volume > 0 else faces[:, ::-1]


# ---- one-sided faces --------------------------------------------------------------------------

def test_a_sphere_behind_the_faces_feels_nothing():
    """Centre 0.9 R under the top of a deep slab (behind every top triangle, far from the other
    faces), moving across top edges and a diagonal and slowly towards the top: no force, so
    x(t) = x0 + v t and v stays v (to rounding)."""
    vertices, faces = slab(4, 0.005, 0.01)
    x0 = np.array([-3e-4, -2e-4, -0.9 * R])
    v0 = np.array([0.2, 0.1, 0.002])
    sim = make_sim(MESH_SPEC, [x0], [v0], walls=[mesh_wall(vertices, faces)],
                   gravity=NO_GRAVITY)
    steps = 1000
    sim.run(steps)
    t = steps * sim.dt
    assert np.abs(sim.particles.v[0] - v0).max() < 1e-15
    assert np.abs(sim.particles.x[0] - (x0 + v0 * t)).max() < 1e-14
    assert sim.particles.x[0, 0] > 0.0 and sim.particles.x[0, 1] > 0.0  # crossed the edges


# ---- moving meshes ask for new candidates -----------------------------------------------------

def test_a_fast_rising_plate_strikes_a_resting_sphere_instead_of_passing_through():
    """The plate starts 3 mm (15 skins) below the sphere and rises at 0.5 m/s; the sphere, at
    rest and without gravity, asks for no list rebuild itself. Struck by an immovable wall at V
    it leaves at (1 + e) V (in the wall's frame it rebounds at e V)."""
    speed = 0.5
    vertices, faces = slab(4, 0.005, 0.002)
    x0 = [0.0003, -0.0002, R + 3e-3]
    sim = make_sim(TRANSLATING_MESH, [x0], gravity=NO_GRAVITY,
                   walls=[mesh_wall(vertices, faces, velocity=(0.0, 0.0, speed))])
    steps = int(4.5e-3 / speed / sim.dt)  # the plate's travel to contact and beyond
    sim.run(steps)
    top = speed * steps * sim.dt
    # the dashpot's onset inside a step: zeta w0 dt of the speed, first order (as the walls' tests)
    assert sim.particles.v[0, 2] == pytest.approx((1 + E) * speed, rel=0.03)
    assert sim.particles.x[0, 2] > top + 0.9 * R


def test_a_gliding_plate_asks_for_new_candidates_once_per_half_skin_of_travel():
    """A plate glides sideways at u (u dt = skin / 20) 40 radii below a resting sphere it never
    reaches: the sphere asks for no rebuild itself, so the lists are rebuilt as the plate
    travels, between D / (skin / 2 + u dt) - 2 and D / (skin / 2) + 1 times over its travel D
    (the bounds of the particles' rule in tests/test_engine_contract.py); a plate at rest asks
    for none."""
    vertices, faces = slab(2, 0.005, 0.002)
    x0 = [[0.0, 0.0, 40 * R]]
    still = make_sim(TRANSLATING_MESH, x0, gravity=NO_GRAVITY, walls=[mesh_wall(vertices, faces)])
    still.run(500, chunk=500)
    assert int(still.counters[0]) == 0
    u, n = still.skin / (20 * still.dt), 2000
    gliding = make_sim(TRANSLATING_MESH, x0, gravity=NO_GRAVITY,
                       walls=[mesh_wall(vertices, faces, velocity=(u, 0.0, 0.0))])
    assert gliding.dt == still.dt
    gliding.run(n, chunk=n)
    travel = n * u * still.dt
    assert (travel / (0.5 * still.skin + u * still.dt) - 2 <= int(gliding.counters[0])
            <= travel / (0.5 * still.skin) + 1)
    assert np.array_equal(gliding.particles.x[0], x0[0])  # never reached


def test_a_turning_paddle_strikes_a_resting_sphere_instead_of_passing_through():
    """A paddle (10 x 1 x 2 mm) turning about z at 40 rad/s from 0.52 rad behind a resting
    sphere 5 mm from the axis: the face meets the sphere at about 4.9 mm, moving at omega times
    that; without friction the sphere leaves along the face normal at (1 + e) that speed."""
    omega = 40.0
    vertices, faces = box_mesh((0.0, -0.5e-3, -1e-3), (0.01, 0.5e-3, 1e-3))
    phi = math.radians(30.0)
    x0 = [0.005 * math.cos(phi), 0.005 * math.sin(phi), 0.0]
    sim = make_sim(MESH_SPEC, [x0], friction=0.0, gravity=NO_GRAVITY,
                   walls=[mesh_wall(vertices, faces, axis=(0, 0, 1), omega=omega)])
    steps = int(8e-3 / sim.dt)
    sim.run(steps)
    v = sim.particles.v[0]
    # the lever of the face point that strikes: the sphere's centre at ~0.2 rad from the face's
    # plane, the face 0.5 mm out: between 4.8 and 5.0 mm
    assert np.linalg.norm(v) == pytest.approx((1 + E) * omega * 4.9e-3, rel=0.04)
    assert abs(v[2]) < 1e-12  # in the plane of the turn
    paddle = omega * steps * sim.dt
    azimuth = math.atan2(sim.particles.x[0, 1], sim.particles.x[0, 0])
    assert azimuth > paddle  # ahead of the paddle


# ---- contact history of simultaneous facet contacts -------------------------------------------

@pytest.mark.parametrize("x_offset", [0.0, 0.15 * R])
def test_a_sphere_sliding_along_a_v_groove_moves_as_between_two_planes(x_offset):
    """Faces at +-20 degrees (normals 40 degrees apart: both contacts count, each within the
    45 degrees that would match the other's slot), friction 0.5, sliding along the groove
    under gravity: each face keeps its own tangential spring, as each analytic plane does."""
    a = math.radians(20.0)
    vertices, faces = v_groove(20.0, 0.006, 0.012, 0.004)
    n1, n2 = (-math.sin(a), 0.0, math.cos(a)), (math.sin(a), 0.0, math.cos(a))
    planes = [dict(kind="plane", point=(0, 0, 0), normal=n, material="m") for n in (n1, n2)]
    x = [[x_offset, -0.008, 0.98 * R / math.cos(a)]]
    v, w = [[0.0, 0.4, 0.0]], [[30.0, 0.0, 10.0]]
    g = (0.0, 0.0, -9.81)
    plane = make_sim(PLAIN_SPEC, x, v, w, walls=planes, gravity=g)
    mesh = make_sim(MESH_SPEC, x, v, w, walls=[mesh_wall(vertices, faces)], gravity=g)
    mesh.set_time_step(plane.dt)
    for _ in range(16):
        plane.run(250)
        mesh.run(250)
        assert np.abs(mesh.particles.v[0] - plane.particles.v[0]).max() < 1e-9
        assert np.abs(mesh.particles.w[0] - plane.particles.w[0]).max() < 1e-6
    assert np.abs(mesh.particles.x[0] - plane.particles.x[0]).max() < 1e-9 * R
    assert mesh.particles.x[0, 1] > -0.0045  # slid across three cuts of the faces along y
    # both faces pushed: the normal impulse on the mesh is that of the two planes together
    assert mesh.impulse(wall=0) == pytest.approx(plane.impulse(wall=0) + plane.impulse(wall=1),
                                                 rel=1e-9, abs=1e-15)
