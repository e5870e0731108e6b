"""Triangle-mesh walls from STL files: reading, checking, writing, and generated meshes.

The contact kernel (engine.mesh) treats each triangle as one-sided and counts a shared edge or
vertex once, which is only right for the surface of a closed solid with consistent winding; a
hole lets particles leak out, a flipped face pushes them into the solid. So every mesh that
reaches the engine passes through :func:`checked_mesh`, which refuses such a mesh with a
one-line ``ValueError`` that names the file (or wall) and the fault, instead of letting it run.

Convention: a mesh wall is a closed solid; its face normals (right-hand winding of the three
vertices) point out of the solid, into the particles' domain. A drum is a solid shell (a liner
with a thickness), whose inner surface's normals point towards the axis.

STL is read and written with trimesh; reading merges the duplicated vertices of STL's separate
triangles so that edges are shared (the topology the checks and the contact kernel need).
"""

import math
import os
import tempfile
from pathlib import Path

import numpy as np
import trimesh

DEGENERATE_AREA = 1e-12  # times the bounding-box diagonal squared: a zero-area triangle


def checked_mesh(label, vertices, faces, scale=1.0):
    """(vertices (V, 3) float64 times ``scale``, faces (F, 3) int64) of a closed solid with
    outward normals, duplicate vertices merged; ``ValueError("label: fault")`` otherwise."""

    def refuse(fault):
        raise ValueError(f"{label}: {fault}")

    try:
        ok = math.isfinite(scale) and scale > 0
    except TypeError:
        ok = False
    if not ok:
        refuse(f"scale must be a finite number > 0, got {scale!r}")
    try:
        vertices, faces = np.asarray(vertices, dtype=np.float64), np.asarray(faces)
    except (TypeError, ValueError) as e:
        refuse(f"vertices and faces must be numeric arrays ({e})")
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        refuse(f"vertices must be an array (V, 3), got shape {vertices.shape}")
    if faces.size == 0:
        refuse("no triangles")
    if faces.ndim != 2 or faces.shape[1] != 3 or not np.issubdtype(faces.dtype, np.integer):
        refuse(f"faces must be an integer array (F, 3), got {faces.dtype} {faces.shape}")
    if faces.min() < 0 or faces.max() >= len(vertices):
        refuse(f"faces refer to vertices outside 0..{len(vertices) - 1}")
    bad = np.flatnonzero(~np.isfinite(vertices[faces]).all(axis=(1, 2)))
    if len(bad):
        refuse(f"non-finite vertex coordinates in {len(bad)} triangles, the first is {bad[0]}")

    # process=True merges coincident vertices (STL repeats them per triangle); on finite
    # coordinates it neither drops nor reorders faces, so face indices still match the input.
    mesh = trimesh.Trimesh(vertices, faces.astype(np.int64), process=True)
    v, f = np.ascontiguousarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    tri = v[f]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    diagonal2 = float(np.sum((v.max(axis=0) - v.min(axis=0)) ** 2))
    bad = np.flatnonzero(area <= DEGENERATE_AREA * diagonal2)
    if len(bad):
        refuse(f"{len(bad)} zero-area (degenerate) triangles, the first is {bad[0]}")

    _, uses = np.unique(np.sort(f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0,
                        return_counts=True)
    if (uses == 1).any():
        refuse(f"open mesh: {int((uses == 1).sum())} boundary edges (edges of only one "
               "triangle); particles would leak through, a mesh wall must be a closed solid")
    if (uses > 2).any():
        refuse(f"{int((uses > 2).sum())} edges shared by more than two triangles: not the "
               "surface of one solid")
    if not mesh.is_winding_consistent:
        refuse("inconsistent winding: some triangles are flipped against their neighbours")
    # signed volume (divergence theorem) about the centroid of the vertices, to limit rounding
    c = tri - v.mean(axis=0)
    volume = np.einsum("ij,ij->i", c[:, 0], np.cross(c[:, 1], c[:, 2])).sum() / 6.0
    if volume < 0:
        refuse("inverted: signed volume < 0, normals point into the solid; flip the winding")
    if volume == 0:
        refuse("encloses no volume")
    return np.ascontiguousarray(v * scale), np.ascontiguousarray(f)


def first_hits(vertices, faces, origins, directions):
    """Per ray (origins and unit directions, (R, 3)): the distance to the first triangle it
    crosses (inf: none) and whether it leaves the solid there (the origin lies inside it).
    Moller-Trumbore, brute force over the triangles: a set-up check of where a mesh lies."""
    tri = np.asarray(vertices, np.float64)[np.asarray(faces)]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    normal = np.cross(e1, e2)
    dist, leaving = np.full(len(origins), np.inf), np.zeros(len(origins), bool)
    for k, (o, d) in enumerate(zip(np.asarray(origins, np.float64),
                                   np.asarray(directions, np.float64))):
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            s = o - tri[:, 0]
            u = np.einsum("ij,ij->i", s, p) * inv
            q = np.cross(s, e1)
            v = (q @ d) * inv
            t = np.einsum("ij,ij->i", e2, q) * inv
            hit = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
        if hit.any():
            j = np.flatnonzero(hit)[np.argmin(t[hit])]
            dist[k], leaving[k] = t[j], normal[j] @ d > 0  # outward normal along the ray
    return dist, leaving


def _stl_layout(path):
    """Whether the file is laid out as binary STL (84-byte header + 50 bytes per triangle) or
    starts as ASCII STL: trimesh returns an empty mesh, not an error, for garbage."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(84)
    if size >= 84 and size == 84 + 50 * int.from_bytes(head[80:84], "little"):
        return True
    return head.lstrip().lower().startswith(b"solid")


def read_mesh(path, scale=1.0):
    """(vertices (V, 3) float64 [file units x scale], faces (F, 3) int64) of the closed solid in
    the STL file (ASCII or binary) at ``path``; CAD in mm: scale=1e-3. Refused with a one-line
    ``ValueError`` starting with the path for anything :func:`checked_mesh` refuses."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    try:
        # process=False: processing drops NaN vertices silently, and checked_mesh must see them
        mesh = trimesh.load(path, file_type="stl", force="mesh", process=False)
    except Exception as e:  # trimesh raises many kinds on a malformed file
        reason = " ".join(str(e).split())[:200]
        raise ValueError(f"{path}: not readable as STL ({type(e).__name__}: {reason})") from None
    if len(mesh.faces) == 0 and not _stl_layout(path):
        raise ValueError(f"{path}: not readable as STL (neither binary STL's length nor "
                         "ASCII STL's 'solid' start)")
    return checked_mesh(str(path), mesh.vertices, mesh.faces, scale)


def write_stl(path, vertices, faces, ascii=False):
    """Write the triangles to an STL file (binary: float32 coordinates; ASCII: full precision),
    through a temporary file in the same directory renamed over ``path``: no partial file."""
    path = Path(path)
    mesh = trimesh.Trimesh(np.asarray(vertices, np.float64), np.asarray(faces, np.int64),
                           process=False)
    data = mesh.export(file_type="stl_ascii" if ascii else "stl")
    if isinstance(data, str):
        data = data.encode("ascii")
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o644)  # mkstemp's 0600 would make the file private
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def box_mesh(lo, hi):
    """(vertices (8, 3), faces (12, 3)) of the closed box [lo, hi] with outward normals."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    if not (lo < hi).all():
        raise ValueError(f"box_mesh: need lo < hi on every axis, got {lo} and {hi}")
    # vertex k has x from bit 0, y from bit 1, z from bit 2 of k (0: lo, 1: hi)
    bits = (np.arange(8)[:, None] >> np.arange(3)) & 1
    vertices = np.where(bits == 1, hi, lo)
    quads = [(0, 2, 3, 1), (4, 5, 7, 6),  # z = lo, z = hi
             (0, 1, 5, 4), (2, 6, 7, 3),  # y = lo, y = hi
             (0, 4, 6, 2), (1, 3, 7, 5)]  # x = lo, x = hi; counter-clockwise seen from outside
    faces = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    return vertices, np.array(faces, np.int64)


def liner_mesh(radius, length, *, segments=64, thickness=None, lifters=0, lifter_height=0.0,
               lifter_width=0.0, center=(0.0, 0.0, 0.0)):
    """(vertices, faces) of a ball-mill liner as one closed solid, axis along z from z=0 to
    ``length`` (then shifted by ``center``): a shell between an inner polygon of ``segments``
    sides with its vertices on the circle of ``radius`` and an outer one on radius + thickness
    (default 0.1 radius), closed by annular end faces, with ``lifters`` rectangular bars
    (``lifter_height`` radially inward: the top face at radius - lifter_height from the axis;
    ``lifter_width`` wide, parallel sides) equally spaced from angle 0 (+x) and running the full
    length. The inner surface's normals point towards the axis.

    Where a lifter stands, the circle's vertices under it (and those within a tenth of a segment
    of its edges, which would leave slivers) are replaced by the two points where its sides meet
    the circle."""
    R, L, N = float(radius), float(length), int(segments)
    T = 0.1 * R if thickness is None else float(thickness)
    if not (R > 0 and L > 0 and T > 0 and N >= 8):
        raise ValueError(f"liner_mesh: need radius, length, thickness > 0 and segments >= 8, "
                         f"got {radius}, {length}, {thickness}, {segments}")
    Ro = R + T
    step = 2 * math.pi / N
    circle = np.arange(N) * step
    angle, tag = [], []  # points on the inner circle; tag: -1 arc, 2 j lifter j's start, 2 j + 1 end
    if lifters:
        h, w = float(lifter_height), float(lifter_width)
        base = math.asin(w / (2 * R)) if 0 < w < 2 * R else math.nan
        top = math.atan2(w / 2, R - h)
        if not (0 < h < R and 0 < w < 2 * R and R - h < R * math.cos(base)
                and 2 * max(base, top) < 2 * math.pi / lifters):
            raise ValueError(f"liner_mesh: {lifters} lifters {lifter_height} high and "
                             f"{lifter_width} wide do not fit inside radius {radius}, apart")
        phi = 2 * math.pi * np.arange(lifters) / lifters
        off = np.abs((circle[:, None] - phi + math.pi) % (2 * math.pi) - math.pi)
        circle = circle[(off >= base + 0.1 * step).all(axis=1)]
        angle = list(np.concatenate([phi - base, phi + base]))
        tag = list(np.concatenate([2 * np.arange(lifters), 2 * np.arange(lifters) + 1]))
    angle = np.concatenate([circle, angle]) % (2 * math.pi)
    tag = np.concatenate([np.full(len(circle), -1), np.asarray(tag, int)])
    order = np.argsort(angle)
    angle, tag = angle[order], tag[order]

    # inner profile (counter-clockwise seen from +z): the circle's points, and after each
    # lifter's start its two top corners; ring[k] is the profile index of circle point k
    profile, ring = [], []
    for a, k in zip(angle, tag):
        ring.append(len(profile))
        profile.append((R * math.cos(a), R * math.sin(a)))
        if k >= 0 and k % 2 == 0:
            p = 2 * math.pi * (k // 2) / lifters
            u, t = np.array([math.cos(p), math.sin(p)]), np.array([-math.sin(p), math.cos(p)])
            profile += [tuple((R - h) * u - w / 2 * t), tuple((R - h) * u + w / 2 * t)]
    profile = np.array(profile)
    n = len(profile)
    outer_angle = np.arange(N) * step
    outer = Ro * np.column_stack([np.cos(outer_angle), np.sin(outer_angle)])

    # vertices: profile at z=0, z=L, outer at z=0, z=L
    xy = np.vstack([profile, profile, outer, outer])
    z = np.repeat([0.0, L, 0.0, L], [n, n, N, N])
    vertices = np.column_stack([xy, z]) + np.asarray(center, np.float64)
    i0, o0 = np.arange(n), 2 * n + np.arange(N)
    i1, o1 = np.roll(i0, -1), np.roll(o0, -1)
    # sides: the inner quads face the axis, the outer ones away from it
    sides = [np.column_stack(c) for c in ((i0, i1 + n, i1), (i0, i0 + n, i1 + n),
                                          (o0, o1, o1 + N), (o0, o1 + N, o0 + N))]
    # top end (z = L), counter-clockwise seen from +z: the annulus between the inner circle's
    # points and the outer polygon zipped by angle (both are convex and angle-sorted, so
    # triangles between neighbours in angle do not cross), and each lifter's quad
    cap = []
    ring = np.array(ring)
    a_in = np.append(angle, angle[0] + 2 * math.pi)
    a_out = np.append(outer_angle, 2 * math.pi)
    i = j = 0
    while i < len(ring) or j < N:
        if j == N or (i < len(ring) and a_in[i + 1] <= a_out[j + 1]):
            cap.append((ring[i], 2 * n + j % N, ring[(i + 1) % len(ring)]))
            i += 1
        else:
            cap.append((ring[i % len(ring)], 2 * n + j, 2 * n + (j + 1) % N))
            j += 1
    for k, r in zip(tag, ring):
        if k >= 0 and k % 2 == 0:  # start, top corners, end of the lifter
            cap += [(r, (r + 3) % n, r + 2), (r, r + 2, r + 1)]
    cap = np.array(cap)
    e1, e2 = xy[cap[:, 1]] - xy[cap[:, 0]], xy[cap[:, 2]] - xy[cap[:, 0]]
    signed = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    if (signed <= 0).any():  # a fold: the shell too thin for the polygons
        raise ValueError(f"liner_mesh: the end faces fold (thickness {T} too small for "
                         f"{segments} segments?)")
    top_cap = np.where(cap < 2 * n, cap + n, cap + N)
    bottom_cap = cap[:, ::-1]
    faces = np.vstack(sides + [top_cap, bottom_cap]).astype(np.int64)
    return np.ascontiguousarray(vertices), faces
