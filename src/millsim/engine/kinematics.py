"""Prescribed motion: analytic walls and kinematic rigid bodies made of particles.

Walls are rows of a float table so that one compiled loop serves any mix of them:

    [kind, px, py, pz, ax, ay, az, radius, omega, material, active, z0, r0, z1, r1,
     vx, vy, vz, ox, oy, oz]

- ``PLANE``: point p, unit normal a pointing into the domain; its surface turns at ``omega``
  rad/s about the normal through p (a drum's end wall turning with the shell; 0: static).
- ``CYLINDER_INNER``: particles inside a cylinder of the given radius, axis through p along a, the
  surface rotating at ``omega`` rad/s about a (a drum shell).
- ``CYLINDER_OUTER``: particles outside the cylinder (a shaft), same rotation convention.
- ``FRUSTUM``: a thin sheet of revolution about the axis through p along a: the segment from
  (z0, r0) to (z1, r1) in (height along a, distance from the axis), revolved. A flat ring or disk
  (z0 = z1, a hole of radius r0 >= 0), a truncated cone (a hopper with its orifice), a cylinder
  shell that ends where the equipment ends (r0 = r1). Touched from either side and at its two rim
  circles: the nearest point of the surface lies in the particle's meridian half-plane, where it
  is the nearest point of the segment. ``radius`` holds max(r0, r1) (its fastest point); the
  sheet turns at ``omega`` about a (an agitator disk).

- ``MESH``: a rigid triangulated solid (engine.mesh): p is its frame's origin, turning at
  ``omega`` about the axis through p along a; ``radius`` holds the farthest vertex from the axis
  (its fastest point).

``active`` is 1, or 0 for a wall that has been taken away (e.g. the holder of a bed once the bed
has settled). Any wall may also translate at the constant velocity v (a piston, a compression
plate, a lifting gate): its point is o + v t, o its point at t = 0 (``place_walls``, compiled only
with PhysicsSpec.translating_walls), and v adds to the velocity of its surface at a contact.

Kinematic bodies are groups of particles whose positions follow a prescribed motion from their
reference positions at t = 0, so there is no drift however long the run:

    [kind, cx, cy, cz, ax, ay, az, rate, ramp]

- ``ROTATE``: rotation about the axis through c along unit a at ``rate`` rad/s.
- ``TRANSLATE``: translation along unit a at ``rate`` m/s.

``ramp`` > 0 brings the body from rest to ``rate`` at a constant acceleration over ``ramp``
seconds (a mill's drive starting up, so that the charge is set moving gradually instead of being
struck at full speed from rest); 0 means at ``rate`` from t = 0.
"""

import math

from numba import njit

PLANE, CYLINDER_INNER, CYLINDER_OUTER, FRUSTUM, MESH = 0, 1, 2, 3, 4
# user-facing kinds; "annulus" and "cone" are frustums (Simulation._wall_table)
WALL_KINDS = {"plane": PLANE, "cylinder_inner": CYLINDER_INNER, "cylinder_outer": CYLINDER_OUTER,
              "annulus": FRUSTUM, "frustum": FRUSTUM, "mesh": MESH}
WALL_COLUMNS = 21
# named columns of a wall row
W_KIND, W_POINT, W_AXIS, W_RADIUS, W_OMEGA, W_MATERIAL, W_ACTIVE = 0, slice(1, 4), slice(4, 7), 7, 8, 9, 10
W_SEGMENT = slice(11, 15)  # frustum: z0, r0, z1, r1
# mesh: cos and sin of its angle now, the angle and time of the last change of omega
W_COS, W_SIN, W_ANGLE_REF, W_TIME_REF = 11, 12, 13, 14
W_VELOCITY, W_ORIGIN = slice(15, 18), slice(18, 21)  # translation: point = origin + velocity t
# the first column of the point, axis and velocity, for compiled code that reads them one by one
W_PX, W_AX, W_VX = 1, 4, 15

ROTATE, TRANSLATE = 0, 1
BODY_KINDS = {"rotate": ROTATE, "translate": TRANSLATE}
BODY_COLUMNS = 9
B_KIND, B_CENTER, B_AXIS, B_RATE, B_RAMP = 0, slice(1, 4), slice(4, 7), 7, 8
B_CX, B_AX = 1, 4  # the first column of the centre and of the axis


@njit(cache=True)
def place_walls(table, time):
    """Every wall's point at ``time``: origin + velocity time (translating walls)."""
    for iw in range(table.shape[0]):
        for a in range(3):
            table[iw, 1 + a] = table[iw, 18 + a] + table[iw, 15 + a] * time


@njit(inline="always", cache=True)
def mesh_angle(wall, time):
    """A mesh's angle about its axis at ``time`` (from the angle and time of the last change of
    omega)."""
    return wall[13] + wall[8] * (time - wall[14])


@njit(cache=True)
def place_meshes(table, time):
    """Every mesh's point and angle at ``time`` (the loop's contacts read cos and sin)."""
    for iw in range(table.shape[0]):
        if int(table[iw, 0]) == MESH:
            th = mesh_angle(table[iw], time)
            table[iw, 11] = math.cos(th)
            table[iw, 12] = math.sin(th)
            for a in range(3):
                table[iw, 1 + a] = table[iw, 18 + a] + table[iw, 15 + a] * time


@njit(inline="always", cache=True)
def wall_contact(wall, x0, x1, x2, r):
    """Overlap, unit normal (wall -> particle) and the wall's velocity at the contact point.

    Returns overlap <= 0 when there is no contact.
    """
    kind = int(wall[0])
    p0, p1, p2 = wall[1], wall[2], wall[3]
    a0, a1, a2 = wall[4], wall[5], wall[6]
    d0, d1, d2 = x0 - p0, x1 - p1, x2 - p2
    if kind == PLANE:
        dist = d0 * a0 + d1 * a1 + d2 * a2
        om = wall[8]
        if om == 0.0:
            return r - dist, a0, a1, a2, 0.0, 0.0, 0.0
        # omega a x (contact - p): the contact point's offset along a drops out of the product
        return (r - dist, a0, a1, a2, om * (a1 * d2 - a2 * d1), om * (a2 * d0 - a0 * d2),
                om * (a0 * d1 - a1 * d0))
    along = d0 * a0 + d1 * a1 + d2 * a2
    q0, q1, q2 = d0 - along * a0, d1 - along * a1, d2 - along * a2
    rho = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
    if rho == 0.0:
        return -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    u0, u1, u2 = q0 / rho, q1 / rho, q2 / rho
    if kind == CYLINDER_INNER:
        overlap = rho + r - wall[7]
        n0, n1, n2 = -u0, -u1, -u2
        contact_radius = wall[7] + 0.5 * overlap
    else:
        overlap = wall[7] + r - rho
        n0, n1, n2 = u0, u1, u2
        contact_radius = wall[7] - 0.5 * overlap
    # Velocity omega a x (contact - axis) of the wall's material at the contact point (mid-overlap,
    # where the torque's lever arm ends too, so that power = torque x omega exactly).
    om = wall[8] * contact_radius
    w0 = om * (a1 * u2 - a2 * u1)
    w1 = om * (a2 * u0 - a0 * u2)
    w2 = om * (a0 * u1 - a1 * u0)
    return overlap, n0, n1, n2, w0, w1, w2


@njit(inline="always", cache=True)
def wall_contact_bounded(wall, x0, x1, x2, r):
    """wall_contact with frustum walls too: compiled only where a run has them
    (PhysicsSpec.bounded_walls), so that the other runs' wall loop stays as small as it was."""
    if int(wall[0]) != FRUSTUM:
        return wall_contact(wall, x0, x1, x2, r)
    a0, a1, a2 = wall[4], wall[5], wall[6]
    d0, d1, d2 = x0 - wall[1], x1 - wall[2], x2 - wall[3]
    along = d0 * a0 + d1 * a1 + d2 * a2
    q0, q1, q2 = d0 - along * a0, d1 - along * a1, d2 - along * a2
    rho = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
    return _frustum_contact(wall, along, q0, q1, q2, rho, r)


@njit(inline="always", cache=True)
def _frustum_contact(wall, h, q0, q1, q2, rho, r):
    """wall_contact of a frustum: the particle's height h along the axis and in-plane offset q
    (length rho) from it."""
    a0, a1, a2 = wall[4], wall[5], wall[6]
    if rho > 0.0:
        u0, u1, u2 = q0 / rho, q1 / rho, q2 / rho
    else:  # on the axis: every meridian is as near; take any
        if abs(a0) < 0.9:
            u0, u1, u2 = 0.0, a2, -a1
        else:
            u0, u1, u2 = -a2, 0.0, a0
        norm = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        u0, u1, u2 = u0 / norm, u1 / norm, u2 / norm
    # nearest point (zc, rc) of the segment to (h, rho) in the meridian half-plane
    z0, r0 = wall[11], wall[12]
    dz, dr = wall[13] - z0, wall[14] - r0
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
    om = wall[8] * (rc - 0.5 * (r - dist) * er)
    return (r - dist, ez * a0 + er * u0, ez * a1 + er * u1, ez * a2 + er * u2,
            om * (a1 * u2 - a2 * u1), om * (a2 * u0 - a0 * u2), om * (a0 * u1 - a1 * u0))


@njit(inline="always", cache=True)
def body_motion(body, t):
    """Angle (rad) or distance (m) travelled since t = 0, and the rate at t."""
    rate, ramp = body[7], body[8]
    if ramp > 0.0:
        if t < ramp:
            return 0.5 * rate * t * t / ramp, rate * t / ramp
        return rate * (t - 0.5 * ramp), rate
    return rate * t, rate


@njit(inline="always", cache=True)
def body_pose(body, x0, t):
    """Position and velocity at time t of a body point whose position at t = 0 was x0, and the
    body's rate at t."""
    kind = int(body[0])
    c0, c1, c2 = body[1], body[2], body[3]
    a0, a1, a2 = body[4], body[5], body[6]
    th, rate = body_motion(body, t)
    if kind == TRANSLATE:
        return (x0[0] + a0 * th, x0[1] + a1 * th, x0[2] + a2 * th,
                a0 * rate, a1 * rate, a2 * rate, rate)
    # Rodrigues rotation of (x0 - c) about a by the angle th.
    r0, r1, r2 = x0[0] - c0, x0[1] - c1, x0[2] - c2
    ct = math.cos(th)
    st = math.sin(th)
    ad = a0 * r0 + a1 * r1 + a2 * r2
    k0 = a1 * r2 - a2 * r1
    k1 = a2 * r0 - a0 * r2
    k2 = a0 * r1 - a1 * r0
    y0 = r0 * ct + k0 * st + a0 * ad * (1.0 - ct)
    y1 = r1 * ct + k1 * st + a1 * ad * (1.0 - ct)
    y2 = r2 * ct + k2 * st + a2 * ad * (1.0 - ct)
    return (c0 + y0, c1 + y1, c2 + y2,
            rate * (a1 * y2 - a2 * y1), rate * (a2 * y0 - a0 * y2), rate * (a0 * y1 - a1 * y0), rate)
