"""Triangle-mesh walls: rigid triangulated solids (liners, lifters, chambers from CAD).

A mesh is one row of the wall table (kind ``MESH``, engine.kinematics) for its motion, material
and loads, plus its triangles in :class:`MeshArrays`, stored in the mesh's own frame: a world point
is ``p(t) + R(theta(t)) y`` for the frame point y, with p(t) = origin + v t the wall's point and
R the rotation by theta(t) = theta_ref + omega (t - t_ref) about the wall's axis through p. The
triangles never move in that frame, so they are binned once in a uniform grid; each neighbour-list
rebuild lists, per particle, the triangles within its radius plus the skin (and a fluid's reach)
in the frame at that time (``rebuilt_mesh_candidates``), and the loop asks for a rebuild before
the mesh's fastest point has travelled half the skin (loop ``advance``), so that with the
particles' own half skin no contact is missed.

Contact with a triangle (Ericson, Real-Time Collision Detection, 2005, sec. 5.1.5: the closest
point and whether it lies in the face, on an edge or at a vertex). Faces are one-sided: the mesh
is a closed solid whose normals point into the particles' domain (``engine.mesh_io``), and a
particle whose centre is behind a triangle's plane does not touch that triangle. One contact
per touching surface (``owns``): a triangle's contact counts unless its closest point lies on an
edge or vertex it shares with a nearer touching triangle (larger overlap; equal overlaps: the
lower index), "on" meaning within TIE r. So only local minima of the distance over the surface
count, each once: beside a flat or convex edge the face (or the edge, in its Voronoi region)
wins, and where several triangles reach the same point (a sphere exactly over a shared edge or
vertex, which rounding reports as two faces, or an edge and a vertex) the total order of
(overlap, index) leaves exactly one. This is the face > edge > vertex precedence of the DEM mesh
contact literature (e.g. Hu et al., Granular Matter 2013; LIGGGHTS ``mesh/surface`` drops edge
and vertex contacts hidden by a face) decided by distance instead of by the reported region.
Face contacts at a concave corner (a lifter's root) are distinct minima and both count.

Each particle has MESH_SLOTS contact-history slots for all meshes; a contact keeps the slot whose
stored normal (in the mesh frame) is within 45 degrees of its own, so that the tangential spring
carries on when a particle rolls from one triangle to the next.
"""

import math
from collections import namedtuple

import numpy as np
from numba import njit

from .kinematics import MESH, W_ACTIVE, W_AX, W_KIND, W_OMEGA, W_OX, W_RADIUS, W_VX, mesh_angle
from .state import MESH_FIELDS

MESH_SLOTS = 6
TAG_COLUMNS = 4  # per slot after the contact state: the normal in the mesh frame (3), wall + 1
SAME_CONTACT_COS = math.cos(math.pi / 4.0)
# A closest point within TIE r of a shared edge or vertex is on it (``owns``), a centre whose
# projection is within TIE r of a face is over it (``triangle_contact``): far above the rounding
# of the overlaps compared there (their ties reach ~1e-7 r from the feature), far below the
# extent of any contact (past a convex edge the face's contact is kept for TIE r / height rad).
TIE = 1e-5
# region of the closest point: the face, a vertex (a, b, c), an edge (ab, ac, bc)
FACE, VERTEX_A, VERTEX_B, VERTEX_C, EDGE_AB, EDGE_AC, EDGE_BC = 0, 1, 2, 3, 4, 5, 6
# grid row per wall: lower corner (3), cell size, cells per axis (3), first cell's index
G_LO, G_SIZE, G_CELLS, G_OFFSET = slice(0, 3), 3, slice(4, 7), 7
GRID_COLUMNS = 8
MAX_CELLS = 2_000_000  # per mesh; a coarser grid beyond (a huge mesh around tiny particles)

# tri: vertices (T, 3, 3) in the frame; normal: unit outward normals (T, 3); vertex: global vertex
# ids (T, 3); wall: the wall row (T,); material (T,); grid, cell_start, cell_tri: the binned
# triangles; cand_start, cand_tri: per particle, the triangles near it (CSR, rebuilt with the
# neighbour list); hist: per particle and slot, the contact state and tag; built: the time of
# the candidates (1,).
MeshArrays = namedtuple("MeshArrays", MESH_FIELDS)


def build_meshes(meshes, n_walls, n, columns, cell_size):
    """MeshArrays of the meshes ``[(wall row, vertices in the frame (V, 3), faces (F, 3),
    material index per face (F,))]``; ``cell_size`` [m]: the grid's cell (about a particle diameter plus skin).
    """
    tris, normals, vertex_ids, walls, materials = [], [], [], [], []
    grid = np.zeros((n_walls, GRID_COLUMNS))
    starts, cells = [np.zeros(1, np.int64)], []
    offset, first_vertex, first_tri, n_binned = 0, 0, 0, 0
    for row, vertices, faces, material in meshes:
        tri = vertices[faces]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        normal /= np.linalg.norm(normal, axis=1)[:, None]
        lo, hi = tri.min(axis=(0, 1)), tri.max(axis=(0, 1))
        size = float(cell_size)
        while np.prod(np.floor((hi - lo) / size) + 1) > MAX_CELLS:
            size *= 2.0
        shape = (np.floor((hi - lo) / size) + 1).astype(np.int64)
        grid[row, G_LO], grid[row, G_SIZE], grid[row, G_CELLS] = lo, size, shape
        grid[row, G_OFFSET] = offset
        start, cell_tri = _bin_triangles(tri, lo, size, shape)
        starts.append(start[1:] + n_binned)
        cells.append(cell_tri + first_tri)
        n_binned += len(cell_tri)
        offset += int(np.prod(shape))
        tris.append(tri)
        normals.append(normal)
        vertex_ids.append(faces + first_vertex)
        walls.append(np.full(len(faces), row, np.int64))
        materials.append(np.asarray(material, np.int64))
        first_vertex += len(vertices)
        first_tri += len(faces)
    return MeshArrays(np.ascontiguousarray(np.concatenate(tris)), np.concatenate(normals),
                      np.concatenate(vertex_ids).astype(np.int64), np.concatenate(walls),
                      np.concatenate(materials), grid, np.concatenate(starts),
                      np.concatenate(cells), np.zeros(n + 1, np.int64), np.zeros(0, np.int64),
                      np.zeros((n, MESH_SLOTS, columns + TAG_COLUMNS)), np.full(1, -np.inf))


@njit(cache=True)
def _bin_triangles(tri, lo, size, shape):
    """CSR of the triangles overlapping each cell (by bounding box)."""
    count = np.zeros(shape[0] * shape[1] * shape[2] + 1, np.int64)
    for fill in range(2):
        if fill:
            for c in range(1, count.shape[0]):
                count[c] += count[c - 1]
            out = np.empty(count[-1], np.int64)
            pos = count[:-1].copy()
        else:
            out = np.empty(0, np.int64)
            pos = np.empty(0, np.int64)
        for t in range(tri.shape[0]):
            c_lo = np.empty(3, np.int64)
            c_hi = np.empty(3, np.int64)
            for a in range(3):
                mn = min(tri[t, 0, a], tri[t, 1, a], tri[t, 2, a])
                mx = max(tri[t, 0, a], tri[t, 1, a], tri[t, 2, a])
                c_lo[a] = min(shape[a] - 1, max(0, int((mn - lo[a]) / size)))
                c_hi[a] = min(shape[a] - 1, max(0, int((mx - lo[a]) / size)))
            for cx in range(c_lo[0], c_hi[0] + 1):
                for cy in range(c_lo[1], c_hi[1] + 1):
                    for cz in range(c_lo[2], c_hi[2] + 1):
                        cell = (cx * shape[1] + cy) * shape[2] + cz
                        if fill:
                            out[pos[cell]] = t
                            pos[cell] += 1
                        else:
                            count[cell + 1] += 1
    return count, out


@njit(inline="always", cache=True)
def rotate(c, s, a0, a1, a2, d0, d1, d2):
    """d rotated about the unit axis a by the angle whose cosine and sine are c, s (Rodrigues)."""
    ad = (a0 * d0 + a1 * d1 + a2 * d2) * (1.0 - c)
    return (d0 * c + (a1 * d2 - a2 * d1) * s + a0 * ad,
            d1 * c + (a2 * d0 - a0 * d2) * s + a1 * ad,
            d2 * c + (a0 * d1 - a1 * d0) * s + a2 * ad)


@njit(inline="always", cache=True)
def to_frame(wall, time, x0, x1, x2):
    """A world point in a mesh's frame at ``time``: taken back by its translation and angle."""
    th = mesh_angle(wall, time)
    return rotate(math.cos(th), -math.sin(th), wall[W_AX], wall[W_AX + 1], wall[W_AX + 2],
                  x0 - wall[W_OX] - wall[W_VX] * time, x1 - wall[W_OX + 1] - wall[W_VX + 1] * time,
                  x2 - wall[W_OX + 2] - wall[W_VX + 2] * time)


@njit(cache=True)
def points_in_frame(wall, time, points):
    """``to_frame`` of every row of ``points`` (n, 3)."""
    out = np.empty_like(points)
    for i in range(points.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = to_frame(wall, time, points[i, 0], points[i, 1],
                                                   points[i, 2])
    return out


@njit(inline="always", cache=True)
def closest_on_triangle(tri, y0, y1, y2):
    """Closest point of triangle ``tri`` (3, 3) to y, and its region (Ericson 2005, 5.1.5)."""
    a0, a1, a2 = tri[0, 0], tri[0, 1], tri[0, 2]
    ab0, ab1, ab2 = tri[1, 0] - a0, tri[1, 1] - a1, tri[1, 2] - a2
    ac0, ac1, ac2 = tri[2, 0] - a0, tri[2, 1] - a1, tri[2, 2] - a2
    ap0, ap1, ap2 = y0 - a0, y1 - a1, y2 - a2
    d1 = ab0 * ap0 + ab1 * ap1 + ab2 * ap2
    d2 = ac0 * ap0 + ac1 * ap1 + ac2 * ap2
    if d1 <= 0.0 and d2 <= 0.0:
        return a0, a1, a2, VERTEX_A
    bp0, bp1, bp2 = y0 - tri[1, 0], y1 - tri[1, 1], y2 - tri[1, 2]
    d3 = ab0 * bp0 + ab1 * bp1 + ab2 * bp2
    d4 = ac0 * bp0 + ac1 * bp1 + ac2 * bp2
    if d3 >= 0.0 and d4 <= d3:
        return tri[1, 0], tri[1, 1], tri[1, 2], VERTEX_B
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return a0 + v * ab0, a1 + v * ab1, a2 + v * ab2, EDGE_AB
    cp0, cp1, cp2 = y0 - tri[2, 0], y1 - tri[2, 1], y2 - tri[2, 2]
    d5 = ab0 * cp0 + ab1 * cp1 + ab2 * cp2
    d6 = ac0 * cp0 + ac1 * cp1 + ac2 * cp2
    if d6 >= 0.0 and d5 <= d6:
        return tri[2, 0], tri[2, 1], tri[2, 2], VERTEX_C
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return a0 + w * ac0, a1 + w * ac1, a2 + w * ac2, EDGE_AC
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        b0, b1, b2 = tri[1, 0], tri[1, 1], tri[1, 2]
        return (b0 + w * (tri[2, 0] - b0), b1 + w * (tri[2, 1] - b1), b2 + w * (tri[2, 2] - b2),
                EDGE_BC)
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    return (a0 + ab0 * v + ac0 * w, a1 + ab1 * v + ac1 * w, a2 + ab2 * v + ac2 * w, FACE)


@njit(inline="always", cache=True)
def triangle_contact(M, t, y0, y1, y2, r):
    """Contact of a sphere (centre y in the frame, radius r) with triangle t: (overlap, unit
    normal triangle -> centre in the frame, region); overlap <= 0: none (also behind the face).
    A centre whose projection lies on the face or within TIE r of it has the face's contact."""
    nf = M.tri_normal[t]
    tri = M.tri[t]
    height = (y0 - tri[0, 0]) * nf[0] + (y1 - tri[0, 1]) * nf[1] + (y2 - tri[0, 2]) * nf[2]
    if height <= 0.0 or height >= r:
        return -1.0, 0.0, 0.0, 0.0, -1
    q0, q1, q2, region = closest_on_triangle(tri, y0, y1, y2)
    if region == FACE:  # the plane's normal and distance exactly, as for an analytic plane
        return r - height, nf[0], nf[1], nf[2], FACE
    e0, e1, e2 = y0 - q0, y1 - q1, y2 - q2
    # The centre's projection within TIE r of the face is on it: rounding puts a point on a
    # shared edge or vertex just outside some of the triangles there, whose edge or vertex
    # normal would lean by that offset over the height (up to ~1e-7 where the overlaps tie).
    o0, o1, o2 = e0 - height * nf[0], e1 - height * nf[1], e2 - height * nf[2]
    if o0 * o0 + o1 * o1 + o2 * o2 <= (TIE * r) ** 2:
        return r - height, nf[0], nf[1], nf[2], FACE
    dist = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    if dist >= r:
        return -1.0, 0.0, 0.0, 0.0, -1
    return r - dist, e0 / dist, e1 / dist, e2 / dist, region


@njit(inline="always", cache=True)
def _has(M, t, vid):
    v = M.tri_vertex[t]
    return v[0] == vid or v[1] == vid or v[2] == vid


@njit(inline="always", cache=True)
def _near_segment(q0, q1, q2, p, s, tol2):
    """Whether q lies within sqrt(tol2) of the segment from p to s."""
    e0, e1, e2 = s[0] - p[0], s[1] - p[1], s[2] - p[2]
    w0, w1, w2 = q0 - p[0], q1 - p[1], q2 - p[2]
    f = min(max((w0 * e0 + w1 * e1 + w2 * e2) / (e0 * e0 + e1 * e1 + e2 * e2), 0.0), 1.0)
    return (w0 - f * e0) ** 2 + (w1 - f * e1) ** 2 + (w2 - f * e2) ** 2 <= tol2


@njit(cache=True, _nrt=False)
def owns(M, k0, k1, k, y0, y1, y2, r):
    """Whether candidate k (triangle t) of a particle counts its contact (centre y in the mesh
    frame, radius r, the particle's candidates k0..k1): unless its closest point lies on (within
    TIE r of) an edge or vertex that t shares with a triangle u of the same mesh that is nearer
    (larger overlap; at equal overlap the lower index). So a contact counts only where its
    closest point is a local minimum of the distance over the surface, once: the ordering by
    (overlap, index) is total, so of the triangles that reach one such point exactly one is not
    outranked, whatever rounding makes of the regions (face, edge or vertex) they report there.

    Not inlined and without fastmath, so that every overlap compared here is the same number
    whichever triangle's call computes it (fastmath may contract the copies differently)."""
    t = M.cand_tri[k]
    xi, m0, m1, m2, _ = triangle_contact(M, t, y0, y1, y2, r)
    if xi <= 0.0:
        return False
    q0, q1, q2 = y0 - (r - xi) * m0, y1 - (r - xi) * m1, y2 - (r - xi) * m2
    tri = M.tri[t]
    tol2 = (TIE * r) ** 2
    near_ab = _near_segment(q0, q1, q2, tri[0], tri[1], tol2)
    near_ac = _near_segment(q0, q1, q2, tri[0], tri[2], tol2)
    near_bc = _near_segment(q0, q1, q2, tri[1], tri[2], tol2)
    if not (near_ab or near_ac or near_bc):  # inside the face: nothing it shares is near
        return True
    v = M.tri_vertex[t]
    for kk in range(k0, k1):
        u = M.cand_tri[kk]
        if kk == k or M.tri_wall[u] != M.tri_wall[t]:
            continue
        sa, sb, sc = _has(M, u, v[0]), _has(M, u, v[1]), _has(M, u, v[2])
        if sa and sb and sc:  # a duplicate of t
            near = True
        elif sa and sb:  # the edge ab
            near = near_ab
        elif sa and sc:
            near = near_ac
        elif sb and sc:
            near = near_bc
        elif sa or sb or sc:  # one vertex
            j = 0 if sa else (1 if sb else 2)
            near = ((q0 - tri[j, 0]) ** 2 + (q1 - tri[j, 1]) ** 2 + (q2 - tri[j, 2]) ** 2
                    <= tol2)
        else:
            continue
        if not near:
            continue
        xu = triangle_contact(M, u, y0, y1, y2, r)[0]
        if xu > xi or (xu == xi and u < t):
            return False
    return True


@njit(cache=True)
def rebuilt_mesh_candidates(M, table, x, radius, body, margin, time):
    """Per particle, the triangles within its radius + ``margin`` at ``time`` (CSR); free
    particles only."""
    n = x.shape[0]
    start = np.zeros(n + 1, np.int64)
    stamp = np.full(M.tri.shape[0], -1, np.int64)
    out = np.empty(0, np.int64)
    lo_c = np.empty(3, np.int64)
    hi_c = np.empty(3, np.int64)
    for fill in range(2):
        if fill:
            for i in range(n):
                start[i + 1] += start[i]
            out = np.empty(start[n], np.int64)
            stamp[:] = -1
        for i in range(n):
            if body[i] >= 0:
                continue
            pos = start[i] if fill else 0
            reach = radius[i] + margin
            for iw in range(table.shape[0]):
                wall = table[iw]
                if int(wall[W_KIND]) != MESH or wall[W_ACTIVE] == 0.0:  # not an active mesh
                    continue
                y0, y1, y2 = to_frame(wall, time, x[i, 0], x[i, 1], x[i, 2])
                g = M.mesh_grid[iw]
                size = g[3]
                y = (y0, y1, y2)
                outside = False
                for a in range(3):
                    cells = int(g[4 + a])
                    lo_c[a] = int(math.floor((y[a] - reach - g[a]) / size))
                    hi_c[a] = int(math.floor((y[a] + reach - g[a]) / size))
                    if hi_c[a] < 0 or lo_c[a] >= cells:
                        outside = True
                    lo_c[a] = max(lo_c[a], 0)
                    hi_c[a] = min(hi_c[a], cells - 1)
                if outside:
                    continue
                ny, nz = int(g[5]), int(g[6])
                offset = int(g[7])
                for cx in range(lo_c[0], hi_c[0] + 1):
                    for cy in range(lo_c[1], hi_c[1] + 1):
                        for cz in range(lo_c[2], hi_c[2] + 1):
                            cell = offset + (cx * ny + cy) * nz + cz
                            for s in range(M.cell_start[cell], M.cell_start[cell + 1]):
                                t = M.cell_tri[s]
                                if stamp[t] == i:
                                    continue
                                stamp[t] = i
                                q0, q1, q2, _ = closest_on_triangle(M.tri[t], y0, y1, y2)
                                d2 = (y0 - q0) ** 2 + (y1 - q1) ** 2 + (y2 - q2) ** 2
                                if d2 < reach * reach:
                                    if fill:
                                        out[pos] = t
                                    pos += 1
            if not fill:
                start[i + 1] = pos
    return start, out


@njit(cache=True)
def mesh_overlaps(M, table, x, radius, body, time):
    """Per particle, its largest overlap with a mesh triangle (0: none), in the triangles'
    frames at ``time`` (needs current candidates)."""
    n = x.shape[0]
    out = np.zeros(n)
    for i in range(n):
        if body[i] >= 0:
            continue
        for k in range(M.cand_start[i], M.cand_start[i + 1]):
            t = M.cand_tri[k]
            y0, y1, y2 = to_frame(table[M.tri_wall[t]], time, x[i, 0], x[i, 1], x[i, 2])
            xi = triangle_contact(M, t, y0, y1, y2, radius[i])[0]
            out[i] = max(out[i], xi)
    return out


@njit(cache=True)
def open_owned_contacts(M, table, x, radius, particles, time):
    """Tag a free history slot of each of ``particles`` for every mesh contact it owns at
    ``time`` (needs current candidates), as the loop would at its next step: the same
    candidates in the same order, so the loop then finds each in its slot. Returns (particle,
    slot, overlap) of each, for a model to set its state there (progeny created reaching into a
    mesh); a contact without a free slot is left to the loop's guard."""
    tag = M.mesh_hist.shape[2] - TAG_COLUMNS
    m = particles.shape[0] * MESH_SLOTS
    who, where, overlap = np.empty(m, np.int64), np.empty(m, np.int64), np.empty(m)
    n = 0
    for i in particles:
        hist = M.mesh_hist[i]
        k0, k1 = M.cand_start[i], M.cand_start[i + 1]
        for k in range(k0, k1):
            t = M.cand_tri[k]
            iw = M.tri_wall[t]
            wall = table[iw]
            if wall[W_ACTIVE] == 0.0:
                continue
            y0, y1, y2 = to_frame(wall, time, x[i, 0], x[i, 1], x[i, 2])
            xi, m0, m1, m2, _ = triangle_contact(M, t, y0, y1, y2, radius[i])
            if xi <= 0.0 or not owns(M, k0, k1, k, y0, y1, y2, radius[i]):
                continue
            for q in range(MESH_SLOTS):
                if hist[q, tag + 3] == 0.0:
                    hist[q, tag], hist[q, tag + 1], hist[q, tag + 2] = m0, m1, m2
                    hist[q, tag + 3] = iw + 1
                    who[n], where[n], overlap[n] = i, q, xi
                    n += 1
                    break
    return who[:n], where[:n], overlap[:n]


@njit(cache=True)
def mesh_travel(W, time):
    """How far the fastest point of any active mesh has moved since its candidates were listed."""
    speed = 0.0
    for iw in range(W.table.shape[0]):
        wall = W.table[iw]
        if int(wall[W_KIND]) == MESH and wall[W_ACTIVE] != 0.0:
            speed = max(speed, abs(wall[W_OMEGA]) * wall[W_RADIUS]
                        + math.sqrt(wall[W_VX] ** 2 + wall[W_VX + 1] ** 2 + wall[W_VX + 2] ** 2))
    if speed == 0.0:
        return 0.0
    return speed * (time - W.mesh_built[0])


def with_mesh_candidates(W, P, margin, time):
    """W with the triangles near each particle listed at ``time`` (margin: the skin)."""
    start, tri = rebuilt_mesh_candidates(W, W.table, P.x, P.radius, P.body, margin, time)
    return W._replace(cand_start=start, cand_tri=tri, mesh_built=np.full(1, time))


def mesh_geometry(key, wall):
    """(vertices (V, 3) [m], faces (F, 3)) of a mesh wall's declaration: ``file`` (STL, times
    ``scale``) or ``vertices`` and ``faces``; checked as a closed solid (engine.mesh_io)."""
    from .mesh_io import checked_mesh, read_mesh

    if "file" in wall:
        if "vertices" in wall or "faces" in wall:
            raise ValueError(f"{key}: give file or vertices and faces, not both")
        return read_mesh(wall["file"], wall.get("scale", 1.0))
    if "vertices" not in wall or "faces" not in wall:
        raise ValueError(f"{key}: a mesh wall needs file (STL) or vertices and faces")
    return checked_mesh(key, wall["vertices"], wall["faces"], wall.get("scale", 1.0))


@njit(cache=True)
def signed_clearance(tri, normal, points):
    """Per point, its distance to the nearest triangle, negative inside the solid (the side of
    the nearest triangle's normal; set-up checks, brute force over the triangles)."""
    out = np.empty(points.shape[0])
    for i in range(points.shape[0]):
        y0, y1, y2 = points[i, 0], points[i, 1], points[i, 2]
        best, side = np.inf, 1.0
        for t in range(tri.shape[0]):
            q0, q1, q2, _ = closest_on_triangle(tri[t], y0, y1, y2)
            d2 = (y0 - q0) ** 2 + (y1 - q1) ** 2 + (y2 - q2) ** 2
            if d2 < best:
                best = d2
                side = (y0 - q0) * normal[t, 0] + (y1 - q1) * normal[t, 1] + (y2 - q2) * normal[t, 2]
        out[i] = math.sqrt(best) if side >= 0.0 else -math.sqrt(best)
    return out
