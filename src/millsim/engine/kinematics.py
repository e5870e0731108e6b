"""Prescribed motion: analytic walls and kinematic rigid bodies made of particles.

Walls are rows of a float table so that one compiled loop serves any mix of them (each kind, its
keys, checks and contact function: one entry of the registry in :mod:`millsim.engine.walls`):

    [kind, px, py, pz, ax, ay, az, radius, omega, material, active, z0, r0, z1, r1,
     vx, vy, vz, ox, oy, oz, ramp, omega_full, vx_full, vy_full, vz_full, ox0, oy0, oz0]

The kinds (plane, cylinders, frustums and annuli, tori, meshes), their keys and what their
columns hold: engine.walls and docs/walls.md. ``radius`` holds a turning wall's fastest radius.

``active`` is 1, or 0 for a wall that has been taken away (e.g. the holder of a bed once the bed
has settled). Any wall may also translate at the constant velocity v (a piston, a compression
plate, a lifting gate): its point is o + v t, o its point at t = 0 (``place_walls``, compiled only
with PhysicsSpec.translating_walls), and v adds to the velocity of its surface at a contact.

A wall with ``ramp`` T > 0 (PhysicsSpec.ramped_walls) starts from rest: its omega and velocity
grow linearly from 0 at t = 0 to their full values (the ``*_full`` columns) at t = T, then stay,
so that its angle is omega t^2 / (2T) before T and omega (t - T/2) after, and its point moves
likewise from o0 (``ramp_walls``, each step before the walls are placed). The loop's contacts
read omega and v of the step as for any wall; without ramp those columns are never written.

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

import numpy as np
from numba import njit

from ..util.validation import unit_vector

# codes of the first kinds (the registry of every kind, its names and code: engine.walls)
PLANE, CYLINDER_INNER, CYLINDER_OUTER, FRUSTUM, MESH = 0, 1, 2, 3, 4
WALL_COLUMNS = 29
# named columns of a wall row
W_KIND, W_POINT, W_AXIS, W_RADIUS, W_OMEGA, W_MATERIAL, W_ACTIVE = 0, slice(1, 4), slice(4, 7), 7, 8, 9, 10
W_SEGMENT = slice(11, 15)  # frustum: z0, r0, z1, r1
# mesh: cos and sin of its angle now, the angle and time of the last change of omega
W_COS, W_SIN, W_ANGLE_REF, W_TIME_REF = 11, 12, 13, 14
W_VELOCITY, W_ORIGIN = slice(15, 18), slice(18, 21)  # translation: point = origin + velocity t
# a ramped wall: the ramp's duration [s], the full omega, velocity and its point at t = 0
W_RAMP, W_RAMP_OMEGA, W_RAMP_VELOCITY, W_RAMP_ORIGIN = 21, 22, slice(23, 26), slice(26, 29)
# the first column of the point, axis, velocity and origin, for compiled code reading them one by one
W_PX, W_AX, W_VX, W_OX = 1, 4, 15, 18
W_RVX, W_ROX = 23, 26  # the full velocity and the point at t = 0 of a ramped wall

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
            table[iw, W_PX + a] = table[iw, W_OX + a] + table[iw, W_VX + a] * time


@njit(inline="always", cache=True)
def ramp_motion(ramp, t):
    """(rate at t as a fraction of the full rate, time at the full rate that turns or travels
    as far) of a start from rest at constant acceleration over ``ramp`` seconds."""
    if t < ramp:
        return t / ramp, 0.5 * t * t / ramp
    return 1.0, t - 0.5 * ramp


@njit(cache=True)
def ramp_walls(table, time):
    """Every ramped wall's omega and velocity at ``time``, and the origin (a mesh: the angle)
    that place_walls / place_meshes turn into its ramped point (angle) at ``time``."""
    for iw in range(table.shape[0]):
        ramp = table[iw, W_RAMP]
        if ramp > 0.0:
            f, s = ramp_motion(ramp, time)
            table[iw, W_OMEGA] = table[iw, W_RAMP_OMEGA] * f
            for a in range(3):
                v = table[iw, W_RVX + a] * f
                table[iw, W_VX + a] = v
                # origin + v time (place_walls) is then o0 + v_full s
                table[iw, W_OX + a] = table[iw, W_ROX + a] + table[iw, W_RVX + a] * s - v * time
            if int(table[iw, W_KIND]) == MESH:  # mesh_angle at ``time`` is then omega_full s
                table[iw, W_ANGLE_REF] = table[iw, W_RAMP_OMEGA] * s
                table[iw, W_TIME_REF] = time


@njit(inline="always", cache=True)
def mesh_angle(wall, time):
    """A mesh's angle about its axis at ``time`` (from the angle and time of the last change of
    omega)."""
    return wall[W_ANGLE_REF] + wall[W_OMEGA] * (time - wall[W_TIME_REF])


@njit(cache=True)
def place_meshes(table, time):
    """Every mesh's point and angle at ``time`` (the loop's contacts read cos and sin)."""
    for iw in range(table.shape[0]):
        if int(table[iw, W_KIND]) == MESH:
            th = mesh_angle(table[iw], time)
            table[iw, W_COS] = math.cos(th)
            table[iw, W_SIN] = math.sin(th)
            for a in range(3):
                table[iw, W_PX + a] = table[iw, W_OX + a] + table[iw, W_VX + a] * time


@njit(inline="always", cache=True)
def body_motion(body, t):
    """Angle (rad) or distance (m) travelled since t = 0, and the rate at t."""
    rate, ramp = body[B_RATE], body[B_RAMP]
    if ramp > 0.0:
        if t < ramp:
            return 0.5 * rate * t * t / ramp, rate * t / ramp
        return rate * (t - 0.5 * ramp), rate
    return rate * t, rate


@njit(inline="always", cache=True)
def body_pose(body, x0, t):
    """Position and velocity at time t of a body point whose position at t = 0 was x0, and the
    body's rate at t."""
    kind = int(body[B_KIND])
    c0, c1, c2 = body[B_CX], body[B_CX + 1], body[B_CX + 2]
    a0, a1, a2 = body[B_AX], body[B_AX + 1], body[B_AX + 2]
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


def body_table(spec, bodies):
    """The body table of the declarations ``bodies`` (list of dicts, Simulation)."""
    table = np.zeros((len(bodies), BODY_COLUMNS))
    for k, b in enumerate(bodies):
        kind = b.get("kind")
        if kind not in BODY_KINDS:
            raise ValueError(f"bodies[{k}].kind: must be one of {sorted(BODY_KINDS)}, got {kind!r}")
        table[k, B_KIND] = BODY_KINDS[kind]
        table[k, 1:4] = np.asarray(b.get("center", (0, 0, 0)), dtype=float)
        table[k, B_AXIS] = unit_vector(f"bodies[{k}].axis", b.get("axis", (0, 0, 1)))
        table[k, B_RATE] = float(b.get("rate", 0.0))
        ramp = float(b.get("ramp", 0.0))
        if not ramp >= 0.0 or not math.isfinite(ramp):
            raise ValueError(f"bodies[{k}].ramp: must be a finite time >= 0 s, got {ramp!r}")
        table[k, B_RAMP] = ramp
    if len(bodies) and not spec.bodies:
        raise ValueError("bodies: given but spec.bodies is false")
    return table

