"""File conventions: the CF attributes of every netCDF file millsim writes (read back raw with
netCDF4, as a CF tool sees them), and the particle and parent ids of the snapshots, through the
breakage of both models (Weibull splits in the ball mill, Tavares progeny in bed_impact).

The two runs use the compiled variants of tests/test_restart.py (ballmill2d with fragmentation)
and tests/test_bed_impact.py (Tavares), so this file adds no kernel compilation of its own.
"""

import json
import sys
from datetime import UTC, datetime, timedelta

import netCDF4
import numpy as np
import pytest
import xarray as xr

from millsim.analysis.aggregate import aggregate
from millsim.cli import main
from millsim.io import case_parameters, open_snapshots, read_case, write_case, write_netcdf

# 0.06 s of a 2 cm drum, ~130 grains, fractures from the second record on (tests/test_restart.py)
BALLMILL = {"drum_radius": "0.02", "grain_radius": "0.002", "filling": "0.3", "duration": "0.06",
            "transient": "0.02", "record_interval": "0.005", "snapshot_interval": "0.005",
            "weibull_c": "1e-4", "seed": "3"}


def _raw_attrs(path):
    """Global and per-variable attributes as stored in the file."""
    with netCDF4.Dataset(path) as nc:
        return ({k: nc.getncattr(k) for k in nc.ncattrs()},
                {name: {k: var.getncattr(k) for k in var.ncattrs()}
                 for name, var in nc.variables.items()})


def _frames(path):
    """(time, particle_id, parent_id, radius, kinematic) of every snapshot frame."""
    with open_snapshots(path) as frames:
        return [(float(g.attrs["time"]), g["particle_id"][()], g["parent_id"][()], g["radius"][()],
                 g["kinematic"][()]) for g in frames.values()]


def _check_ids(frames, dim):
    """Ids are unique in every frame and keep their particle (same radius, never reappearing
    after a gap); a particle made by breakage names an id issued before its own, seen no later
    than the frame before it appears and never after (it was replaced); the fragments of a
    parent hold no more than its volume (area in 2D), the rest being fines or dust. Returns
    the number of fragments seen."""
    first_seen, last_seen, radius, parent = {}, {}, {}, {}
    for k, (_, ids, parents, r, _) in enumerate(frames):
        assert len(np.unique(ids)) == len(ids), f"frame {k}: ids not unique"
        for i, p, ri in zip(ids.tolist(), parents.tolist(), r.tolist()):
            if i in radius:
                assert ri == radius[i] and parent[i] == p, f"id {i} changed particle"
                assert last_seen[i] == k - 1, f"id {i} reappeared"
            else:
                first_seen[i], radius[i], parent[i] = k, ri, p
            last_seen[i] = k
    children = {}
    for i, p in parent.items():
        if p < 0:
            continue
        assert p < i
        children.setdefault(p, []).append(i)
        if p in first_seen:  # else it was made and broke between two frames
            assert first_seen[p] < first_seen[i] and last_seen[p] < first_seen[i], (p, i)
    for p, kids in children.items():
        if p in radius:
            assert sum(radius[c] ** dim for c in kids) <= radius[p] ** dim * (1 + 1e-12), p
    return sum(len(kids) for kids in children.values())


@pytest.fixture(scope="module")
def ballmill(tmp_path_factory):
    d = tmp_path_factory.mktemp("ballmill")
    args = [f"--set={k}={v}" for k, v in BALLMILL.items()]
    assert main(["run", "ballmill2d", *args, "--out", str(d / "case.nc"),
                 "--snapshots", str(d / "snap.h5"), "--quiet"]) == 0
    return d


def test_case_file_carries_the_cf_attributes(ballmill):
    """Conventions, title, history (time and command line of the write), units by name,
    standard_name only where the CF table has one (time), axis on the space and time
    coordinates (the drum's y is vertical: CF axis Z, positive up)."""
    glob, var = _raw_attrs(ballmill / "case.nc")
    assert glob["Conventions"] == "CF-1.8"
    assert glob["title"].startswith("millsim ballmill2d case: 2D ball mill")
    when, command = glob["history"].split(" ", 1)
    assert when == glob["created_utc"]
    assert timedelta(0) <= datetime.now(UTC) - datetime.fromisoformat(when) \
        < timedelta(minutes=30)
    assert command  # this process's command line (pytest's here: main() ran in-process)
    assert {name: var[name].get("units") for name in ("time", "snapshot", "gx", "gy",
            "size_class", "drive_power", "size_distribution")} == {
        "time": "s", "snapshot": "s", "gx": "m", "gy": "m", "size_class": "m",
        "drive_power": "W", "size_distribution": "kg"}
    named = {name: a["standard_name"] for name, a in var.items() if "standard_name" in a}
    assert named == {"time": "time", "snapshot": "time"}
    axes = {name: (a["axis"], a.get("positive")) for name, a in var.items() if "axis" in a}
    assert axes == {"time": ("T", None), "snapshot": ("T", None), "gx": ("X", None),
                    "gy": ("Z", "up")}


def test_size_class_bounds_are_the_classes_of_the_distribution(ballmill):
    """size_class names its bounds; the bounds run from the sieve radius to the largest raw
    radius in contiguous classes around each centre, and binning the grains of the particle
    snapshot taken at each size snapshot by them gives the stored mass per class."""
    _, var = _raw_attrs(ballmill / "case.nc")
    assert var["size_class"]["bounds"] == "size_class_bounds"
    ds = read_case(ballmill / "case.nc")
    b = ds["size_class_bounds"].values
    assert ds["size_class_bounds"].dims == ("size_class", "bound") and b.shape == (12, 2)
    assert (b[:, 1] > b[:, 0]).all() and np.array_equal(b[1:, 0], b[:-1, 1])
    v = case_parameters(ds)
    assert b[0, 0] == pytest.approx(v["sieve_radius"], rel=1e-12)
    assert b[-1, 1] == pytest.approx(v["grain_radius"] * (1 + v["grain_radius_spread"]), rel=1e-12)
    np.testing.assert_allclose(ds["size_class"], b.mean(axis=1), rtol=1e-12)

    frames = {round(t, 9): (r, kin) for t, _, _, r, kin in _frames(ballmill / "snap.h5")}
    edges = np.append(b[:, 0], b[-1, 1])
    assert len(ds["snapshot"]) >= 7
    for t, stored in zip(ds["snapshot"].values, ds["size_distribution"].values):
        r, kin = frames[round(float(t), 9)]
        grains = r[kin == 0]
        mass = v["density"] * np.pi * grains**2 * v["thickness"]  # disks
        expected, _ = np.histogram(grains, bins=edges, weights=mass)
        np.testing.assert_allclose(stored, expected, rtol=1e-12)


def test_aggregate_keeps_one_set_of_bounds_and_the_attributes(ballmill, tmp_path, monkeypatch):
    """The aggregate of the case stacked over n_over_nc: Conventions, its own title and a
    history whose first line is this write's command line (program by name, shell-quoted) and
    whose next is the case's; the bounds stay one (size_class, bound) variable, not one per
    case; the coordinates keep their axes."""
    monkeypatch.setattr(sys, "argv", ["/opt/venv/bin/millsim", "aggregate", "my case.nc"])
    ds = aggregate("ballmill2d", [ballmill / "case.nc"], ["n_over_nc"])
    write_netcdf(tmp_path / "agg.nc", ds)
    glob, var = _raw_attrs(tmp_path / "agg.nc")
    case_glob, _ = _raw_attrs(ballmill / "case.nc")
    assert glob["Conventions"] == "CF-1.8"
    assert glob["title"] == "millsim ballmill2d: 1 cases stacked over n_over_nc"
    assert glob["history"].split("\n") == [
        f"{glob['created_utc']} millsim aggregate 'my case.nc'", case_glob["history"]]
    assert var["size_class"]["bounds"] == "size_class_bounds"
    back = read_case(tmp_path / "agg.nc")
    assert back["size_class_bounds"].dims == ("size_class", "bound")
    assert back["mass_fraction"].dims == ("n_over_nc", "size_class")
    assert (var["gx"]["axis"], var["gy"]["axis"]) == ("X", "Z")
    assert json.loads(glob["source_cases"]) == [str(ballmill / "case.nc")]


def test_ballmill_snapshot_ids_follow_the_weibull_splits(ballmill):
    """Every fragment of a split disk names its parent; ids are never reused; the drum's wall
    particles keep theirs; at most as many particles vanish between two frames as fractures
    were recorded in between (a vanished particle broke)."""
    frames = _frames(ballmill / "snap.h5")
    assert _check_ids(frames, dim=2) > 20
    ds = read_case(ballmill / "case.nc")
    events = dict(zip(np.round(ds["time"].values, 9), ds["fracture_events"].values))
    for (t0, ids0, _, _, kin0), (t1, ids1, _, _, _) in zip(frames, frames[1:]):
        gone = np.setdiff1d(ids0, ids1)
        assert not np.isin(gone, ids0[kin0 == 1]).any()
        assert len(gone) <= events[round(t1, 9)] - events.get(round(t0, 9), 0)


def test_tavares_progeny_name_their_parent(tmp_path):
    """The tiny bed of tests/test_bed_impact.py (one 5.5 mm particle under the ball, broken
    with certainty, its progeny unbreakable): the particle's id vanishes at the break, and the
    progeny spheres that replace it, as many as the case's event record says, name it as their
    parent and hold no more than its volume (the rest is unresolved fines)."""
    out, snap = tmp_path / "case.nc", tmp_path / "snap.h5"
    assert main(["run", "bed_impact", "--set", "rings=0", "--set", "settle_time=0", "--set",
                 "d_min_ratio=0.2", "--set", "record_interval=5e-5", "--out", str(out),
                 "--snapshots", str(snap), "--quiet"]) == 0
    ds = read_case(out)
    assert int(ds["breakage_events"]) == 1
    frames = _frames(snap)
    _, ids, parents, radius, _ = frames[0]
    assert sorted(ids.tolist()) == [0, 1] and (parents == -1).all()
    particle = int(ids[np.argmin(radius)])  # the ball is the larger
    assert _check_ids(frames, dim=3) == int(ds["event_progeny"][0]) > 1
    _, ids, parents, _, _ = frames[-1]
    assert particle not in ids
    assert sorted(set(parents.tolist())) == [-1, particle]


def test_writer_requires_a_title_and_keeps_history(tmp_path):
    """A dataset without a title is refused (no file); re-writing a dataset read back puts the
    new write before the history it came with; a bounds variable may leave its units to its
    coordinate, any other variable may not."""
    data = xr.Dataset({"p": ("t", np.arange(3.0), {"units": "W"})},
                      coords={"t": ("t", [0.0, 1.0, 2.0], {"units": "s"})})
    with pytest.raises(ValueError, match="title"):
        write_netcdf(tmp_path / "a.nc", data)
    assert not list(tmp_path.iterdir())
    first = write_case(tmp_path / "a.nc", data, {"scene": "demo", "parameters": {}, "seed": 0,
                                                 "dt": 1.0, "steps": 2, "wall_time_s": 0.1})
    glob, _ = _raw_attrs(first)
    assert glob["title"] == "millsim demo case" and glob["history"].count("\n") == 0
    write_netcdf(tmp_path / "b.nc", read_case(first))
    glob_b, _ = _raw_attrs(tmp_path / "b.nc")
    now, before = glob_b["history"].split("\n")
    assert now.startswith(f"{glob_b['created_utc']} ") and before == glob["history"]

    bounds = (("t", "nv"), [[0.0, 1.0], [1.0, 2.0], [2.0, 3.0]])
    bounded = data.assign_coords(t=data["t"].assign_attrs(bounds="t_bounds"), t_bounds=bounds)
    write_netcdf(tmp_path / "c.nc", bounded, {"title": "bounded"})
    _, var = _raw_attrs(tmp_path / "c.nc")
    assert var["t"]["bounds"] == "t_bounds" and var["t"]["units"] == "s"
    with pytest.raises(ValueError, match="'t_bounds'"):  # referenced by nothing: a plain variable
        write_netcdf(tmp_path / "d.nc", data.assign_coords(t_bounds=bounds), {"title": "unbound"})
