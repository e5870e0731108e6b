"""Mesh walls from STL (engine.mesh_io): refusals, round trips, generated meshes.

- Each fault is refused with one line naming the file and the fault: a missing file, garbage, a
  NaN vertex, a zero-area triangle, an open mesh, an inverted box, one flipped triangle, scale 0.
- ASCII and binary STL of one box read back to the same triangles; scale multiplies coordinates.
- Rays meet a box first where its planes say, through a face, an edge or a vertex (every vertex
  lies on triangles' boundaries only), leaving it from inside and entering from outside.
- The liner (with and without lifters) read back is a closed solid whose volume is the area
  between its profile polygons (shoelace, built here from radius and segments) times its
  length, with inner normals towards the axis and end faces without folds.
"""

import math
from pathlib import Path

import numpy as np
import pytest

from millsim.engine.mesh_io import box_mesh, first_hits, liner_mesh, read_mesh, write_stl

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "meshes" / "ballmill_liner.stl"


def write_binary_stl(path, triangles):
    """Binary STL of (F, 3, 3) triangles written here, independent of trimesh (NaN allowed)."""
    rec = np.zeros(len(triangles), [("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    rec["v"] = triangles
    with open(path, "wb") as fh:
        fh.write(b"\0" * 80 + np.uint32(len(triangles)).tobytes() + rec.tobytes())


def refused(path, fault, **kw):
    with pytest.raises(ValueError) as err:
        read_mesh(path, **kw)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(str(path)) and fault in msg, msg
    return msg


def shoelace(xy):
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)


def signed_volume(v, f):
    t = v[f]
    return np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() / 6.0


def normals(v, f):
    t = v[f]
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    return n / np.linalg.norm(n, axis=1)[:, None]


def test_missing_file(tmp_path):
    refused(tmp_path / "none.stl", "no such file")


def test_garbage(tmp_path):
    path = tmp_path / "garbage.stl"
    path.write_bytes(np.random.default_rng(1).bytes(333))
    refused(path, "not readable as STL")


def test_empty_stl(tmp_path):
    path = tmp_path / "empty.stl"
    path.write_text("solid empty\nendsolid empty\n")
    refused(path, "no triangles")


def test_nan_vertex(tmp_path):
    v, f = box_mesh((0, 0, 0), (1, 1, 1))
    tri = v[f]
    tri[3, 1, 0] = np.nan
    path = tmp_path / "nan.stl"
    write_binary_stl(path, tri)
    refused(path, "non-finite vertex coordinates in 1 triangles, the first is 3")


def test_zero_area_triangle(tmp_path):
    # a closed, consistently wound box in which triangle (a, b, c) became (a, m, c), (m, b, c)
    # and a sliver (a, b, m) through the midpoint m of edge ab: a T-junction repaired badly
    v, f = box_mesh((0, 0, 0), (1, 1, 1))
    a, b, c = f[0]
    v = np.vstack([v, 0.5 * (v[a] + v[b])])
    m = len(v) - 1
    f = np.vstack([[(a, m, c), (m, b, c)], f[1:], [(a, b, m)]])
    path = tmp_path / "sliver.stl"
    write_stl(path, v, f, ascii=True)
    refused(path, "1 zero-area (degenerate) triangles, the first is 13")


def test_open_mesh(tmp_path):
    v, f = box_mesh((0, 0, 0), (1, 1, 1))
    path = tmp_path / "open.stl"
    write_stl(path, v, f[1:])
    msg = refused(path, "open mesh: 3 boundary edges")
    assert "leak" in msg


def test_inverted_box(tmp_path):
    v, f = box_mesh((0, 0, 0), (1, 1, 1))
    path = tmp_path / "inverted.stl"
    write_stl(path, v, f[:, ::-1])
    refused(path, "normals point into the solid; flip the winding")


def test_one_flipped_triangle(tmp_path):
    v, f = box_mesh((0, 0, 0), (1, 1, 1))
    f[5] = f[5, ::-1]
    path = tmp_path / "flipped.stl"
    write_stl(path, v, f)
    refused(path, "inconsistent winding")


@pytest.mark.parametrize("scale", [0.0, -1.0, math.nan, math.inf])
def test_bad_scale(tmp_path, scale):
    path = tmp_path / "box.stl"
    write_stl(path, *box_mesh((0, 0, 0), (1, 1, 1)))
    refused(path, "scale must be a finite number > 0", scale=scale)


def test_box_is_closed_outward():
    v, f = box_mesh((-1, -2, -3), (1, 2, 3))
    assert len(f) == 12 and signed_volume(v, f) == pytest.approx(48.0, rel=1e-15)
    # each face's normal points from the box's centre to the face's centroid
    assert (np.einsum("ij,ij->i", normals(v, f), v[f].mean(axis=1)) > 0).all()


def test_rays_meet_a_box_where_its_planes_say_through_faces_edges_and_vertices():
    """Box [0, 2]^3, rays from its centre to every vertex (distance sqrt(3)), to the middle of
    every edge (sqrt(2)) and of every face (1), each on triangles' edges only, all leaving the
    solid; rays from outside entering it (the first of the two faces they cross); one passing
    by. Distances by the planes of the box, here."""
    vertices, faces = box_mesh((0, 0, 0), (2, 2, 2))
    centre = np.ones(3)
    corners = np.array([[x, y, z] for x in (0, 2) for y in (0, 2) for z in (0, 2)], float)
    edges = np.unique([(a + b) / 2 for a in corners for b in corners
                       if np.abs(a - b).sum() == 2], axis=0)
    face_centres = np.array([centre + s * e for e in np.eye(3) for s in (-1, 1)])
    targets = np.vstack([corners, edges, face_centres])
    assert len(edges) == 12
    d = targets - centre
    dist, leaving = first_hits(vertices, faces, np.tile(centre, (len(d), 1)),
                               d / np.linalg.norm(d, axis=1)[:, None])
    expected = np.repeat([math.sqrt(3), math.sqrt(2), 1.0], [8, 12, 6])
    np.testing.assert_allclose(dist, expected, rtol=1e-12)
    assert leaving.all()
    origins = np.array([[1.0, 1.0, -3.0], [5.0, 0.5, 1.5], [1.0, 1.0, 5.0]])
    directions = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    dist, leaving = first_hits(vertices, faces, origins, directions)
    np.testing.assert_allclose(dist[:2], [3.0, 3.0], rtol=1e-12)
    assert dist[2] == math.inf and not leaving.any()


def test_ascii_and_binary_read_back_the_same(tmp_path):
    v, f = box_mesh((-0.5, 0.25, 1.0), (1.5, 0.75, 3.0))  # exact in float32
    want = sorted(map(sorted, v[f].tolist()))  # each triangle's vertex set, sorted
    for ascii in (True, False):
        path = tmp_path / f"box_{ascii}.stl"
        write_stl(path, v, f, ascii=ascii)
        rv, rf = read_mesh(path)
        assert rv.dtype == np.float64 and rv.flags.c_contiguous and rf.dtype == np.int64
        assert len(rv) == 8  # duplicates merged
        assert sorted(map(sorted, rv[rf].tolist())) == want
    assert not list(tmp_path.glob(".*.tmp"))  # no temporary file left behind


def test_scale_scales_the_bounding_box(tmp_path):
    path = tmp_path / "mm.stl"
    write_stl(path, *box_mesh((0, -10, 5), (20, 10, 45)))
    v, _ = read_mesh(path, scale=1e-3)
    np.testing.assert_allclose(v.min(axis=0), [0, -0.01, 0.005], rtol=1e-15)
    np.testing.assert_allclose(v.max(axis=0), [0.02, 0.01, 0.045], rtol=1e-15)


R, LENGTH, N, THICK = 0.1, 0.05, 96, 0.01


def test_plain_liner_volume_and_normals(tmp_path):
    v, f = liner_mesh(R, LENGTH, segments=N, thickness=THICK, center=(0.0, 0.0, 0.0))
    path = tmp_path / "liner.stl"
    write_stl(path, v, f, ascii=True)  # full precision
    rv, rf = read_mesh(path)
    assert len(rf) == 8 * N  # 2 per segment: inner, outer, both ends
    shell = 0.5 * N * math.sin(2 * math.pi / N) * ((R + THICK) ** 2 - R**2)
    assert signed_volume(rv, rf) == pytest.approx(shell * LENGTH, rel=1e-9)
    centroid = rv[rf].mean(axis=1)
    r = np.hypot(centroid[:, 0], centroid[:, 1])
    inner = r < R + 0.5 * THICK
    inner &= (centroid[:, 2] > 0) & (centroid[:, 2] < LENGTH)  # not the ends
    assert inner.sum() == 2 * N
    r_hat = np.column_stack([centroid[:, :2] / r[:, None], np.zeros(len(r))])
    assert (np.einsum("ij,ij->i", normals(rv, rf)[inner], -r_hat[inner]) > 0.99).all()


def test_liner_with_lifters(tmp_path):
    # lifters 8, as wide as two segments: their sides meet the circle at its vertices, so the
    # profile is the polygon with each lifter's centre vertex replaced by its two top corners
    lifters, h, k = 8, 0.01, N // 8
    w = 2 * R * math.sin(2 * math.pi / N)
    v, f = liner_mesh(R, LENGTH, segments=N, thickness=THICK, lifters=lifters,
                      lifter_height=h, lifter_width=w, center=(1.0, -2.0, 0.5))
    path = tmp_path / "lifters.stl"
    write_stl(path, v, f, ascii=True)
    rv, rf = read_mesh(path)
    profile = []
    for i in range(N):
        a = 2 * math.pi * i / N
        if i % k:
            profile.append((R * math.cos(a), R * math.sin(a)))
        else:  # top corners of the lifter centred at a: radius R - h, -w/2 then +w/2
            u, t = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
            profile += [(R - h) * u - w / 2 * t, (R - h) * u + w / 2 * t]
    outer = 0.5 * N * math.sin(2 * math.pi / N) * (R + THICK) ** 2
    assert signed_volume(rv - (1.0, -2.0, 0.5), rf) == pytest.approx(
        (outer - shoelace(np.array(profile))) * LENGTH, rel=1e-9)
    # the end faces: every triangle faces out of its end (no fold), areas sum to the section
    n, z = normals(rv, rf), rv[rf][:, :, 2]
    for end, sign in ((0.5, -1.0), (0.5 + LENGTH, 1.0)):
        on = (np.abs(z - end) < 1e-12).all(axis=1)
        assert (n[on, 2] * sign > 1 - 1e-12).all()
    # the faces on the inner circle and the lifter tops (all three vertices there) face the axis
    c = rv[rf] - (1.0, -2.0, 0.5)
    rv_tri = np.hypot(c[:, :, 0], c[:, :, 1])
    centroid = c.mean(axis=1)
    r_hat = centroid[:, :2] / np.hypot(centroid[:, 0], centroid[:, 1])[:, None]
    facing = -np.einsum("ij,ij->i", n[:, :2], r_hat)
    circle = (np.abs(rv_tri - R) < 1e-12).all(axis=1)
    tops = (np.abs(rv_tri - math.hypot(R - h, w / 2)) < 1e-12).all(axis=1)
    assert circle.sum() == 2 * (N - 2 * lifters) and tops.sum() == 2 * lifters
    assert (facing[circle] > 0.99).all() and (facing[tops] > 0.99).all()


def test_example_liner():
    v, f = read_mesh(EXAMPLE)  # binary STL, float32: closed, consistent and outward as stored
    assert 1000 <= len(f) <= 3000
    r = np.hypot(v[:, 0], v[:, 2])  # axis along y (the packing scene's drum)
    assert r.min() == pytest.approx(math.hypot(0.09, 0.005), rel=1e-6)  # lifter top corners
    assert r.max() == pytest.approx(0.11, rel=1e-6)
    np.testing.assert_allclose([v[:, 1].min(), v[:, 1].max()], [0.0, 0.05], atol=1e-9)


def test_liner_refuses_lifters_that_do_not_fit():
    with pytest.raises(ValueError, match="do not fit"):
        liner_mesh(R, LENGTH, lifters=8, lifter_height=0.01, lifter_width=0.1)
    with pytest.raises(ValueError, match="do not fit"):
        liner_mesh(R, LENGTH, lifters=8, lifter_height=R, lifter_width=0.01)


@pytest.mark.parametrize("kw", [dict(radius=0.0, thickness=0.01), dict(radius=-R),
                                dict(length=0.0), dict(thickness=0.0), dict(segments=7)])
def test_liner_refuses_a_degenerate_shell(kw):
    with pytest.raises(ValueError, match="^liner_mesh: need radius, length, thickness > 0 and "
                                         "segments >= 8"):
        liner_mesh(**dict(dict(radius=R, length=LENGTH), **kw))
