"""Wall kinds as a registry: each kind is one :class:`WallKind` entry, beside its compiled contact.

A wall is a row of the float table the compiled loop reads (columns named in
:mod:`~millsim.engine.kinematics`, ``W_*``). An entry gives a kind's names and code, the keys of
its declaration and how they fill its row (with one-line errors naming the key), where it may be
used, and its contact function ``contact(wall, x0, x1, x2, r)`` -> (overlap, unit normal wall ->
particle, velocity of the wall's surface at the contact point), overlap <= 0 when apart.

The loop calls one of two dispatchers: :func:`wall_contact` (plane and cylinders, always
compiled) or :func:`wall_contact_bounded` (all the analytic kinds, compiled only into runs with
PhysicsSpec.bounded_walls, so that the other runs' wall loop stays as small as it was). Meshes
have their own contact code (engine.mesh). Adding a kind: its contact function, its entry in
``KINDS``, its branch in :func:`wall_contact_bounded` and its test (tests/test_walls.py checks
every entry against the dispatchers); docs/walls.md.

The wall half of the Simulation (building the table, moving, disabling and enabling walls,
a mesh's clearance, the walls' surface speed and initial overlaps) lives here as functions of
the Simulation; its methods call them.
"""

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..util.validation import check_range, unit_vector
from .kinematics import (
    CYLINDER_INNER,
    CYLINDER_OUTER,
    FRUSTUM,
    MESH,
    PLANE,
    W_ACTIVE,
    W_ANGLE_REF,
    W_AXIS,
    W_KIND,
    W_MATERIAL,
    W_OMEGA,
    W_ORIGIN,
    W_POINT,
    W_RADIUS,
    W_RAMP,
    W_RAMP_OMEGA,
    W_RAMP_ORIGIN,
    W_RAMP_VELOCITY,
    W_SEGMENT,
    W_TIME_REF,
    W_VELOCITY,
    WALL_COLUMNS,
    mesh_angle,
    ramp_walls,
)
from .mesh import mesh_geometry, open_owned_contacts, points_in_frame, signed_clearance

# first columns of the point, the axis and the kind's own columns (W_SEGMENT), for compiled code
_P, _A, _S = W_POINT.start, W_AXIS.start, W_SEGMENT.start
# a torus's own columns: the radius of its centre circle and of its tube [m]
TORUS_RING, TORUS_TUBE = _S, _S + 1
TORUS_INNER, TORUS_OUTER = 5, 6

# keys every analytic kind takes (its axis as ``axis`` or ``normal``, either is accepted)
COMMON_KEYS = frozenset({"kind", "point", "normal", "axis", "omega", "velocity", "ramp",
                         "material"})


# ---- contact functions ---------------------------------------------------------------------

@njit(inline="always", cache=True)
def plane_contact(wall, x0, x1, x2, r):
    """A plane through p with unit normal a into the domain, turning at omega about the normal
    through p."""
    a0, a1, a2 = wall[_A], wall[_A + 1], wall[_A + 2]
    d0, d1, d2 = x0 - wall[_P], x1 - wall[_P + 1], x2 - wall[_P + 2]
    dist = d0 * a0 + d1 * a1 + d2 * a2
    om = wall[W_OMEGA]
    if om == 0.0:
        return r - dist, a0, a1, a2, 0.0, 0.0, 0.0
    # omega a x (contact - p): the contact point's offset along a drops out of the product
    return (r - dist, a0, a1, a2, om * (a1 * d2 - a2 * d1), om * (a2 * d0 - a0 * d2),
            om * (a0 * d1 - a1 * d0))


@njit(inline="always", cache=True)
def cylinder_contact(wall, x0, x1, x2, r):
    """A cylinder of radius ``W_RADIUS`` about the axis through p along a, particles inside
    (CYLINDER_INNER, a drum shell) or outside (CYLINDER_OUTER, a shaft), turning at omega."""
    a0, a1, a2 = wall[_A], wall[_A + 1], wall[_A + 2]
    d0, d1, d2 = x0 - wall[_P], x1 - wall[_P + 1], x2 - wall[_P + 2]
    along = d0 * a0 + d1 * a1 + d2 * a2
    q0, q1, q2 = d0 - along * a0, d1 - along * a1, d2 - along * a2
    rho = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
    if rho == 0.0:
        return -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    u0, u1, u2 = q0 / rho, q1 / rho, q2 / rho
    if int(wall[W_KIND]) == CYLINDER_INNER:
        overlap = rho + r - wall[W_RADIUS]
        n0, n1, n2 = -u0, -u1, -u2
        contact_radius = wall[W_RADIUS] + 0.5 * overlap
    else:
        overlap = wall[W_RADIUS] + r - rho
        n0, n1, n2 = u0, u1, u2
        contact_radius = wall[W_RADIUS] - 0.5 * overlap
    # Velocity omega a x (contact - axis) of the wall's material at the contact point (mid-overlap,
    # where the torque's lever arm ends too, so that power = torque x omega exactly).
    om = wall[W_OMEGA] * contact_radius
    w0 = om * (a1 * u2 - a2 * u1)
    w1 = om * (a2 * u0 - a0 * u2)
    w2 = om * (a0 * u1 - a1 * u0)
    return overlap, n0, n1, n2, w0, w1, w2


@njit(inline="always", cache=True)
def _meridian(a0, a1, a2, q0, q1, q2, rho):
    """The unit vector from the axis towards the particle (its meridian half-plane), any one
    when it is on the axis: every meridian is as near."""
    if rho > 0.0:
        return q0 / rho, q1 / rho, q2 / rho
    if abs(a0) < 0.9:
        u0, u1, u2 = 0.0, a2, -a1
    else:
        u0, u1, u2 = -a2, 0.0, a0
    norm = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    return u0 / norm, u1 / norm, u2 / norm


@njit(inline="always", cache=True)
def frustum_contact(wall, x0, x1, x2, r):
    """A thin sheet of revolution: the segment (z0, r0)-(z1, r1) of ``W_SEGMENT`` (height along
    a, distance from the axis) revolved about the axis through p; touched from either side and
    at its rims: the nearest point lies in the particle's meridian half-plane."""
    a0, a1, a2 = wall[_A], wall[_A + 1], wall[_A + 2]
    d0, d1, d2 = x0 - wall[_P], x1 - wall[_P + 1], x2 - wall[_P + 2]
    h = d0 * a0 + d1 * a1 + d2 * a2
    q0, q1, q2 = d0 - h * a0, d1 - h * a1, d2 - h * a2
    rho = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
    u0, u1, u2 = _meridian(a0, a1, a2, q0, q1, q2, rho)
    # nearest point (zc, rc) of the segment to (h, rho) in the meridian half-plane
    z0, r0 = wall[_S], wall[_S + 1]
    dz, dr = wall[_S + 2] - z0, wall[_S + 3] - r0
    t = ((h - z0) * dz + (rho - r0) * dr) / (dz * dz + dr * dr)
    t = min(max(t, 0.0), 1.0)
    zc, rc = z0 + t * dz, r0 + t * dr
    ez, er = h - zc, rho - rc
    dist = math.sqrt(ez * ez + er * er)
    if dist > 0.0:
        ez, er = ez / dist, er / dist
    else:  # centre on the sheet: push along the sheet's normal
        ln = math.sqrt(dz * dz + dr * dr)
        ez, er = -dr / ln, dz / ln
    # Velocity omega a x (contact - axis) at the contact point, mid-overlap (where the loop's
    # torque lever arm ends, so that power = torque x omega exactly): at radius rc - er xi / 2.
    om = wall[W_OMEGA] * (rc - 0.5 * (r - dist) * er)
    return (r - dist, ez * a0 + er * u0, ez * a1 + er * u1, ez * a2 + er * u2,
            om * (a1 * u2 - a2 * u1), om * (a2 * u0 - a0 * u2), om * (a0 * u1 - a1 * u0))


@njit(inline="always", cache=True)
def torus_contact(wall, x0, x1, x2, r):
    """A torus about the axis through p along a: tube radius ``TORUS_TUBE`` around the circle of
    radius ``TORUS_RING`` in the plane through p across a (the knuckle of a dished head);
    particles inside the tube (TORUS_INNER) or outside it (TORUS_OUTER), turning at omega. The
    distance to the surface is the distance to that circle minus the tube radius."""
    a0, a1, a2 = wall[_A], wall[_A + 1], wall[_A + 2]
    d0, d1, d2 = x0 - wall[_P], x1 - wall[_P + 1], x2 - wall[_P + 2]
    h = d0 * a0 + d1 * a1 + d2 * a2
    q0, q1, q2 = d0 - h * a0, d1 - h * a1, d2 - h * a2
    rho = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
    u0, u1, u2 = _meridian(a0, a1, a2, q0, q1, q2, rho)
    ring, tube = wall[TORUS_RING], wall[TORUS_TUBE]
    # from the nearest point of the centre circle to the particle, in the meridian half-plane
    sz, sr = h, rho - ring
    dist = math.sqrt(sz * sz + sr * sr)
    if dist > 0.0:
        sz, sr = sz / dist, sr / dist
    else:  # on the centre circle: every direction of the meridian is as near; take the radial
        sz, sr = 0.0, 1.0
    if int(wall[W_KIND]) == TORUS_INNER:
        overlap = dist + r - tube
        side = -1.0
    else:
        overlap = tube + r - dist
        side = 1.0
    # the contact point, mid-overlap, lies at (tube - side xi / 2) from the circle along s
    arm = ring + (tube - side * 0.5 * overlap) * sr
    om = wall[W_OMEGA] * arm
    return (overlap, side * (sz * a0 + sr * u0), side * (sz * a1 + sr * u1),
            side * (sz * a2 + sr * u2),
            om * (a1 * u2 - a2 * u1), om * (a2 * u0 - a0 * u2), om * (a0 * u1 - a1 * u0))


@njit(inline="always", cache=True)
def wall_contact(wall, x0, x1, x2, r):
    """Overlap, unit normal (wall -> particle) and the wall's velocity at the contact point, for
    the kinds every run with walls compiles (plane, cylinders). Overlap <= 0: no contact."""
    if int(wall[W_KIND]) == PLANE:
        return plane_contact(wall, x0, x1, x2, r)
    return cylinder_contact(wall, x0, x1, x2, r)


@njit(inline="always", cache=True)
def wall_contact_bounded(wall, x0, x1, x2, r):
    """wall_contact of every analytic kind: compiled only where a run has bounded kinds
    (PhysicsSpec.bounded_walls), so that the other runs' wall loop stays as small as it was.
    One branch per entry of KINDS with ``bounded`` (tests/test_walls.py checks them all)."""
    kind = int(wall[W_KIND])
    if kind == FRUSTUM:
        return frustum_contact(wall, x0, x1, x2, r)
    if kind == TORUS_INNER or kind == TORUS_OUTER:
        return torus_contact(wall, x0, x1, x2, r)
    return wall_contact(wall, x0, x1, x2, r)


# ---- parsing: a declaration's own keys into its row ----------------------------------------

def _positive(key, wall, name):
    if name not in wall:
        raise ValueError(f"{key}.{name}: required for a {wall['kind']} wall [m]")
    return check_range(f"{key}.{name}", wall[name], 0.0, lo_open=True)


def _parse_plane(sim, key, k, wall, row):
    if wall.get("omega", 0.0) != 0.0 and sim.spec.dim == 2:
        raise ValueError(f"{key}.omega: a plane turning about its normal would carry disks "
                         "out of the plane of a 2D run; give 0")


def _parse_cylinder(sim, key, k, wall, row):
    row[W_RADIUS] = _positive(key, wall, "radius")


def _parse_annulus(sim, key, k, wall, row):
    """The flat ring from inner_radius (0: a disk) to radius at height 0."""
    outer, inner = _positive(key, wall, "radius"), wall.get("inner_radius", 0.0)
    if not 0.0 <= inner < outer:
        raise ValueError(f"{key}.inner_radius: must be in [0, radius = {outer:g}), got "
                         f"{inner:g}")
    row[W_SEGMENT] = 0.0, inner, 0.0, outer
    row[W_RADIUS] = outer


def _parse_frustum(sim, key, k, wall, row):
    try:
        (z0, r0), (z1, r1) = wall["start"], wall["end"]
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{key}: a frustum needs start and end, each [height along the axis, "
                         "radius] in m") from None
    if min(r0, r1) < 0.0 or (z0 == z1 and r0 == r1):
        raise ValueError(f"{key}: start {[z0, r0]} and end {[z1, r1]} must be distinct "
                         "points with radii >= 0")
    row[W_SEGMENT] = float(z0), float(r0), float(z1), float(r1)
    row[W_RADIUS] = max(row[W_SEGMENT][1], row[W_SEGMENT][3])  # its fastest point


def _parse_torus(sim, key, k, wall, row):
    ring, tube = _positive(key, wall, "ring_radius"), _positive(key, wall, "tube_radius")
    if not tube < ring:
        raise ValueError(f"{key}.tube_radius: must be below ring_radius = {ring:g} m (a ring "
                         f"torus), got {tube:g}")
    row[TORUS_RING], row[TORUS_TUBE] = ring, tube
    row[W_RADIUS] = ring + tube  # its fastest point


def _parse_mesh(sim, key, k, wall, row):
    """Read and check a mesh wall's triangles (file or vertices and faces, in the world at
    t = 0, metres after ``scale``); ``W_RADIUS``: its farthest vertex from the axis [m]."""
    vertices, faces = mesh_geometry(key, wall)
    frame = vertices - row[W_POINT]  # the frame's origin is the wall's point
    along = frame @ row[W_AXIS]
    arm = np.sqrt(np.maximum((frame**2).sum(1) - along**2, 0.0))
    material = np.full(len(faces), sim.material_index(wall["material"]), np.int64)
    names = wall.get("triangle_materials")
    if names is not None:  # e.g. rubber liner plates with steel lifters in one solid
        if len(names) != len(faces):
            raise ValueError(f"{key}.triangle_materials: {len(names)} names for "
                             f"{len(faces)} triangles")
        material = np.array([sim.material_index(m) for m in names], np.int64)
    sim._mesh_geometry.append((k, np.ascontiguousarray(frame), faces, material))
    row[W_RADIUS] = float(arm.max())


# ---- the registry --------------------------------------------------------------------------

@dataclass(frozen=True)
class WallKind:
    """One kind of wall.

    name: what a declaration's ``kind`` says. code: its ``W_KIND`` (an ``annulus`` is a flat
    ``frustum``: one code, two entries). keys: the keys its declaration may have.
    parse(sim, key, index, wall, row): fills its own columns of the row from the declaration,
    refusing bad values with one line naming the key. contact: its compiled contact function
    (None for meshes: engine.mesh).
    bounded: its contact is in wall_contact_bounded only (PhysicsSpec.bounded_walls).
    far_skip: the loop's near-walls pass may leave it out for a particle farther than the skin
    (wall_contact gives its gap; its surface stays in place as it turns; translating walls are
    always visited). switch: the PhysicsSpec switch it needs. dims: the run dimensions it
    exists in. axis_default: its axis when the declaration gives none (None: required).
    """

    name: str
    code: int
    keys: frozenset
    parse: object
    contact: object
    bounded: bool = False
    far_skip: bool = False
    switch: str = None
    dims: tuple = (2, 3)
    axis_default: tuple = None


KINDS = (
    WallKind("plane", PLANE, COMMON_KEYS, _parse_plane, plane_contact, far_skip=True),
    WallKind("cylinder_inner", CYLINDER_INNER, COMMON_KEYS | {"radius"}, _parse_cylinder,
             cylinder_contact, far_skip=True),
    WallKind("cylinder_outer", CYLINDER_OUTER, COMMON_KEYS | {"radius"}, _parse_cylinder,
             cylinder_contact, far_skip=True),
    WallKind("annulus", FRUSTUM, COMMON_KEYS | {"radius", "inner_radius"}, _parse_annulus,
             frustum_contact, bounded=True, switch="bounded_walls", dims=(3,)),
    WallKind("frustum", FRUSTUM, COMMON_KEYS | {"start", "end"}, _parse_frustum,
             frustum_contact, bounded=True, switch="bounded_walls", dims=(3,)),
    WallKind("mesh", MESH, COMMON_KEYS - {"normal"} | {"file", "scale", "vertices", "faces",
                                                         "triangle_materials"},
             _parse_mesh, None, switch="mesh_walls", dims=(3,), axis_default=(0.0, 0.0, 1.0)),
    WallKind("torus_inner", TORUS_INNER, COMMON_KEYS | {"ring_radius", "tube_radius"},
             _parse_torus, torus_contact, bounded=True, switch="bounded_walls", dims=(3,)),
    WallKind("torus_outer", TORUS_OUTER, COMMON_KEYS | {"ring_radius", "tube_radius"},
             _parse_torus, torus_contact, bounded=True, switch="bounded_walls", dims=(3,)),
)
BY_NAME = {kind.name: kind for kind in KINDS}
# per code, whether the loop's near-walls pass may skip a wall of that kind out of reach
SKIP_WHEN_FAR = np.array([any(k.far_skip for k in KINDS if k.code == code)
                          for code in range(max(k.code for k in KINDS) + 1)])


# ---- the wall half of a Simulation -----------------------------------------------------------

def wall_table(sim, walls):
    """The wall table of the declarations ``walls`` (list of dicts, docs/walls.md)."""
    table = np.zeros((len(walls), WALL_COLUMNS))
    for k, wall in enumerate(walls):
        key = f"walls[{k}]"
        name = wall.get("kind")
        if name not in BY_NAME:
            raise ValueError(f"{key}.kind: must be one of {sorted(BY_NAME)}, got {name!r}")
        kind = BY_NAME[name]
        if kind.switch and not getattr(sim.spec, kind.switch):
            raise ValueError(f"{key}.kind: {name} walls need PhysicsSpec({kind.switch}=True)")
        if sim.spec.dim not in kind.dims:
            raise ValueError(f"{key}.kind: {name} is a 3D wall")
        unknown = set(wall) - kind.keys
        if unknown:
            raise ValueError(f"{key}: unknown keys {sorted(unknown)} for a {name} wall")
        row = table[k]
        row[W_KIND] = kind.code
        row[W_POINT] = np.asarray(wall.get("point", (0, 0, 0)), dtype=float)
        axis = wall.get("normal", wall.get("axis", kind.axis_default))
        if axis is None:
            raise ValueError(f"{key}.axis: required for a {name} wall (or normal) [unit vector]")
        row[W_AXIS] = unit_vector(f"{key}.axis", axis)
        kind.parse(sim, key, k, wall, row)
        row[W_OMEGA] = wall.get("omega", 0.0)
        row[W_MATERIAL] = sim.material_index(wall["material"])
        row[W_ACTIVE] = 1.0
        row[W_VELOCITY] = wall_velocity(sim.spec, key, wall.get("velocity", (0.0, 0.0, 0.0)))
        row[W_ORIGIN] = row[W_POINT]
        ramp = wall_ramp(sim.spec, key, wall.get("ramp", 0.0))
        if ramp > 0.0:  # the full motion kept; ramp_walls sets the motion of the moment
            row[W_RAMP], row[W_RAMP_OMEGA] = ramp, row[W_OMEGA]
            row[W_RAMP_VELOCITY], row[W_RAMP_ORIGIN] = row[W_VELOCITY], row[W_POINT]
    if len(walls) and not sim.spec.walls:
        raise ValueError("walls: given but spec.walls is false")
    if (table[:, W_RAMP] > 0.0).any():
        ramp_walls(table, 0.0)
    return table


def wall_ramp(spec, key, ramp):
    """A wall's ramp [s] (0: at its omega and velocity from the start), checked."""
    try:
        ramp = float(ramp)
    except (TypeError, ValueError):
        ramp = math.nan
    if not (math.isfinite(ramp) and ramp >= 0.0):
        raise ValueError(f"{key}.ramp: must be a finite time >= 0 [s]")
    if ramp > 0.0 and not spec.ramped_walls:
        raise ValueError(f"{key}.ramp: ramped walls need PhysicsSpec(ramped_walls=True)")
    return ramp


def wall_velocity(spec, key, velocity):
    """A wall's translation velocity [m/s], checked against the spec."""
    velocity = np.asarray(velocity, dtype=float)
    if velocity.shape != (3,) or not np.isfinite(velocity).all():
        raise ValueError(f"{key}.velocity: must be 3 finite numbers [m/s], got "
                         f"{velocity.tolist()}")
    if velocity.any() and not spec.translating_walls:
        raise ValueError(f"{key}.velocity: translating walls need "
                         "PhysicsSpec(translating_walls=True)")
    if spec.dim == 2 and velocity[2] != 0.0:
        raise ValueError(f"{key}.velocity: a 2D run's walls move in the xy plane; give vz = 0")
    return velocity


def set_wall(sim, index, point=None, axis=None, radius=None, omega=None, velocity=None):
    """Simulation.set_wall."""
    row = sim.walls[index]
    if row[W_RAMP] > 0.0 and not (point is None and omega is None and velocity is None):
        raise ValueError(f"walls[{index}]: a ramped wall's point, omega and velocity follow its "
                         "ramp; set_wall changes only its axis and radius")
    if velocity is not None:
        row[W_VELOCITY] = wall_velocity(sim.spec, f"walls[{index}]", velocity)
    if point is not None:
        row[W_POINT] = np.asarray(point, dtype=float)
    if point is not None or velocity is not None:
        row[W_ORIGIN] = row[W_POINT] - row[W_VELOCITY] * sim.time
    if axis is not None:
        row[W_AXIS] = unit_vector(f"walls[{index}].axis", axis)
    if radius is not None:
        row[W_RADIUS] = check_range(f"walls[{index}].radius", radius, 0.0, lo_open=True)
    if omega is not None:
        if row[W_KIND] == MESH:  # the angle goes on from where it is
            row[W_ANGLE_REF] = mesh_angle(row, sim.time)
            row[W_TIME_REF] = sim.time
        row[W_OMEGA] = float(omega)


def set_wall_active(sim, index, active):
    """Take wall ``index`` away or put it (back) in place, with no contact history."""
    sim.walls[index, W_ACTIVE] = 1.0 if active else 0.0
    sim.wall_hist[:, index, :] = 0.0
    forget_mesh_contacts(sim, index)


def forget_mesh_contacts(sim, index):
    if sim._mesh_geometry:
        hist = sim._W.mesh_hist
        hist[hist[:, :, sim.layout.wall_columns + 3] == index + 1] = 0.0


def open_mesh_contacts(sim, indices):
    """Simulation.open_mesh_contacts."""
    if not sim._mesh_geometry:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    p = sim.particles
    return open_owned_contacts(sim._W, sim.walls, p.x, p.radius,
                               np.atleast_1d(np.asarray(indices, np.int64)), sim.time)


def mesh_clearance(sim, points):
    """Simulation.mesh_clearance."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    out = np.full(len(points), np.inf)
    W = sim._W
    for row, *_ in sim._mesh_geometry:
        wall = sim.walls[row]
        if wall[W_ACTIVE] == 0.0:
            continue
        frame = points_in_frame(wall, sim.time, points)
        mine = W.tri_wall == row
        out = np.minimum(out, signed_clearance(W.tri[mine], W.tri_normal[mine], frame))
    return out


def surface_speed(sim, free):
    """The fastest surface speed of any wall now [m/s] (the contact-resolution guard): turning
    (radius x omega; a turning plane: omega x the farthest free particle) plus translating."""
    w = sim.walls
    surface = np.abs(w[:, W_RADIUS] * w[:, W_OMEGA])
    # a turning plane has no radius: its surface speed is omega x the farthest particle
    for k in np.flatnonzero((w[:, W_KIND] == PLANE) & (w[:, W_OMEGA] != 0.0)):
        arm = np.cross(w[k, W_AXIS], sim.particles.x[free] - w[k, W_POINT])
        surface[k] = abs(w[k, W_OMEGA]) * np.sqrt((arm**2).sum(1)).max(initial=0.0)
    surface += np.sqrt((w[:, W_VELOCITY] ** 2).sum(1))  # translating walls
    return float(surface.max())


def worst_wall_overlap(sim, worst, what):
    """The largest overlap / radius of a free particle with an analytic wall, if above
    ``worst``, and whom it concerns."""
    p = sim.particles
    for iw, wall in enumerate(sim.walls):
        if wall[W_KIND] == MESH:
            continue
        for q in np.flatnonzero(sim.free):
            xi = wall_contact_bounded(wall, p.x[q, 0], p.x[q, 1], p.x[q, 2], p.radius[q])[0]
            if xi / p.radius[q] > worst:
                worst, what = float(xi / p.radius[q]), f"particle {q} and wall {iw}"
    return worst, what
