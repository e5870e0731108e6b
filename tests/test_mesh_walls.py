"""Triangle-mesh walls (engine.mesh) against the analytic walls and brute force written here.

- Geometry: the closest point of a triangle against a dense barycentric sampling; each particle's
  candidate triangles against a brute-force search over all triangles.
- A sphere bouncing, sliding and rolling with friction on a flat mesh (a plate whose top is cut
  into many triangles: shared edges and vertices on the way) moves as on the analytic plane, to
  rounding: no bump at an edge or vertex, no double counting.
- A sphere over a convex edge or vertex of a box touches it once: the force equals one contact
  with a plane through the edge point, normal along the line to the centre.
- One contact per touching surface where rounding decides the region: a sphere resting exactly
  over a shared edge or vertex (4, 6, 8 triangles) of turned triangulations sits where the
  analytic plane puts it (m g / k_n); in a meshed 90 degree groove, touched exactly at vertices,
  at the closed-form balance; rolling down an incline near the friction limit across triangles
  (the loaded tangential spring carried over) as on the analytic plane, (5/14) g sin(a) t^2.
- A plate turning about its normal carries a particle as the analytic turning plane does (the
  mesh frame's angle, the surface velocity, the list rebuilds its travel asks for), and receives
  the same work; a rising plate as the translating plane.
- Refusals: no spec flag, unknown keys.
"""

import math

import numpy as np
import pytest

from millsim.engine import PhysicsSpec, Simulation, StepPolicy
from millsim.engine.mesh import closest_on_triangle, rebuilt_mesh_candidates
from millsim.engine.mesh_io import box_mesh
from millsim.models import Interaction, Material, MaterialTable

R = 1e-3
RHO = 2500.0
K_N = 2e3
MASS = RHO * 4.0 / 3.0 * math.pi * R**3
MESH_SPEC = PhysicsSpec(dim=3, walls=True, mesh_walls=True)
PLAIN_SPEC = PhysicsSpec(dim=3, walls=True)
G = (0.0, 0.0, -9.81)


def plate(cells, half, depth, alternate=False):
    """A closed slab [-half, half]^2 x [-depth, 0] whose top is cut into cells x cells squares
    (two triangles each) and whose sides match its edge vertices (no T-junctions)."""
    s = np.linspace(-half, half, cells + 1)
    return block(s, s, lambda x, y: 0.0 * x, depth, alternate)


def block(xs, ys, height, depth, alternate=False):
    """A closed solid over the grid xs x ys from z = -depth up to z = height(x, y): its top is
    cut into two triangles per cell, all diagonals alike (interior vertices of 6 triangles) or
    alternating (``alternate``: vertices of 4 and 8), its sides match its edge vertices."""
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    top = np.column_stack([gx.ravel(), gy.ravel(), height(gx, gy).ravel()])
    bottom = top.copy()
    bottom[:, 2] = -depth
    vertices = np.vstack([top, bottom])
    nb = len(top)
    nx, ny = len(xs) - 1, len(ys) - 1

    def idx(i, j):
        return i * (ny + 1) + j

    faces = []
    for i in range(nx):
        for j in range(ny):
            a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
            up = [(a, b, d), (b, c, d)] if alternate and (i + j) % 2 else [(a, b, c), (a, c, d)]
            faces += up + [(p + nb, r + nb, q + nb) for p, q, r in up]  # down
    ring = ([idx(i, 0) for i in range(nx)] + [idx(nx, j) for j in range(ny)]
            + [idx(i, ny) for i in range(nx, 0, -1)] + [idx(0, j) for j in range(ny, 0, -1)])
    for k in range(len(ring)):  # counter-clockwise seen from above: outward side quads
        a, b = ring[k], ring[(k + 1) % len(ring)]
        faces += [(a, a + nb, b + nb), (a, b + nb, b)]
    return vertices, np.array(faces)


def turned(vertices, theta):
    """The vertices turned by theta about the z axis."""
    c, s = math.cos(theta), math.sin(theta)
    out = vertices.copy()
    out[:, 0] = c * vertices[:, 0] - s * vertices[:, 1]
    out[:, 1] = s * vertices[:, 0] + c * vertices[:, 1]
    return out


def make_sim(spec, x, v=None, w=None, walls=(), friction=0.5, gravity=G, impact_speed=1.0,
             radius=R):
    mat = Material("m", RHO)
    table = MaterialTable([mat], {"*": Interaction(restitution=0.5, friction=friction,
                                                   normal_stiffness=K_N)}, "linear_history")
    n = len(x)
    return Simulation(spec, table, x=np.asarray(x, float),
                      radius=np.broadcast_to(np.asarray(radius, float), n).copy(), material="m",
                      v=v, w=w, walls=list(walls), gravity=gravity, skin=0.2 * R,
                      step=StepPolicy(impact_speed=impact_speed))


def mesh_wall(vertices, faces, **motion):
    return dict(kind="mesh", vertices=vertices, faces=faces, material="m", **motion)


# ---- geometry ---------------------------------------------------------------------------------

def test_closest_point_of_a_triangle_is_the_nearest_of_a_dense_sampling():
    rng = np.random.default_rng(3)
    u, v = np.meshgrid(np.linspace(0, 1, 401), np.linspace(0, 1, 401))
    keep = u + v <= 1.0
    u, v = u[keep], v[keep]
    for _ in range(200):
        tri = rng.normal(size=(3, 3))
        y = rng.normal(size=3) * 2.0
        q = np.array(closest_on_triangle(tri, *y)[:3])
        samples = tri[0] + np.outer(u, tri[1] - tri[0]) + np.outer(v, tri[2] - tri[0])
        best = np.sqrt(((samples - y) ** 2).sum(1)).min()
        spacing = 2.5e-3 * np.abs(tri - tri[0]).max() * 2.0
        dist = np.linalg.norm(q - y)
        assert dist <= best + 1e-12
        assert dist >= best - spacing  # not nearer than the triangle allows


def test_candidates_are_every_triangle_within_radius_and_skin():
    vertices, faces = plate(6, 0.01, 0.004)
    rng = np.random.default_rng(5)
    x = rng.uniform([-0.012, -0.012, -0.006], [0.012, 0.012, 0.003], size=(300, 3))
    x[:, 2] = np.abs(x[:, 2]) + R  # above the top mostly; a few near the sides
    sim = make_sim(MESH_SPEC, x[:1] + [0, 0, 0.01], walls=[mesh_wall(vertices, faces)])
    mesh = sim._W
    radius = np.full(len(x), R)
    margin = 0.3 * R
    start, tri = rebuilt_mesh_candidates(mesh, sim.walls, x, radius, np.full(len(x), -1), margin,
                                         0.0)
    for i in range(len(x)):
        dist = np.array([np.linalg.norm(np.array(closest_on_triangle(mesh.tri[t], *x[i])[:3])
                                        - x[i]) for t in range(len(faces))])
        assert sorted(tri[start[i]:start[i + 1]]) == sorted(np.flatnonzero(dist < R + margin))


# ---- a flat mesh is the plane -----------------------------------------------------------------

@pytest.mark.parametrize("start", [
    # bouncing and sliding along x across many edges, then rolling
    dict(x=[-0.0087, 0.0021, 3 * R], v=[0.3, 0.0, -0.05]),
    # along a diagonal: through shared vertices, spinning
    dict(x=[-0.0079, -0.0079, 2 * R], v=[0.2, 0.2, -0.02], w=[5.0, -20.0, 3.0]),
])
def test_a_sphere_on_a_flat_mesh_moves_as_on_the_analytic_plane(start):
    vertices, faces = plate(20, 0.02, 0.003)  # 2 mm squares: the sphere crosses a few edges
    x, v, w = [start["x"]], [start["v"]], [start.get("w", [0.0, 0.0, 0.0])]
    plane = make_sim(PLAIN_SPEC, x, v, w, walls=[dict(kind="plane", point=(0, 0, 0),
                                                      normal=(0, 0, 1), material="m")])
    mesh = make_sim(MESH_SPEC, x, v, w, walls=[mesh_wall(vertices, faces)])
    dt = plane.dt
    mesh.set_time_step(dt)
    path_plane, path_mesh = [], []
    for _ in range(40):
        plane.run(250)
        mesh.run(250)
        path_plane.append(plane.particles.x[0].copy())
        path_mesh.append(mesh.particles.x[0].copy())
        assert np.abs(mesh.particles.v[0] - plane.particles.v[0]).max() < 1e-12
        assert np.abs(mesh.particles.w[0] - plane.particles.w[0]).max() < 1e-9
    travelled = np.linalg.norm(path_plane[-1][:2] - np.asarray(start["x"])[:2])
    assert travelled > 0.006  # across three squares at least: their edges and vertices
    assert np.abs(np.array(path_mesh) - np.array(path_plane)).max() < 1e-12
    assert mesh.impulse(wall=0) == pytest.approx(plane.impulse(wall=0), rel=1e-9, abs=1e-15)


@pytest.mark.parametrize("centre_offset", [
    (0.7, 0.0, 0.7),  # beyond the top edge x = half, above it: an edge of two faces
    (0.6, 0.6, 0.5),  # beyond the corner: a vertex of three faces, five triangles
])
def test_a_convex_edge_or_vertex_counts_once(centre_offset):
    half = 0.004
    vertices, faces = box_mesh((-half, -half, -0.002), (half, half, 0.0))
    corner = np.array([half, 0.0 if centre_offset[1] == 0.0 else half, 0.0])
    direction = np.asarray(centre_offset) / np.linalg.norm(centre_offset)
    x = corner + direction * 0.9 * R  # overlap 0.1 R with the feature
    mesh = make_sim(MESH_SPEC, [x], walls=[mesh_wall(vertices, faces)], friction=0.0,
                    gravity=(0.0, 0.0, 0.0))
    plane = make_sim(PLAIN_SPEC, [x], walls=[dict(kind="plane", point=corner, normal=direction,
                                                  material="m")], friction=0.0,
                     gravity=(0.0, 0.0, 0.0))
    mesh.run(1)
    plane.run(1)
    assert np.abs(mesh.particles.v[0] - plane.particles.v[0]).max() < 1e-12 * np.abs(
        plane.particles.v[0]).max()
    tags = mesh._W.mesh_hist[0, :, mesh.layout.wall_columns + 3]
    assert (tags != 0).sum() == 1


# ---- one contact per touching surface ---------------------------------------------------------
# A sphere exactly over a shared edge or vertex: rounding makes the triangles there report two
# faces, or an edge and a vertex; exactly one of them must count (mesh.owns).

REST = MASS * 9.81 / K_N  # static overlap of one contact carrying m g (linear spring)
FLAT = dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="m")


@pytest.mark.parametrize("theta", [0.0, 0.7, 2.0])
def test_a_sphere_resting_over_a_shared_edge_or_vertex_carries_m_g_once(theta):
    """Friction 0, damped: placed over a vertex of 4, 6 or 8 triangles, or over a shared edge
    (of the grid, or a diagonal), of a regular triangulation turned by theta, the sphere comes
    to rest at the overlap m g / k_n, where the analytic plane puts it (not at half of it:
    two faces counted; nor through the plate: none)."""
    plane = make_sim(PLAIN_SPEC, [[0.0, 0.0, R]], walls=[FLAT], friction=0.0)
    plane.run(4000)
    assert R - plane.particles.x[0, 2] == pytest.approx(REST, rel=1e-9)

    def idx(i, j):
        return i * 7 + j  # the top's 7 x 7 vertices

    spots = {False: [(idx(3, 3),), (idx(3, 3), idx(4, 3)), (idx(3, 3), idx(4, 4))],  # 6; edges
             True: [(idx(3, 3),), (idx(3, 2),), (idx(3, 2), idx(4, 2))]}  # vertices of 8, 4
    for alternate, features in spots.items():
        vertices, faces = plate(6, 0.006, 0.002, alternate)
        vertices = turned(vertices, theta)
        for feature in features:
            spot = vertices[list(feature)].mean(axis=0)
            mesh = make_sim(MESH_SPEC, [[spot[0], spot[1], R]], walls=[mesh_wall(vertices, faces)],
                            friction=0.0)
            mesh.set_time_step(plane.dt)
            mesh.run(4000)
            shift = mesh.particles.x[0] - [spot[0], spot[1], 0.0]
            assert np.abs(shift - plane.particles.x[0]).max() < 1e-9 * REST, (alternate, feature)
            assert np.abs(mesh.particles.v[0] - plane.particles.v[0]).max() < 1e-12


@pytest.mark.parametrize("theta,alternate", [(0.0, False), (0.7, True), (2.0, False)])
def test_a_sphere_in_a_meshed_right_angle_groove_rests_at_the_static_balance(theta, alternate):
    """Friction 0, damped, in a 90 degree groove (faces z = |x|) whose triangulation has a
    vertex exactly where each face is touched: at rest each face carries m g / sqrt(2), so the
    centre sits on the groove's plane of symmetry at sqrt(2) (R - m g / (sqrt(2) k_n))."""
    delta = MASS * 9.81 / (math.sqrt(2.0) * K_N)
    foot = (R - delta) / math.sqrt(2.0)  # the contact points' distance from the groove's bottom
    xs = foot * np.array([-5.0, -3.0, -1.0, 0.0, 1.0, 3.0, 5.0])
    vertices, faces = block(xs, 2.0 * foot * np.arange(-3, 4), lambda x, y: np.abs(x), 0.002,
                             alternate)
    vertices = turned(vertices, theta)
    mesh = make_sim(MESH_SPEC, [[0.0, 0.0, math.sqrt(2.0) * R]],
                    walls=[mesh_wall(vertices, faces)], friction=0.0)
    mesh.run(4000)
    x = mesh.particles.x[0]
    assert np.abs(x[:2]).max() < 1e-9 * delta  # both faces alike
    assert (math.sqrt(2.0) * R - x[2]) / math.sqrt(2.0) == pytest.approx(delta, rel=1e-9)
    assert np.abs(mesh.particles.v[0]).max() < 1e-12


@pytest.mark.parametrize("theta,heading,start", [
    (0.0, 0.3, (-0.012, -0.004)),  # across grid edges and diagonals at arbitrary points
    (0.7, 0.0, (-0.014, 0.0)),  # from a vertex along a row of shared edges and their vertices
])
def test_the_tangential_spring_carries_over_from_triangle_to_triangle(theta, heading, start):
    """A sphere rolling down an incline (gravity tilted) at 0.9 of the friction it can hold
    ((2/7) tan(alpha) = 0.9 mu): the spring carries (2/7) m g sin(alpha) all the way while the
    contact crosses triangles. It rolls as on the analytic plane (no slip where the plane has
    none) and covers (5/14) g sin(alpha) t^2."""
    mu = 0.5
    tan_a = 0.9 * mu * 3.5
    alpha = math.atan(tan_a)
    along = np.array([math.cos(theta + heading), math.sin(theta + heading), 0.0])
    gravity = 9.81 * (math.sin(alpha) * along + math.cos(alpha) * np.array([0.0, 0.0, -1.0]))
    vertices, faces = plate(20, 0.02, 0.003)  # 2 mm squares
    vertices = turned(vertices, theta)
    x = [turned(np.array([[start[0], start[1], R]]), theta)[0]]
    plane = make_sim(PLAIN_SPEC, x, walls=[FLAT], friction=mu, gravity=gravity)
    mesh = make_sim(MESH_SPEC, x, walls=[mesh_wall(vertices, faces)], friction=mu,
                    gravity=gravity)
    mesh.set_time_step(plane.dt)
    for _ in range(20):
        plane.run(1000)
        mesh.run(1000)
        assert np.abs(mesh.particles.v[0] - plane.particles.v[0]).max() < 1e-12
        assert np.abs(mesh.particles.w[0] - plane.particles.w[0]).max() < 1e-9
    travelled = (mesh.particles.x[0] - x[0]) @ along
    assert travelled > 0.006  # across three squares at least
    assert travelled == pytest.approx(5.0 / 14.0 * 9.81 * math.sin(alpha) * mesh.time**2,
                                      rel=1e-4)
    lever = 0.5 * (R + mesh.particles.x[0, 2])  # to the contact point, mid-overlap
    slip = mesh.particles.v[0] + np.cross(mesh.particles.w[0], [0.0, 0.0, -lever])
    assert np.linalg.norm(slip) < 1e-6 * np.linalg.norm(mesh.particles.v[0])


# ---- moving meshes ----------------------------------------------------------------------------

@pytest.mark.parametrize("rotvec,origin", [
    ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((0.4, -0.7, 0.25), (0.01, -0.02, 0.005)),  # an oblique axis through another point
])
def test_a_turning_plate_carries_a_particle_as_the_analytic_turning_plane(rotvec, origin):
    """A plate turning about its normal: a resting particle off the axis is dragged along; the
    mesh's angle advances, the list is rebuilt as its rim travels; the whole scene rotated and
    moved (gravity too) must give the same, rotated."""
    from scipy.spatial.transform import Rotation

    turn = Rotation.from_rotvec(rotvec)
    origin = np.asarray(origin)
    vertices, faces = plate(8, 0.01, 0.002)
    vertices = turn.apply(vertices) + origin
    x = [turn.apply([0.004, 0.001, R - 0.05 * R]) + origin]
    axis = turn.apply([0.0, 0.0, 1.0])
    gravity = turn.apply(G)
    omega = 3.0
    plane = make_sim(PhysicsSpec(dim=3, walls=True), x, gravity=gravity,
                     walls=[dict(kind="plane", point=origin, normal=axis, material="m",
                                 omega=omega)])
    mesh = make_sim(MESH_SPEC, x, gravity=gravity,
                    walls=[mesh_wall(vertices, faces, point=origin, axis=axis, omega=omega)])
    mesh.set_time_step(plane.dt)
    for _ in range(20):
        plane.run(500)
        mesh.run(500)
    assert np.abs(mesh.particles.x[0] - plane.particles.x[0]).max() < 1e-9 * R
    assert np.abs(mesh.particles.v[0] - plane.particles.v[0]).max() < 1e-7 * omega * 0.004
    in_plane = plane.particles.v[0] - (plane.particles.v[0] @ axis) * axis
    assert np.linalg.norm(in_plane) > 0.3 * omega * 0.004  # it was dragged
    assert mesh.work(wall=0) == pytest.approx(plane.work(wall=0), rel=1e-6)
    assert mesh.angular_impulse(wall=0) == pytest.approx(plane.angular_impulse(wall=0), rel=1e-6)
    assert mesh.counters[0] > 3  # the plate's corners (14 mm out) travel the skin


def test_a_rising_mesh_plate_carries_a_particle_as_the_translating_plane():
    vertices, faces = plate(4, 0.005, 0.002)
    speed = 0.05
    spec = PhysicsSpec(dim=3, walls=True, mesh_walls=True, translating_walls=True)
    x = [[0.0011, 0.0003, R]]
    plane = make_sim(PhysicsSpec(dim=3, walls=True, translating_walls=True), x,
                     walls=[dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="m",
                                 velocity=(0.0, 0.0, speed))], impact_speed=0.1)
    mesh = make_sim(spec, x, walls=[mesh_wall(vertices, faces, velocity=(0.0, 0.0, speed))],
                    impact_speed=0.1)
    mesh.set_time_step(plane.dt)
    plane.run(20000)
    mesh.run(20000)
    assert mesh.particles.v[0, 2] == pytest.approx(plane.particles.v[0, 2], rel=1e-9)
    assert mesh.particles.x[0, 2] == pytest.approx(plane.particles.x[0, 2], rel=1e-9)
    assert mesh.work(wall=0) == pytest.approx(plane.work(wall=0), rel=1e-9)


# ---- refusals ---------------------------------------------------------------------------------

def _table():
    return MaterialTable([Material("m", RHO)], {"*": Interaction(restitution=0.5,
                                                                 normal_stiffness=K_N)},
                         "linear_history")


@pytest.mark.parametrize("spec,extra,message", [
    (PLAIN_SPEC, {}, r"walls\[0\]\.kind: mesh walls need PhysicsSpec\(mesh_walls=True\)"),
    (MESH_SPEC, {"radius": 1.0}, r"walls\[0\]: unknown keys \['radius'\]"),
])
def test_mesh_walls_refused_where_they_cannot_work(spec, extra, message):
    vertices, faces = box_mesh((-0.01, -0.01, -0.01), (0.01, 0.01, 0.0))
    with pytest.raises(ValueError, match=message):
        Simulation(spec, _table(), x=[[0.0, 0.0, 0.002]], radius=[R], material="m",
                   walls=[dict(mesh_wall(vertices, faces), **extra)], gravity=G)


def test_mesh_walls_need_3d_walls():
    with pytest.raises(ValueError, match="mesh_walls: needs walls=True and dim=3"):
        PhysicsSpec(dim=2, walls=True, mesh_walls=True)


# ---- the shipped example: a ball mill with lifters, run from its STL -------------------------

def test_the_example_liner_runs_in_the_packing_drum_and_its_lifters_lift():
    """The packing scene's drum with the shipped liner (8 lifters): the lattice start is clear of
    the lifters (an overlapping start would be refused), the shell turns and puts power in."""
    from pathlib import Path

    from millsim.scenes.base import get_scene

    liner = Path(__file__).resolve().parents[1] / "examples" / "meshes" / "ballmill_liner.stl"
    scene = get_scene("packing")
    ds, _ = scene.run(scene.resolve(dict(
        container="drum", liner=str(liner), drum_radius=0.1, drum_length=0.05, radius=0.004,
        n=200, settle_steps=3000, spinup_steps=3000, steps=3000, dt=1e-5, settle_dt=1e-5,
        drum_omega=5.0, skin=8e-4)))
    assert float(ds["shell_power"]) > 0.0  # the turning liner drives the charge
    assert float(ds["shell_torque"]) != 0.0


def test_each_triangle_takes_its_own_material():
    """A flat mesh whose top triangles are a soft material: a sphere resting on it sits at the
    soft pair's overlap m g / k_soft, not the default material's."""
    vertices, faces = plate(2, 0.005, 0.002)
    top = np.array([np.allclose(vertices[f][:, 2], 0.0) for f in faces])
    soft_k = K_N / 4.0
    mats = [Material("m", RHO), Material("soft", RHO)]
    table = MaterialTable(mats, {"*": Interaction(restitution=0.5, friction=0.5,
                                                  normal_stiffness=K_N),
                                 ("m", "soft"): Interaction(restitution=0.5, friction=0.5,
                                                            normal_stiffness=soft_k)},
                          "linear_history")
    wall = mesh_wall(vertices, faces, triangle_materials=["soft" if t else "m" for t in top])
    sim = Simulation(MESH_SPEC, table, x=[[0.001, 0.0005, R]], radius=[R], material="m",
                     walls=[wall], gravity=G, skin=0.2 * R)
    sim.run(40000)
    assert R - sim.particles.x[0, 2] == pytest.approx(MASS * 9.81 / soft_k, rel=1e-6)
    with pytest.raises(ValueError, match=r"walls\[0\]\.triangle_materials: 3 names for"):
        Simulation(MESH_SPEC, table, x=[[0.001, 0.0005, R]], radius=[R], material="m",
                   walls=[mesh_wall(vertices, faces, triangle_materials=["m"] * 3)], gravity=G)


def test_a_pour_keeps_clear_of_a_mesh_and_mesh_clearance_is_signed():
    """Poured spheres are placed clear of a mesh wall that cuts through the pour region, and
    mesh_clearance is the distance to the turned mesh, negative inside its solid."""
    from millsim.engine import Pour

    vertices, faces = box_mesh((-0.004, -0.004, 0.0), (0.004, 0.004, 0.006))  # a block in the way
    sim = make_sim(MESH_SPEC, [[0.0, 0.0, 0.02]], walls=[mesh_wall(vertices, faces, omega=2.0)])
    sim.run(1000)  # turned by 2 rad s-1 x t about z
    c, s = math.cos(2.0 * sim.time), math.sin(2.0 * sim.time)
    face_point = np.array([0.004 * c, 0.004 * s, 0.003]) + 0.001 * np.array([c, s, 0.0])
    assert sim.mesh_clearance([face_point])[0] == pytest.approx(0.001, rel=1e-9)
    assert sim.mesh_clearance([[0.0, 0.0, 0.003]])[0] == pytest.approx(-0.003, rel=1e-9)
    pour = Pour(lo=(-0.008, -0.008, 0.0), hi=(0.008, 0.008, 0.008), count=60, rate=1e9,
                material="m", radii=[R], seed=3, start=0.0)
    new = pour.fill(sim)
    assert len(new) > 10
    assert (sim.mesh_clearance(sim.particles.x[new]) >= R).all()




@pytest.mark.parametrize("kind", ["mesh", "plane"])
def test_a_sphere_driven_past_the_overlap_guard_into_a_wall_stops_the_run_naming_it(kind):
    """Issue 47, seed 54 (`wall_pass:249`): a sphere hitting a plate head-on at v reaches the
    linear spring's overlap v sqrt(m/k_n) (undamped bound; e = 0.5 takes off a little), here
    about 0.6 R, past the default guard of 0.3 R (Guards()): the run stops at that step naming the
    sphere and the wall, for a mesh plate as for an analytic plane; at a tenth of the speed
    (~0.06 R) it rebounds."""
    from millsim.engine import Guards, SimulationError

    m = RHO * 4.0 / 3.0 * math.pi * R**3
    fast = 0.6 * R / math.sqrt(m / K_N)
    assert Guards().max_overlap == 0.3
    wall = (mesh_wall(*plate(2, 0.01, 0.004)) if kind == "mesh"
            else dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="m"))
    spec = MESH_SPEC if kind == "mesh" else PLAIN_SPEC
    sim = make_sim(spec, [[0, 0, 1.01 * R]], v=[[0, 0, -fast]], walls=[wall], gravity=(0, 0, 0),
                   impact_speed=fast)
    with pytest.raises(SimulationError, match=r"overlap between particle 0 and wall 0 exceeds 0.3"):
        sim.run(int(4 * R / fast / sim.dt), chunk=1000)
    slow = make_sim(spec, [[0, 0, 1.01 * R]], v=[[0, 0, -0.1 * fast]], walls=[wall],
                    gravity=(0, 0, 0), impact_speed=fast)
    slow.run(int(40 * R / fast / slow.dt), chunk=1000)
    assert slow.particles.v[0, 2] > 0


def test_a_start_inside_a_mesh_wall_is_refused_by_the_overlap_relative_to_the_radius():
    """Issue 47, seed 57 (`guards:34`, `guards:35`): the start-up check compares each sphere's
    overlap with a mesh wall, as a fraction of its own radius, with the pairs' worst and the
    guard (0.3 by default). Here a large sphere sinks 0.5 R into the plate (0.25 of its radius
    2 R), a small one 0.4 R (0.4 of R), and a pair above the plate overlaps by 0.2 of R: only
    the small sphere is past the guard, and the message names it with 0.4."""
    x = [[-0.005, 0.0, 1.5 * R], [0.005, 0.0, 0.6 * R], [0.0, 0.005, 5 * R],
         [1.8 * R, 0.005, 5 * R]]
    wall = mesh_wall(*plate(2, 0.01, 0.004))
    with pytest.raises(ValueError, match=r"initial state: particle 1 and a mesh wall overlap by "
                                         r"0\.4 of the smaller radius, above max_overlap = 0\.3"):
        make_sim(MESH_SPEC, x, walls=[wall], radius=[2 * R, R, R, R])
    # the small sphere lifted to 0.8 R (0.2 of R): the worst is the large one's 0.25, accepted
    x[1][2] = 0.8 * R
    make_sim(MESH_SPEC, x, walls=[wall], radius=[2 * R, R, R, R])
