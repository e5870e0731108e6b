"""Snapshots as ParaView reads them: the XDMF sidecar parsed back with the HDF5 it points at.

- Walls: one temporal grid beside the particles', a frame each. A drum shell's vertices lie at its
  radius; a turning mesh's vertices at frame k are those of frame 0 turned by omega (t_k - t_0)
  (closed form); a 2D run's walls are segments in the z = 0 plane.
- Contacts: a resting stack of three spheres on a floor: each pair's normal force is the weight
  it carries (m g, 2 m g) and the law's force of the overlap written (k_n overlap), the
  tangential force vanishes, the contact point sits mid-overlap. Writing them does not change
  the run. (The linear law and spec of tests/test_mesh_walls.py: the same compiled loop.)
- Units: every dataset carries the netCDF files' CF units (m s-1, rad s-1, N).
- A disk that fills: the run is refused up front where the frames are counted (the estimate
  names the parameters), else the snapshots stop with a warning and are removed, the case is
  written, exit code 2, one line naming the file; never a crash. tmpfs mounts need root.
"""

import math
import os
import subprocess
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest
from test_conventions import BALLMILL

from millsim.cli import main
from millsim.engine import PhysicsSpec, Simulation, StepPolicy
from millsim.engine.mesh_io import box_mesh
from millsim.engine.wall_geometry import pair_contact_forces
from millsim.io import SNAPSHOT_UNITS, SnapshotWriter
from millsim.models import Interaction, Material, MaterialTable
from millsim.scenes import base
from millsim.scenes.base import RunContext

from helpers import clipped_damping_ratio

R = 1e-3
RHO = 2500.0
K_N = 2e3
MASS = RHO * 4.0 / 3.0 * math.pi * R**3
G = 9.81
DRUM = 5 * R  # the shell's radius
OMEGA = 20.0  # the mesh paddle's rate [rad/s]
PADDLE = (1.5 * R, -0.5 * R, 12 * R), (3.5 * R, 0.5 * R, 13 * R)  # its box at t = 0 (axis z)


def _stack_sim(mesh=True):
    """Three spheres resting on each other on a floor, inside a drum shell (axis z), with a
    paddle (a mesh box) turning about the axis above them."""
    walls = [dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="m"),
             dict(kind="cylinder_inner", point=(0, 0, 0), axis=(0, 0, 1), radius=DRUM,
                  material="m")]
    if mesh:
        vertices, faces = box_mesh(*PADDLE)
        walls.append(dict(kind="mesh", vertices=vertices, faces=faces, point=(0, 0, 0),
                          axis=(0, 0, 1), omega=OMEGA, material="m"))
    table = MaterialTable([Material("m", RHO)], {"*": Interaction(
        restitution=0.2, friction=0.5, normal_stiffness=K_N)}, "linear_history")
    x = [[0.0, 0.0, R], [0.0, 0.0, 3 * R], [0.0, 0.0, 5 * R]]
    return Simulation(PhysicsSpec(dim=3, walls=True, mesh_walls=mesh), table, x=x,
                      radius=[R] * 3, material="m", walls=walls, gravity=(0, 0, -G),
                      skin=0.2 * R, step=StepPolicy(impact_speed=0.5))


def _grids(xdmf):
    """{collection name: [(time, uniform grid element)]} of an XDMF file."""
    root = ET.parse(xdmf).getroot()
    assert root.tag == "Xdmf"
    return {series.get("Name"): [(float(g.find("Time").get("Value")), g)
                                 for g in series.findall("Grid")]
            for series in root.findall("Domain/Grid")
            if series.get("CollectionType") == "Temporal"}


def _read(h5, item):
    """The array an XDMF DataItem points at (file:path), checked against its Dimensions."""
    name, path = item.text.strip().split(":")
    assert name == h5.filename.rsplit("/", 1)[-1]
    data = h5[path][()]
    assert data.shape == tuple(int(d) for d in item.get("Dimensions").split())
    return data


def _cell_grid(h5, grid):
    """points, cells and {attribute: per-cell values} of one uniform grid."""
    topology = grid.find("Topology")
    cells = _read(h5, topology.find("DataItem"))
    assert int(topology.get("NumberOfElements")) == len(cells)
    points = _read(h5, grid.find("Geometry/DataItem"))
    attributes = {}
    for a in grid.findall("Attribute"):
        assert a.get("Center") == "Cell"
        attributes[a.get("Name")] = _read(h5, a.find("DataItem"))
        assert len(attributes[a.get("Name")]) == len(cells)
    return topology.get("TopologyType"), points, cells, attributes


@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    """The settled stack, snapshotted at three times with walls and contacts."""
    path = tmp_path_factory.mktemp("stack") / "snap.h5"
    sim = _stack_sim()
    sim.run(int(0.03 / sim.dt))  # settled: the damping has taken the bounce out
    ctx = RunContext(snapshots=SnapshotWriter(path, dim=3), snapshot_contacts=True)
    times = []
    for _ in range(3):
        ctx.snapshot(sim)
        times.append(sim.time)
        sim.run(int(0.002 / sim.dt))  # the paddle turns by 0.04 rad between frames
    ctx.snapshots.close()
    return path, sim, times


def test_walls_and_contacts_are_time_series_beside_the_particles(stack):
    path, _, times = stack
    grids = _grids(path.with_suffix(".xdmf"))
    assert set(grids) == {"particles", "walls", "contacts"}
    for name, frames in grids.items():
        assert [t for t, _ in frames] == times, name
    with h5py.File(path) as h5:
        for _, grid in grids["walls"]:
            kind, points, cells, attributes = _cell_grid(h5, grid)
            assert kind == "Triangle" and cells.shape[1] == 3
            assert set(attributes) == {"wall", "kind"}
            assert set(np.unique(attributes["wall"])) == {0, 1, 2}


def test_the_drum_shell_lies_at_its_radius_and_the_floor_closes_it(stack):
    path, _, _ = stack
    with h5py.File(path) as h5:
        _, points, cells, attributes = _cell_grid(h5, _grids(path.with_suffix(".xdmf"))
                                                  ["walls"][0][1])
    shell = points[np.unique(cells[attributes["wall"] == 1])]
    np.testing.assert_allclose(np.hypot(shell[:, 0], shell[:, 1]), DRUM, rtol=1e-12)
    # from the floor (the plane across its axis) up past the paddle, the highest thing drawn
    assert shell[:, 2].min() == 0.0 and shell[:, 2].max() > 13 * R
    floor = points[np.unique(cells[attributes["wall"] == 0])]
    assert not floor[:, 2].any() and np.hypot(floor[:, 0], floor[:, 1]).max() == \
        pytest.approx(DRUM, rel=1e-12)


def test_a_turning_mesh_is_written_at_its_angle_of_each_frame(stack):
    path, _, times = stack
    with h5py.File(path) as h5:
        frames = [_cell_grid(h5, grid) for _, grid in _grids(path.with_suffix(".xdmf"))["walls"]]
    box = box_mesh(*PADDLE)[0]  # its vertices at t = 0, in the drawing's order
    for t, (_, points, cells, attributes) in zip(times, frames):
        paddle = points[np.unique(cells[attributes["wall"] == 2])]
        assert len(paddle) == 8
        a = OMEGA * t
        turned = np.column_stack([box[:, 0] * math.cos(a) - box[:, 1] * math.sin(a),
                                  box[:, 0] * math.sin(a) + box[:, 1] * math.cos(a), box[:, 2]])
        assert a > 0.5  # 0.6 rad at the first frame, 0.04 rad more at each
        np.testing.assert_allclose(paddle, turned, atol=1e-12)


def test_contact_forces_carry_the_weight_above_and_follow_the_law(stack):
    path, _, _ = stack
    with h5py.File(path) as h5:
        for _, grid in _grids(path.with_suffix(".xdmf"))["contacts"]:
            kind, points, cells, c = _cell_grid(h5, grid)
            assert kind == "Polyline" and cells.shape == (2, 2)
            for q in range(2):
                above = 3 - max(c["i"][q], c["j"][q])  # spheres resting on the pair's upper one
                fn = c["normal_force"][q]
                # on i from j; i below j here (the list keeps i < j): pushed down
                assert c["i"][q] < c["j"][q] and fn[2] < 0
                np.testing.assert_allclose(-fn[2], above * MASS * G, rtol=1e-4)
                np.testing.assert_allclose(fn[:2], 0.0, atol=1e-12)
                np.testing.assert_allclose(-fn[2], K_N * c["overlap"][q], rtol=1e-4)
                np.testing.assert_allclose(c["tangential_force"][q], 0.0, atol=1e-9 * MASS * G)
                np.testing.assert_allclose(c["force"][q], fn + c["tangential_force"][q])
                # the segment joins the two centres; the contact point sits mid-overlap
                lower, upper = points[cells[q]]
                assert upper[2] - lower[2] == pytest.approx(2 * R - c["overlap"][q], rel=1e-9)
                assert c["contact_point"][q][2] == pytest.approx(
                    lower[2] + R - c["overlap"][q] / 2, rel=1e-9) or \
                    c["contact_point"][q][2] == pytest.approx(upper[2] - R + c["overlap"][q] / 2,
                                                              rel=1e-9)


def test_contact_forces_of_a_moving_spinning_pair_are_the_linear_law():
    """An oblique pair of unequal spheres (radii 1 and 2 mm) overlapping by 1e-5 m, moving and
    spinning, its tangential spring fresh: the snapshot's contact forces against the linear law
    written here (docs/models.md): F_n = k_n delta - 2 zeta sqrt(m_eff k_n) v_n, F_t =
    -2 zeta sqrt(m_eff k_t) v_t (k_t = 2/7 k_n, friction 10: no slip), with the relative velocity
    at the contact point v_i - v_j - (a_i w_i + a_j w_j) x n, a = r - delta/2, n from j to i."""
    e, k_n, delta = 0.5, 1e4, 1e-5
    table = MaterialTable([Material("m", RHO)],
                          {"*": Interaction(normal_stiffness=k_n, restitution=e, friction=10.0)},
                          "linear_history")
    radius = np.array([1e-3, 2e-3])
    n = np.array([1.0, 2.0, 2.0]) / 3.0
    x = np.array([n * (radius.sum() - delta), [0.0, 0.0, 0.0]])
    v = np.array([[-0.01, -0.02, 0.005], [0.01, 0.003, 0.0]])
    w = np.array([[1.0, 2.0, -3.0], [0.0, -1.0, 2.0]])
    sim = Simulation(PhysicsSpec(gravity=False), table, x=x, radius=radius, material="m", v=v,
                     w=w)
    c = pair_contact_forces(sim)
    assert len(c["i"]) == 1
    i = int(c["i"][0])
    assert {i, int(c["j"][0])} == {0, 1}
    sign = 1.0 if i == 0 else -1.0  # n points from j to i
    m = RHO * 4 / 3 * math.pi * radius**3
    m_eff = m[0] * m[1] / m.sum()
    a = radius - delta / 2
    vrel = sign * (v[0] - v[1] - np.cross(a[0] * w[0] + a[1] * w[1], n))
    v_n = vrel @ (sign * n)
    v_t = vrel - v_n * sign * n
    zeta = clipped_damping_ratio(e)
    f_n = k_n * delta - 2 * zeta * math.sqrt(m_eff * k_n) * v_n
    assert v_n < 0 < f_n  # approaching
    np.testing.assert_allclose(c["overlap"], [delta], rtol=1e-9)
    np.testing.assert_allclose(c["normal_force"][0], f_n * sign * n, rtol=1e-9)
    np.testing.assert_allclose(c["tangential_force"][0],
                               -2 * zeta * math.sqrt(m_eff * k_n * 2 / 7) * v_t, rtol=1e-9)
    np.testing.assert_allclose(c["contact_point"][0], x[i] - a[i] * sign * n, rtol=1e-9,
                               atol=1e-15)


def test_every_dataset_has_cf_units(stack):
    path, _, _ = stack
    seen = {}
    with h5py.File(path) as h5:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                seen[name.rsplit("/", 1)[-1]] = obj.attrs.get("units")
        h5.visititems(visit)
    assert seen == {name: SNAPSHOT_UNITS[name] for name in seen}
    assert seen["velocity"] == "m s-1" and seen["angular_velocity"] == "rad s-1"
    assert seen["normal_force"] == "N" and seen["points"] == "m"


def test_static_walls_are_stored_once(stack):
    path, _, _ = stack
    with h5py.File(path) as h5:
        walls = h5["walls"]
        # the cells never change (links to frame 0's: one object); the points turn with the paddle
        assert walls["000000/cells"].id == walls["000002/cells"].id
        assert walls["000000/points"].id != walls["000001/points"].id


def test_writing_walls_and_contacts_leaves_the_run_unchanged(tmp_path):
    plain, written = _stack_sim(), _stack_sim()
    ctx = RunContext(snapshots=SnapshotWriter(tmp_path / "s.h5", dim=3), snapshot_contacts=True)
    for _ in range(4):
        plain.run(200)
        written.run(200)
        ctx.snapshot(written)
    ctx.snapshots.close()
    assert np.array_equal(plain.particles.x, written.particles.x)
    assert np.array_equal(plain.particles.v, written.particles.v)
    assert np.array_equal(plain.contacts.state, written.contacts.state)


def test_a_2d_run_draws_its_walls_as_segments_in_the_plane(tmp_path):
    table = MaterialTable([Material("m", RHO)], {"*": Interaction(normal_stiffness=K_N)},
                          "linear_history")
    walls = [dict(kind="cylinder_inner", point=(0, 0, 0), axis=(0, 0, 1), radius=DRUM,
                  material="m"),
             dict(kind="plane", point=(0, -2 * R, 0), normal=(0, 1, 0), material="m")]
    sim = Simulation(PhysicsSpec(dim=2, walls=True), table, x=[[0.0, 0.0, 0.0]], radius=[R],
                     material="m", walls=walls, gravity=(0, -G, 0), skin=0.2 * R)
    path = tmp_path / "s.h5"
    ctx = RunContext(snapshots=SnapshotWriter(path, dim=2))
    ctx.snapshot(sim)
    ctx.snapshots.close()
    (_, grid), = _grids(path.with_suffix(".xdmf"))["walls"]
    with h5py.File(path) as h5:
        kind, points, cells, attributes = _cell_grid(h5, grid)
    assert kind == "Polyline" and cells.shape[1] == 2
    assert not points[:, 2].any()
    ring = points[np.unique(cells[attributes["wall"] == 0])]
    np.testing.assert_allclose(np.hypot(ring[:, 0], ring[:, 1]), DRUM, rtol=1e-12)
    line = points[np.unique(cells[attributes["wall"] == 1])]
    assert len(line) == 2 and (line[:, 1] == -2 * R).all()
    assert line[:, 0].min() < -DRUM and line[:, 0].max() > DRUM  # across the drum


def test_members_of_a_kinematic_body_are_flagged_and_free_particles_not(tmp_path):
    """The per-particle `kinematic` field: 1 for the members of body 0 (the first body, e.g. a
    ball mill's drum), 0 for free particles; ids as the run numbers them."""
    from one_particle import BODY_HERTZ, make_sim

    sim = make_sim(BODY_HERTZ, [(0, 0, 0), (0.01, 0, 0), (0.02, 0, 0)], body=[0, 0, -1],
                   bodies=[dict(kind="rotate", center=(0, 0, 0), axis=(0, 0, 1), rate=1.0)])
    path = tmp_path / "k.h5"
    ctx = RunContext(snapshots=SnapshotWriter(path, dim=3))
    ctx.snapshot(sim)
    ctx.snapshots.close()
    with h5py.File(path) as h5:
        frame = h5["frames/000000"]
        assert frame["kinematic"][()].tolist() == [1, 1, 0]
        assert frame["particle_id"][()].tolist() == [0, 1, 2]


def _sized_writer(frame_bytes):
    """What check_snapshot_space reads of a SnapshotWriter: a first frame of ``frame_bytes`` and
    a disk of unknown free space."""
    return type("Writer", (), dict(failure=None, frame_bytes=frame_bytes, path="s.h5",
                                   free_bytes=lambda self: None))()


@pytest.mark.parametrize("frame_bytes, warned", [(1_000_000, True), (999_000, False)])
def test_snapshots_above_1_gb_are_warned_of(capsys, frame_bytes, warned):
    """docs/pipeline.md: more than 1 GB of snapshots is said in a warning before the run goes
    on: 1001 frames (duration 1 s / record_interval 1 ms) of 1 MB are 1.001 GB, of 999 kB not."""
    writer = _sized_writer(frame_bytes)
    RunContext(snapshots=writer).check_snapshot_space({"duration": 1.0, "record_interval": 1e-3})
    err = capsys.readouterr().err
    assert ("millsim: warning: --snapshots: about" in err) == warned, err
    assert not warned or "for 1001 frames" in err


@pytest.mark.parametrize("values, frames", [
    ({"revolutions": 2.0, "records_per_revolution": 10}, 21),
    ({"steps": 1000, "record_every": 10}, 101),
    ({"max_time": 0.01, "record_interval": 1e-3}, 11),
])
def test_every_scenes_frames_are_counted_from_its_own_cadence(capsys, values, frames):
    """docs/pipeline.md: frames from duration or max_time / record_interval, steps /
    record_every or revolutions x records_per_revolution, whichever pair a scene has (one
    frame more, the first); 100 MB frames make each warn with its count."""
    writer = _sized_writer(10**8)
    RunContext(snapshots=writer).check_snapshot_space(values)
    assert f"for {frames} frames" in capsys.readouterr().err


def test_vtk_reads_every_block_at_every_time(tmp_path):
    """ParaView's XDMF reader (VTK's) gives the three blocks at each time, also where a frame
    has no contact (an empty grid, which it would drop)."""
    vtk = pytest.importorskip("vtk", reason="VTK is not a dependency (pip install vtk)")
    path = tmp_path / "s.h5"
    triangle = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    with SnapshotWriter(path, dim=3) as writer:
        for k in range(3):
            writer.write(0.1 * k, np.full((4, 3), float(k)), np.ones(4), np.zeros((4, 3)),
                         walls={"points": triangle + k, "cells": [[0, 1, 2]], "wall": [0]},
                         contacts={"points": np.zeros((2 * k, 3)),
                                   "cells": np.arange(2 * k).reshape(-1, 2),
                                   "normal_force": np.ones((k, 3))})
    reader = vtk.vtkXdmfReader()
    reader.SetFileName(str(path.with_suffix(".xdmf")))
    reader.UpdateInformation()
    for k in range(3):
        reader.UpdateTimeStep(0.1 * k)
        out = reader.GetOutputDataObject(0)
        blocks = {out.GetMetaData(b).Get(vtk.vtkCompositeDataSet.NAME()): out.GetBlock(b)
                  for b in range(out.GetNumberOfBlocks())}
        assert set(blocks) == {"particles", "walls", "contacts"}
        assert blocks["particles"].GetNumberOfPoints() == 4
        assert blocks["particles"].GetPoint(0) == (k, k, k)
        assert blocks["walls"].GetPoint(0) == (k, k, k)
        assert blocks["contacts"].GetNumberOfCells() == k


def test_contacts_need_snapshots(tmp_path, capsys):
    assert main(["run", "collision", "--out", str(tmp_path / "x.nc"), "--snapshot-contacts",
                 "--quiet"]) == 2
    assert "--snapshot-contacts: needs --snapshots" in capsys.readouterr().err


# ---- a disk that fills -----------------------------------------------------------------------

@pytest.fixture
def small_fs(tmp_path):
    """A fresh tmpfs of the given size, unmounted afterwards (root only)."""
    if not hasattr(os, "geteuid") or os.geteuid() != 0:
        pytest.skip("mounting a small filesystem needs root")
    mounted = []

    def mount(size):
        path = tmp_path / f"fs{len(mounted)}"
        path.mkdir()
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
                              capture_output=True, text=True)
        if done.returncode:
            pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
        mounted.append(path)
        return path

    yield mount
    for path in mounted:
        subprocess.run(["umount", "-l", str(path)], check=False)


def test_a_full_disk_stops_the_snapshots_and_removes_them(small_fs):
    where = small_fs("1m")
    writer = SnapshotWriter(where / "s.h5", dim=3)
    n = 2000  # ~170 kB a frame
    for k in range(40):
        writer.write(0.01 * k, np.zeros((n, 3)), np.ones(n), np.zeros((n, 3)),
                     angular_velocity=np.zeros((n, 3)))
        if writer.failure:
            break
    assert writer.failure is not None and 0 < k < 39
    assert writer.failure.startswith(f"{where / 's.h5'}: disk full")
    assert not list(where.iterdir())  # nothing partial left
    writer.write(1.0, np.zeros((n, 3)), np.ones(n), np.zeros((n, 3)))  # a no-op now
    writer.close()
    assert not list(where.iterdir())


# test_conventions' small 2D ball mill (the same compiled physics), recording more often: its
# frames are counted from duration and record_interval
_BALLMILL = [f"--set={k}={v}" for k, v in {**BALLMILL, "duration": "0.02", "transient": "0.01",
                                             "record_interval": "0.0005",
                                             "snapshot_interval": "0.0005"}.items()]


def test_snapshots_that_cannot_fit_are_refused_before_the_run(small_fs, tmp_path, capsys):
    where = small_fs("1m")
    code = main(["run", "ballmill2d", *_BALLMILL, "--out", str(tmp_path / "case.nc"),
                 "--snapshots", str(where / "s.h5"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1
    assert "--snapshots: about" in err and "41 frames (duration = 0.02 / record_interval = " \
        "0.0005" in err and "free on the disk of" in err
    assert not list(where.iterdir()) and not (tmp_path / "case.nc").exists()


def test_a_disk_filling_during_the_run_keeps_the_case(small_fs, tmp_path, capsys, monkeypatch):
    where = small_fs("1m")
    monkeypatch.setattr(base, "_FRAME_COUNTS", ())  # as for a scene whose frames are not counted
    out = tmp_path / "case.nc"
    code = main(["run", "ballmill2d", *_BALLMILL, "--out", str(out), "--snapshots",
                 str(where / "s.h5"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, err
    assert err[0].startswith(f"millsim: warning: --snapshots: {where / 's.h5'}: disk full")
    assert err[-1].startswith(f"millsim: error: --snapshots: {where / 's.h5'}: disk full")
    assert err[-1].endswith(f"the case {out} is written")
    assert out.exists() and not list(where.iterdir())
