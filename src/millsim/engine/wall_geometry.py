"""Wall surfaces and pair contact forces as drawable data for the particle snapshots (ParaView).

:class:`WallTessellator` turns a Simulation's walls at the frame's time into one cell grid:
triangles in 3D, line segments in the z = 0 plane in 2D, each cell tagged with its wall's index
and kind. Analytic walls are unbounded or of revolution, so they are drawn over a finite extent:

- a cylinder between the planes across its axis (a drum's end walls) where there are such planes,
  else over the axial span of everything drawn; a plane across a cylinder's axis as the disk of
  that cylinder's radius (a drum's end wall), any other plane as the rectangle that covers the
  projection of everything drawn (particles so far, the finite walls);
- frustums, annuli and cones over their own segment; meshes at their pose (translation and
  angle) at the frame's time, as the contact code places them (mesh.to_frame, inverted).

The extent only grows from frame to frame, so that static walls keep the same geometry and the
writer can store it once. Inactive walls (Simulation.disable_wall) are left out of the frame.

:func:`pair_contact_forces` evaluates the contact law of every touching particle pair at the
frame's state (positions, velocities, stored tangential springs), read-only: the run is not
changed by it.
"""

import math

import numpy as np

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
    W_OMEGA,
    W_ORIGIN,
    W_RADIUS,
    W_SEGMENT,
    W_TIME_REF,
    W_VELOCITY,
)

SEGMENTS = 72  # around a circle: 5 degrees, smooth at ParaView's default zoom
MARGIN = 0.05  # of the drawn extent's size, around it (planes and cylinders reach past the charge)
ALIGNED = 0.999  # |cos| above which a plane counts as across a cylinder's axis


def _frame_of(axis):
    """Two unit vectors u, v completing the unit ``axis`` to a right-handed frame."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(axis, u)


def _rotate(points, axis, angle):
    """``points`` (n, 3) turned by ``angle`` about the unit ``axis`` through the origin
    (Rodrigues, as mesh.rotate)."""
    c, s = math.cos(angle), math.sin(angle)
    along = (points @ axis)[:, None] * (1.0 - c)
    return points * c + np.cross(axis, points) * s + axis * along


def _band(centre, axis, z0, r0, z1, r1, segments):
    """Triangles of the surface of revolution of the segment (z0, r0)-(z1, r1) about the axis
    through ``centre``: a cylinder, cone, frustum, annulus or disk (a rim of radius 0 is one
    point, so no degenerate triangle is drawn)."""
    u, v = _frame_of(axis)
    phi = np.linspace(0.0, 2.0 * math.pi, segments, endpoint=False)
    ring = np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v
    k = np.arange(segments)
    nxt = (k + 1) % segments
    rims, index, offset = [], [], 0
    for z, r in ((z0, r0), (z1, r1)):
        if r == 0.0:
            rims.append((centre + z * axis)[None])
            index.append(np.full(segments, offset))
            offset += 1
        else:
            rims.append(centre + z * axis + r * ring)
            index.append(offset + k)
            offset += segments
    a, b = index
    a1, b1 = a[nxt], b[nxt]
    tri = []
    if r0 != 0.0:
        tri.append(np.stack([a, a1, b], 1))
    if r1 != 0.0:
        tri.append(np.stack([a1, b1, b], 1))
    return np.concatenate(rims), np.concatenate(tri)


class WallTessellator:
    """Per frame, the walls of a Simulation as one cell grid (see the module's docstring).

    ``segments``: points around a circle. Returns None from a call when the simulation has no
    walls, else a dict: ``points`` (P, 3) [m], ``cells`` (C, 3) triangles or (C, 2) segments
    (indices into points), ``wall`` (C,) the wall's index in the Simulation's wall table and
    ``kind`` (C,) its kind (engine.kinematics: 0 plane, 1 cylinder inside, 2 cylinder outside,
    3 frustum/annulus/cone, 4 mesh).
    """

    def __init__(self, segments=SEGMENTS):
        self.segments = segments
        self.lo = self.hi = None  # the drawn extent so far

    def __call__(self, sim):
        table = sim.walls
        if not len(table):
            return None
        self._grow(sim)
        size = float(np.max(self.hi - self.lo))
        lo, hi = self.lo - MARGIN * size, self.hi + MARGIN * size
        meshes = {row: (frame, faces) for row, frame, faces, _ in sim._mesh_geometry}
        parts = []
        for iw, row in enumerate(table):
            if row[W_ACTIVE] == 0.0:
                continue
            point = row[W_ORIGIN] + row[W_VELOCITY] * sim.time
            if sim.spec.dim == 2:
                drawn = self._wall_2d(row, point, lo, hi)
            else:
                drawn = self._wall_3d(table, row, point, lo, hi, meshes.get(iw), sim.time)
            if drawn is not None:
                parts.append((iw, int(row[W_KIND]), *drawn))
        width = 2 if sim.spec.dim == 2 else 3
        points, cells, wall, kind, offset = [np.zeros((0, 3))], [np.zeros((0, width), np.int64)], \
            [], [], 0
        for iw, k, p, c in parts:
            points.append(p)
            cells.append(c + offset)
            wall.append(np.full(len(c), iw, np.int32))
            kind.append(np.full(len(c), k, np.int32))
            offset += len(p)
        return {"points": np.concatenate(points), "cells": np.concatenate(cells),
                "wall": np.concatenate(wall or [np.zeros(0, np.int32)]),
                "kind": np.concatenate(kind or [np.zeros(0, np.int32)])}

    # ---- the extent --------------------------------------------------------------------------
    def _grow(self, sim):
        """Take in the particles now and the finite walls (cylinder cross-sections, frustum
        rims, meshes): everything a plane or cylinder should reach across."""
        p = sim.particles
        boxes = []
        if len(p.radius):
            r = p.radius[:, None]
            boxes += [p.x - r, p.x + r]
        for row in sim.walls:
            point, axis = row[W_ORIGIN] + row[W_VELOCITY] * sim.time, row[W_AXIS]
            kind = row[W_KIND]
            if kind in (CYLINDER_INNER, CYLINDER_OUTER, FRUSTUM):
                u, v = _frame_of(axis)
                heights = (0.0,) if kind != FRUSTUM else (row[W_SEGMENT][0], row[W_SEGMENT][2])
                for z in heights:
                    for d in (u, -u, v, -v):
                        boxes.append((point + z * axis + row[W_RADIUS] * d)[None])
            elif kind == PLANE:
                boxes.append(point[None])
        for row, frame, *_ in sim._mesh_geometry:
            boxes.append(self._mesh_points(sim.walls[row], frame, sim.time))
        if not boxes:
            return
        points = np.concatenate(boxes)
        if sim.spec.dim == 2:
            points = points.copy()
            points[:, 2] = 0.0
        lo, hi = points.min(0), points.max(0)
        self.lo = lo if self.lo is None else np.minimum(self.lo, lo)
        self.hi = hi if self.hi is None else np.maximum(self.hi, hi)

    @staticmethod
    def _mesh_points(row, frame, time):
        """A mesh's vertices in the world at ``time``: its frame turned by its angle then,
        placed at its point (the inverse of mesh.to_frame)."""
        angle = row[W_ANGLE_REF] + row[W_OMEGA] * (time - row[W_TIME_REF])
        return row[W_ORIGIN] + row[W_VELOCITY] * time + _rotate(frame, row[W_AXIS], angle)

    @staticmethod
    def _span(lo, hi, centre, direction):
        """Range of (corner - centre) . direction over the corners of the box [lo, hi]."""
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])
        s = (corners - centre) @ direction
        return float(s.min()), float(s.max())

    # ---- one wall ----------------------------------------------------------------------------
    def _wall_3d(self, table, row, point, lo, hi, mesh, time):
        kind, axis = row[W_KIND], row[W_AXIS]
        if kind == MESH:
            frame, faces = mesh
            return self._mesh_points(row, frame, time), np.asarray(faces, np.int64)
        if kind == FRUSTUM:
            return _band(point, axis, *row[W_SEGMENT], self.segments)
        if kind in (CYLINDER_INNER, CYLINDER_OUTER):
            s0, s1 = self._span(lo, hi, point, axis)
            ends = {1.0: [], -1.0: []}  # planes across the axis facing +axis / -axis
            for other in table:
                if other[W_KIND] == PLANE and other[W_ACTIVE] != 0.0:
                    cos = float(other[W_AXIS] @ axis)
                    if abs(cos) > ALIGNED:
                        ends[math.copysign(1.0, cos)].append(float((other[W_ORIGIN] - point)
                                                                   @ axis))
            low = [s for s in ends[1.0] if s < s1]
            high = [s for s in ends[-1.0] if s > s0]
            s0, s1 = (max(low) if low else s0), (min(high) if high else s1)
            r = row[W_RADIUS]
            return _band(point, axis, s0, r, s1, r, self.segments)
        if kind != PLANE:
            return None  # a kind not drawn yet (docs/walls.md, "Adding a kind")
        # a plane: the disk of a cylinder it crosses, else a rectangle over the extent
        for other in table:
            if (other[W_KIND] in (CYLINDER_INNER, CYLINDER_OUTER) and other[W_ACTIVE] != 0.0
                    and abs(float(other[W_AXIS] @ axis)) > ALIGNED):
                centre = other[W_ORIGIN] + ((point - other[W_ORIGIN]) @ axis) * axis
                return _band(centre, axis, 0.0, 0.0, 0.0, other[W_RADIUS], self.segments)
        u, v = _frame_of(axis)
        centre = point + ((0.5 * (lo + hi) - point) - ((0.5 * (lo + hi) - point) @ axis)
                          * axis)
        (u0, u1), (v0, v1) = self._span(lo, hi, centre, u), self._span(lo, hi, centre, v)
        corners = centre + np.array([u0 * u + v0 * v, u1 * u + v0 * v, u1 * u + v1 * v,
                                     u0 * u + v1 * v])
        return corners, np.array([[0, 1, 2], [0, 2, 3]])

    def _wall_2d(self, row, point, lo, hi):
        """A 2D run's walls in the z = 0 plane: a plane as a segment, a cylinder (its axis
        along z) as a closed polygon."""
        kind, axis = row[W_KIND], row[W_AXIS]
        point = np.array([point[0], point[1], 0.0])
        if kind == PLANE:
            along = np.array([-axis[1], axis[0], 0.0])
            along /= np.linalg.norm(along)
            s0, s1 = self._span(lo, hi, point, along)
            return np.array([point + s0 * along, point + s1 * along]), np.array([[0, 1]])
        if kind in (CYLINDER_INNER, CYLINDER_OUTER):
            phi = np.linspace(0.0, 2.0 * math.pi, self.segments, endpoint=False)
            r = row[W_RADIUS]
            ring = point + r * np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], 1)
            k = np.arange(self.segments)
            return ring, np.stack([k, (k + 1) % self.segments], 1)
        return None  # frustums and meshes are 3D walls (refused in 2D by the Simulation)


def pair_contact_forces(sim):
    """The touching particle pairs of ``sim`` now and the forces of their contact law.

    Returns a dict of arrays over the pairs: ``i``, ``j`` (particle indices), ``normal`` (unit,
    from j to i), ``overlap`` [m], ``contact_point`` [m] (mid-overlap, as the contact code puts
    it), ``normal_force`` and ``tangential_force`` [N] (vectors, on i; j gets the opposite).
    Elastic, damping and friction force of the law, at the stored tangential springs (their
    copy is advanced by a zero step, so the run's state is untouched); lubrication and the
    rolling-friction torque are not included. Refused for runs with a breakage model, whose
    fragments count their overlap from a reference the law alone does not know.
    """
    if sim.breakage is not None:
        raise ValueError("snapshot contacts: not for runs with a breakage model (fragments' "
                         "reference overlaps and bonds are the model's); run without breakage")
    i, j, overlap, slots = sim.contact_pairs(with_slots=True)
    p = sim.particles
    d = sim.separation(i, j)
    dist = np.linalg.norm(d, axis=1)
    n = d / dist[:, None] if len(dist) else np.zeros((0, 3))
    ri, rj = p.radius[i], p.radius[j]
    ai, aj = ri - 0.5 * overlap, rj - 0.5 * overlap
    spin = ai[:, None] * p.w[i] + aj[:, None] * p.w[j]
    vrel = p.v[i] - p.v[j] - np.cross(spin, n)
    with np.errstate(divide="ignore"):  # two body particles: infinite, as in the step loop
        m_eff = 1.0 / (p.inv_mass[i] + p.inv_mass[j])
    r_eff = ri * rj / (ri + rj)
    state = np.array(sim.contacts.state[:, :sim.law.spring_columns], dtype=np.float64)
    fn = np.zeros(len(i))
    ft = np.zeros((len(i), 3))
    force, clip = sim.law.force, sim.spec.clip_normal
    for q in range(len(i)):
        params = sim.pair_params[p.material[i[q]], p.material[j[q]]]
        fn[q], ft[q, 0], ft[q, 1], ft[q, 2], _ = force(
            params, overlap[q], n[q, 0], n[q, 1], n[q, 2], vrel[q, 0], vrel[q, 1], vrel[q, 2],
            m_eff[q], r_eff[q], clip, state, int(slots[q]), 0.0)
    return {"i": i, "j": j, "normal": n, "overlap": overlap,
            "contact_point": p.x[i] - ai[:, None] * n, "normal_force": fn[:, None] * n,
            "tangential_force": ft}
