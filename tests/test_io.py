import platform
import xml.etree.ElementTree as ET
from datetime import UTC, datetime, timedelta

import h5py
import numba
import numpy as np
import pytest
import xarray as xr

import millsim
from millsim.io import SnapshotWriter, case_parameters, read_case, write_case


def make_dataset() -> xr.Dataset:
    time = np.linspace(0.0, 0.1, 5)
    return xr.Dataset(
        {
            "power": ("time", np.arange(5.0), {"units": "W", "long_name": "mill power draw"}),
            "fines_fraction": (
                "time",
                np.linspace(0, 0.2, 5),
                {"units": "1", "long_name": "mass fraction below cut"},
            ),
        },
        coords={"time": ("time", time, {"units": "s", "long_name": "simulated time"})},
    )


def make_provenance(**overrides) -> dict:
    provenance = {
        "scene": "ball_mill",
        "parameters": {
            "speed_fraction": np.float64(0.75),
            "n_balls": np.int64(40),
            "breakage": True,
            "liner": "wave",
            "note": None,
            "size_classes": [1e-3, 2e-3],
            "contact": {"model": "hertz", "restitution": 0.5},
        },
        "seed": 7,
        "dt": 1e-5,
        "steps": 10_000,
        "wall_time_s": 12.5,
    }
    provenance.update(overrides)
    return provenance


def leftovers(directory) -> list[str]:
    return sorted(p.name for p in directory.iterdir())


def test_roundtrip(tmp_path):
    data = make_dataset()
    path = write_case(tmp_path / "cases" / "case.nc", data, make_provenance())
    assert path == tmp_path / "cases" / "case.nc"
    assert leftovers(path.parent) == ["case.nc"]

    ds = read_case(path)
    xr.testing.assert_allclose(ds, data)
    assert ds["power"].attrs["units"] == "W"
    assert ds["time"].dtype == np.float64  # seconds stay floats, not decoded timedeltas
    assert "_FillValue" not in ds["time"].encoding  # CF: no missing values in coordinates

    attrs = ds.attrs
    assert attrs["scene"] == "ball_mill"
    assert attrs["seed"] == 7 and attrs["steps"] == 10_000
    assert attrs["dt"] == 1e-5 and attrs["wall_time_s"] == 12.5
    assert attrs["Conventions"] == "CF-1.8"
    assert attrs["param_speed_fraction"] == 0.75
    assert attrs["param_n_balls"] == 40
    assert attrs["param_breakage"] == 1
    assert attrs["param_liner"] == "wave"
    assert not {"param_note", "param_size_classes", "param_contact"} & set(attrs)
    # the software of this very process, and a creation time of a moment ago
    assert attrs["millsim_version"] == millsim.__version__
    assert attrs["python_version"] == platform.python_version()
    assert attrs["numpy_version"] == np.__version__
    assert attrs["numba_version"] == numba.__version__
    created = datetime.fromisoformat(attrs["created_utc"])
    assert created.utcoffset() == timedelta(0)
    assert timedelta(seconds=-1) < datetime.now(UTC) - created < timedelta(minutes=5)
    assert "hostname" not in attrs
    assert attrs["engine_hash"] == millsim.provenance_hash()

    assert case_parameters(ds) == {
        "speed_fraction": 0.75,
        "n_balls": 40,
        "breakage": True,
        "liner": "wave",
        "note": None,
        "size_classes": [1e-3, 2e-3],
        "contact": {"model": "hertz", "restitution": 0.5},
    }
    # read_case has closed the file: it can be replaced at once
    write_case(path, data, make_provenance(seed=8))
    assert read_case(path).attrs["seed"] == 8


def test_missing_units_names_variable(tmp_path):
    data = make_dataset()
    del data["fines_fraction"].attrs["units"]
    with pytest.raises(ValueError, match="fines_fraction"):
        write_case(tmp_path / "case.nc", data, make_provenance())

    data = make_dataset()
    del data["time"].attrs["units"]
    with pytest.raises(ValueError, match="'time'"):
        write_case(tmp_path / "case.nc", data, make_provenance())
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("key", ["scene", "parameters", "seed", "dt", "steps", "wall_time_s"])
def test_missing_provenance_key(tmp_path, key):
    provenance = make_provenance()
    del provenance[key]
    with pytest.raises(ValueError, match=key):
        write_case(tmp_path / "case.nc", make_dataset(), provenance)
    assert leftovers(tmp_path) == []


class Unserialisable:
    pass


@pytest.mark.parametrize(
    "breakage",
    [
        lambda ds, prov: ds["power"].attrs.update(calibration=Unserialisable()),
        lambda ds, prov: prov.update(operator=Unserialisable()),
        lambda ds, prov: prov["parameters"].update(bad=Unserialisable()),
    ],
    ids=["variable-attr", "provenance-attr", "parameter"],
)
def test_failed_write_leaves_no_file(tmp_path, breakage):
    data, provenance = make_dataset(), make_provenance()
    breakage(data, provenance)
    with pytest.raises(TypeError):
        write_case(tmp_path / "case.nc", data, provenance)
    assert leftovers(tmp_path) == []


def test_failure_during_write_keeps_previous_file(tmp_path, monkeypatch):
    path = write_case(tmp_path / "case.nc", make_dataset(), make_provenance(seed=1))
    original = xr.Dataset.to_netcdf

    def partial_then_fail(self, target, *args, **kwargs):
        original(self, target, *args, **kwargs)  # a complete-looking temp file exists now
        raise OSError("disk full")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", partial_then_fail)
    with pytest.raises(OSError, match="disk full"):
        write_case(path, make_dataset(), make_provenance(seed=2))
    monkeypatch.undo()

    assert leftovers(tmp_path) == ["case.nc"]
    assert read_case(path).attrs["seed"] == 1


def test_failure_without_previous_file(tmp_path, monkeypatch):
    def fail_after_creating(self, target, *args, **kwargs):
        with open(target, "wb") as handle:
            handle.write(b"CDF partial")
        raise RuntimeError("killed")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", fail_after_creating)
    with pytest.raises(RuntimeError):
        write_case(tmp_path / "case.nc", make_dataset(), make_provenance())
    assert leftovers(tmp_path) == []


def test_case_parameters_requires_json():
    with pytest.raises(ValueError, match="parameters_json"):
        case_parameters(make_dataset())


def hdf_references(xdmf_path):
    """(file, dataset path, declared dimensions) for every HDF DataItem in an XDMF file."""
    root = ET.parse(xdmf_path).getroot()
    for item in root.iter("DataItem"):
        assert item.get("Format") == "HDF"
        file_name, dataset = item.text.strip().split(":")
        dims = tuple(int(d) for d in item.get("Dimensions").split())
        yield file_name, dataset, dims, item.get("NumberType"), int(item.get("Precision"))


@pytest.mark.parametrize("dim", [3, 2])
def test_snapshot_writer(tmp_path, dim):
    rng = np.random.default_rng(0)
    path = tmp_path / "snapshots" / "case.h5"
    counts = [6, 9]  # breakage adds particles
    with SnapshotWriter(path, dim=dim) as writer:
        for frame, n in enumerate(counts):
            writer.write(
                time=0.01 * frame,
                position=rng.random((n, dim)),
                radius=rng.random(n) * 1e-3,
                velocity=rng.random((n, dim)),
                generation=np.full(n, frame, dtype=np.int32),
                force=rng.random((n, dim)),
                broken=np.zeros(n, dtype=bool),
            )

    xdmf = path.with_suffix(".xdmf")
    root = ET.parse(xdmf).getroot()
    assert root.tag == "Xdmf" and root.get("Version") == "3.0"
    series = root.find("Domain/Grid")
    assert series.get("CollectionType") == "Temporal"
    grids = series.findall("Grid")
    assert [float(g.find("Time").get("Value")) for g in grids] == [0.0, 0.01]
    for grid, n in zip(grids, counts):
        topology = grid.find("Topology")
        assert topology.get("TopologyType") == "Polyvertex"
        assert topology.get("NumberOfElements") == str(n)
        assert grid.find("Geometry").get("GeometryType") == "XYZ"
        kinds = {a.get("Name"): a.get("AttributeType") for a in grid.findall("Attribute")}
        assert kinds == {
            "radius": "Scalar",
            "velocity": "Vector",
            "generation": "Scalar",
            "force": "Vector",
            "broken": "Scalar",
        }

    expected_types = {"f8": ("Float", 8), "i4": ("Int", 4), "u1": ("UChar", 1)}
    references = list(hdf_references(xdmf))
    assert len(references) == 2 * 6
    with h5py.File(path, "r") as h5:
        for file_name, dataset, dims, number_type, precision in references:
            assert file_name == path.name
            assert dataset in h5, dataset
            assert h5[dataset].shape == dims
            assert expected_types[h5[dataset].dtype.str[1:]] == (number_type, precision)
        assert h5["frames/000001/position"].shape == (9, 3)
        assert h5["frames/000000/position"].attrs["units"] == "m"
        assert h5["frames/000001"].attrs["time"] == 0.01
        if dim == 2:
            assert not h5["frames/000000/position"][:, 2].any()


def test_snapshot_writer_rejects_bad_shapes(tmp_path):
    with SnapshotWriter(tmp_path / "s.h5", dim=3) as writer:
        with pytest.raises(ValueError, match="velocity"):
            writer.write(0.0, np.zeros((4, 3)), np.ones(4), np.zeros((3, 3)))
        with pytest.raises(ValueError, match="position"):
            writer.write(0.0, np.zeros(4), np.ones(4), np.zeros((4, 3)))
        with pytest.raises(ValueError, match="label"):
            labels = np.array(["a"] * 4)
            writer.write(0.0, np.zeros((4, 3)), np.ones(4), np.zeros((4, 3)), label=labels)
    with pytest.raises(ValueError, match="closed"):
        writer.write(0.0, np.zeros((1, 3)), np.ones(1), np.zeros((1, 3)))
    # a failed write must not leave a half-made frame behind
    assert not ET.parse(tmp_path / "s.xdmf").getroot().find("Domain/Grid").findall("Grid")
