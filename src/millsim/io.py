"""netCDF output (one writer for cases, aggregates and analysis results), optional particle
snapshots (HDF5 + XDMF) and the checkpoints of running cases (pickle); the readers of the later
stages (cases, aggregates, CSV tables, snapshots), which refuse a missing, empty, truncated or
foreign file with one line naming it.

All quantities are SI; every variable carries a CF-style ``units`` attribute ("1" when
dimensionless). A case's provenance goes into global attributes so that a case file alone says
how it was produced.

CF conventions (CF-1.8) of every netCDF file: global ``Conventions``, ``title`` and ``history``
(when and by which command line it was written); ``standard_name`` only where the CF standard
name table has one (``time``: elapsed simulated time in s, without a calendar date to count from;
the DEM quantities have none); ``axis`` (X, Y horizontal, Z vertical with ``positive``, T) on the
spatial and time coordinates that the scenes define; ``bounds`` on coordinates that stand for
intervals (the ball mill's size classes), whose bounds variable inherits the coordinate's units.
"""

from __future__ import annotations

import glob
import json
import operator
import os
import pickle
import platform
import shlex
import sys
import tempfile
import time
import uuid
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import xarray as xr

import millsim

__all__ = ["write_netcdf", "write_case", "read_case", "read_table", "case_parameters",
           "atomic_target", "check_writable", "open_snapshots", "SnapshotWriter",
           "write_checkpoint", "read_checkpoint"]

# key -> coercion; coercing also rejects e.g. a float seed instead of silently truncating it
_REQUIRED_PROVENANCE = {
    "scene": str,
    "parameters": dict,
    "seed": operator.index,
    "dt": float,
    "steps": operator.index,
    "wall_time_s": float,
}


# A temporary file of atomic_target not touched for this long is left over from a killed writer
# (SIGKILL, out of memory, power loss); writing one file takes seconds.
STALE_TEMPORARY_S = 3600.0


def check_writable(path: str | os.PathLike[str], key: str | None = None) -> None:
    """Refuse an output ``path`` that cannot be written, before any work is done for it.

    Catches a path that is a directory, a parent that is a file, and a directory that refuses a
    new file (read-only, no permission), by creating and removing a probe file in the nearest
    directory that exists (the missing ones are created only when the output is written).
    ``key`` (the option that named the path) leads the message.
    """
    path = Path(path)
    key = f"{key}: " if key else ""
    if path.is_dir():
        raise ValueError(f"{key}{path} is a directory; give a file name")
    parent = path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise ValueError(f"{key}cannot write {path}: {parent} is not a directory")
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".probe", dir=parent)
    except OSError as exc:
        raise ValueError(f"{key}cannot write {path}: {parent}: {exc.strerror}") from None
    os.close(fd)
    os.unlink(probe)


@contextmanager
def atomic_target(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it onto ``path`` only if the block succeeds.

    Same directory so that os.replace is an atomic rename on one filesystem; same suffix so that
    writers that pick the format by it (matplotlib) write the right one. The name is only
    reserved, not created, so the writer creates the file with the usual umask permissions. The
    temporary files of earlier writers of ``path`` that were killed are removed first.
    """
    path = Path(path)
    check_writable(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _remove_stale(path)
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def _remove_stale(path: Path) -> None:
    now = time.time()
    for name in glob.glob(f".{glob.escape(path.name)}.*.tmp*", root_dir=path.parent):
        stale = path.parent / name
        try:
            if now - stale.stat().st_mtime > STALE_TEMPORARY_S:
                stale.unlink()
        except FileNotFoundError:  # removed meanwhile by another writer
            pass


def _unreadable(path: str | os.PathLike[str], exc: BaseException, kind: str) -> ValueError:
    """The one-line error for a file that cannot be opened as ``kind``."""
    p = Path(path)
    if not p.exists():
        reason = "no such file"
    elif p.is_dir():
        reason = "a directory, not a file"
    elif isinstance(exc, PermissionError):
        reason = "permission denied"
    elif p.stat().st_size == 0:
        reason = "empty file"
    else:
        detail = " ".join(str(getattr(exc, "strerror", None) or exc).split())  # h5py's span lines
        reason = f"not a readable {kind} (truncated, damaged or another format: {detail})"
    return ValueError(f"{path}: {reason}")


def _attr_value(name: str, value: Any) -> Any:
    """Convert ``value`` to something netCDF4 can store as an attribute."""
    if value is None:
        return ""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool):  # netCDF has no boolean type
        return int(value)
    if isinstance(value, (str, bytes, int, float)):
        return value
    if isinstance(value, (list, tuple, np.ndarray)):
        array = np.asarray(value)
        if array.ndim == 1 and array.dtype.kind in "iuf":
            return array
        if array.ndim == 1 and array.dtype.kind == "b":
            return array.astype(np.int8)
    raise TypeError(
        f"attribute {name!r}: {type(value).__name__} is not netCDF-legal "
        "(nested structures belong in provenance['parameters'])"
    )


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def _software_attrs() -> dict[str, str]:
    version = getattr(millsim, "__version__", None)
    if version is None:
        try:
            version = metadata.version("millsim")
        except metadata.PackageNotFoundError:
            version = "unknown"
    try:
        # metadata rather than import: importing numba costs about a second
        numba_version = metadata.version("numba")
    except metadata.PackageNotFoundError:
        numba_version = "unknown"
    attrs = {
        "millsim_version": str(version),
        "python_version": platform.python_version(),
        "numpy_version": np.__version__,
        "numba_version": numba_version,
    }
    if callable(getattr(millsim, "provenance_hash", None)):
        attrs["engine_hash"] = str(millsim.provenance_hash())
    return attrs


def _provenance_attrs(provenance: dict[str, Any]) -> dict[str, Any]:
    attrs: dict[str, Any] = {}
    for key, coerce in _REQUIRED_PROVENANCE.items():
        if key not in provenance:
            raise ValueError(f"provenance is missing required key {key!r}")
        try:
            attrs[key] = coerce(provenance[key])
        except (TypeError, ValueError) as exc:
            raise ValueError(f"provenance[{key!r}]: {exc}") from exc

    parameters = attrs.pop("parameters")
    attrs["parameters_json"] = json.dumps(parameters, sort_keys=True, default=_json_default)
    # scalar copies let ncdump and netCDF tools filter cases without parsing JSON
    for key, value in parameters.items():
        if isinstance(value, np.generic):
            value = value.item()
        if isinstance(value, (str, int, float)):  # bool is an int
            attrs[f"param_{key}"] = _attr_value(key, value)

    for key, value in provenance.items():
        if key not in _REQUIRED_PROVENANCE:
            attrs[key] = _attr_value(key, value)
    return attrs


def write_netcdf(path: str | os.PathLike[str], data: xr.Dataset,
                 attrs: dict[str, Any] | None = None) -> Path:
    """Write any dataset to netCDF4 atomically (``path`` is either complete or untouched), CF-style.

    The one netCDF writer of millsim: case files, aggregates and analysis outputs all go through
    it. Every data variable and coordinate needs a ``units`` attribute ("1" if dimensionless),
    except a bounds variable (it has its coordinate's); coordinates get no fill value (CF forbids
    missing values there); attributes are made netCDF-legal. The global attributes are
    ``data.attrs`` updated by ``attrs``, which must give a ``title``, plus ``Conventions``,
    ``created_utc`` and ``history``: the time and command line of this write, before the history
    the data came with.
    """
    path = Path(path)
    given = {**data.attrs, **(attrs or {})}
    if not given.get("title"):
        raise ValueError("title: every netCDF file of millsim says what it holds in a 'title' "
                         "attribute")
    # a bounds variable read back by xarray has its "bounds" reference in .encoding
    bounds = {v.attrs.get("bounds", v.encoding.get("bounds")) for v in data.variables.values()}
    for name, variable in data.variables.items():
        # xarray keeps the units of decoded times in .encoding rather than .attrs
        if name not in bounds and "units" not in variable.attrs | variable.encoding:
            raise ValueError(
                f"variable {name!r} has no 'units' attribute (use '1' if dimensionless)"
            )

    ds = data.copy(deep=False)
    for name, variable in ds.variables.items():
        variable.attrs = {k: _attr_value(f"{name}.{k}", v) for k, v in variable.attrs.items()}
        if name in ds.coords:
            # CF forbids missing values in coordinates; xarray would add a NaN _FillValue to floats
            variable.encoding = {"_FillValue": None, **variable.encoding}
    created = datetime.now(UTC).isoformat(timespec="seconds")
    history = "\n".join(filter(None, [f"{created} {_command_line()}", given.get("history")]))
    ds.attrs = {
        **{k: _attr_value(k, v) for k, v in given.items()},
        "created_utc": created,
        "history": history,
        "Conventions": "CF-1.8",
    }
    with atomic_target(path) as tmp:
        ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4")
    return path


def _command_line() -> str:
    """The command line of this process, program by its name (for ``history``)."""
    return shlex.join([Path(sys.argv[0]).name or "python", *sys.argv[1:]])


def write_case(path: str | os.PathLike[str], data: xr.Dataset, provenance: dict[str, Any]) -> Path:
    """Write one case with its provenance (:func:`write_netcdf`, atomic).

    ``provenance`` needs the keys scene, parameters, seed, dt (s), steps and wall_time_s; further
    keys are stored as they are. The software versions and the engine hash are added, and a
    title naming the scene unless ``data`` has one.
    """
    attrs = {**_provenance_attrs(provenance), **_software_attrs()}
    attrs.setdefault("title", data.attrs.get("title") or f"millsim {attrs['scene']} case")
    data = data.copy(deep=False)
    # param_* of a re-written case would be stale if its parameters changed
    data.attrs = {k: v for k, v in data.attrs.items() if not k.startswith("param_")}
    return write_netcdf(path, data, attrs)


def read_case(path: str | os.PathLike[str], scene: str | None = None) -> xr.Dataset:
    """Load a netCDF file of millsim (a case or an aggregate) fully into memory; the file is
    closed on return. ``scene``: require a case file (written by write_case) of that scene, or of
    any scene with ``"*"``.

    Times are stored as SI seconds, so CF time decoding is turned off to keep them floats. Bounds
    variables are read as coordinates (so that stacking cases keeps one set, not one per case).
    """
    try:
        ds = xr.load_dataset(path, engine="netcdf4", decode_times=False, decode_timedelta=False,
                             decode_coords="all")
    except (OSError, ValueError) as exc:
        raise _unreadable(path, exc, "netCDF file") from None
    if scene is not None:
        found = ds.attrs.get("scene")
        if found is None or "parameters_json" not in ds.attrs:
            raise ValueError(f"{path}: not a millsim case file (no scene and parameters; "
                             "`millsim run` writes them)")
        if scene != "*" and found != scene:
            raise ValueError(f"{path}: a case of scene {found!r}, not {scene!r}")
    return ds


def read_table(path: str | os.PathLike[str], **read_csv: Any):
    """A CSV table as a pandas DataFrame (``read_csv``: options of pandas.read_csv)."""
    import pandas as pd

    try:
        return pd.read_csv(path, **read_csv)
    except (OSError, ValueError) as exc:  # pandas' parser and decoding errors are ValueErrors
        raise _unreadable(path, exc, "CSV table") from None


def case_parameters(ds: xr.Dataset) -> dict[str, Any]:
    """The parameter dict of a case, as given to write_case."""
    try:
        return json.loads(ds.attrs["parameters_json"])
    except KeyError:
        where = ds.encoding.get("source", "dataset")
        raise ValueError(f"{where}: has no 'parameters_json'; not a case written by write_case") \
            from None


@contextmanager
def open_snapshots(path: str | os.PathLike[str]) -> Iterator[h5py.Group]:
    """The ``/frames`` group of a snapshot file (SnapshotWriter), open while the block runs."""
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise _unreadable(path, exc, "HDF5 snapshot file") from None
    with f:
        if not isinstance(f.get("frames"), h5py.Group):
            raise ValueError(f"{path}: no /frames group; not a snapshot file of `millsim run "
                             "--snapshots`")
        yield f["frames"]


class _CheckpointPickler(pickle.Pickler):
    """Refuses anything of numba's: compiled functions are rebuilt on load, never saved (pickled,
    a dispatcher would carry its code by value and recompile)."""

    def reducer_override(self, obj: Any) -> Any:
        if type(obj).__module__.split(".")[0] == "numba":
            raise TypeError(f"checkpoint: {type(obj).__name__} {obj!r:.60} would be pickled; drop "
                            "it in its owner's __getstate__")
        return NotImplemented


def write_checkpoint(path: str | os.PathLike[str], key: dict[str, Any], state: Any) -> Path:
    """Pickle ``state`` to ``path`` atomically, after a header of ``key`` (what the state belongs
    to, e.g. scene and parameters) and the software versions and engine hash of this process."""
    path = Path(path)
    with atomic_target(path) as tmp:
        with open(tmp, "wb") as fh:
            pickle.dump({**key, **_software_attrs()}, fh, protocol=pickle.HIGHEST_PROTOCOL)
            _CheckpointPickler(fh, protocol=pickle.HIGHEST_PROTOCOL).dump(state)
            fh.flush()
            os.fsync(fh.fileno())  # the rename must not land before the data
    return path


def read_checkpoint(path: str | os.PathLike[str], key: dict[str, Any]) -> Any:
    """The state :func:`write_checkpoint` saved at ``path`` under ``key`` and this process's
    software and engine hash; ValueError naming the difference when it was saved under others."""
    expected = {**key, **_software_attrs()}
    with open(path, "rb") as fh:
        try:
            header = pickle.load(fh)
        except Exception as exc:  # anything pickle raises: a file that is not a checkpoint
            raise ValueError(f"not a checkpoint ({type(exc).__name__}: {exc})") from None
        if not isinstance(header, dict):
            raise ValueError("not a checkpoint (no header)")
        differ = sorted(k for k in expected.keys() | header.keys()
                        if k != "parameters" and header.get(k) != expected.get(k))
        params, theirs = expected.get("parameters", {}), header.get("parameters", {})
        differ += [f"parameter {k}" for k in sorted(params.keys() | theirs.keys())
                   if params.get(k) != theirs.get(k)]
        if differ:
            raise ValueError(f"written under another {', '.join(differ)}")
        try:
            return pickle.load(fh)
        except Exception as exc:  # same code and versions: only a damaged file gets here
            raise ValueError(f"unreadable ({type(exc).__name__}: {exc})") from None


# XDMF names integer types of one byte Char/UChar and all others Int/UInt
_XDMF_NUMBER_TYPES = {("f", 4): "Float", ("f", 8): "Float", ("i", 1): "Char", ("u", 1): "UChar"}
_XDMF_NUMBER_TYPES.update({("i", n): "Int" for n in (2, 4, 8)})
_XDMF_NUMBER_TYPES.update({("u", n): "UInt" for n in (2, 4, 8)})

_SNAPSHOT_UNITS = {"position": "m", "radius": "m", "velocity": "m/s"}


class SnapshotWriter:
    """Particle snapshots to HDF5, one group per frame, plus an XDMF sidecar for ParaView.

    Frames live under ``/frames/NNNNNN`` with datasets position (N x 3, m), radius (N, m),
    velocity (N x 3, m/s) and any extra per-particle fields; N may differ between frames.
    In 2-D (``dim=2``) vectors are given as N x 2 and padded with zeros, since XDMF XYZ geometry
    and Vector attributes need three components. The files are created with the first frame, so
    that a run refused before it starts leaves none; the XDMF file is written on close().
    """

    def __init__(self, path_h5: str | os.PathLike[str], dim: int):
        if dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3, got {dim}")
        self.path = Path(path_h5)
        self.xdmf_path = self.path.with_suffix(".xdmf")
        self.dim = dim
        self._file: h5py.File | None = None
        self._closed = False

    def _open(self) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = h5py.File(self.path, "w")
        self._file.attrs["dim"] = self.dim
        self._file.attrs["time_units"] = "s"
        self._frames = self._file.create_group("frames")

    def __enter__(self) -> SnapshotWriter:
        return self

    def __exit__(self, *exc_info: object) -> None:
        # also on error: the frames written so far are what one wants to look at
        self.close()

    def _per_particle(self, name: str, value: Any, count: int) -> np.ndarray:
        array = np.asarray(value)
        if array.dtype.kind == "b":
            array = array.astype(np.uint8)
        if array.shape == (count, self.dim):
            array = np.pad(array, ((0, 0), (0, 3 - self.dim)))
        if array.shape not in ((count,), (count, 3)):
            expected = f"({count},) or ({count}, {self.dim})"
            raise ValueError(f"{name}: shape {array.shape}, expected {expected}")
        if (array.dtype.kind, array.dtype.itemsize) not in _XDMF_NUMBER_TYPES:
            raise ValueError(f"{name}: dtype {array.dtype} has no XDMF number type")
        return array

    def write(self, time: float, position: Any, radius: Any, velocity: Any, **fields: Any) -> None:
        """Append one frame at ``time`` (s). Extra fields are arrays of shape (N,) or (N, dim)."""
        if self._closed:
            raise ValueError("SnapshotWriter is closed")
        if self._file is None:
            self._open()
        radius = np.asarray(radius, dtype=np.float64)
        if radius.ndim != 1:
            raise ValueError(f"radius: shape {radius.shape}, expected (N,)")
        count = len(radius)
        arrays = {
            "position": self._per_particle("position", np.asarray(position, np.float64), count),
            "radius": self._per_particle("radius", radius, count),
            "velocity": self._per_particle("velocity", np.asarray(velocity, np.float64), count),
        }
        for name in ("position", "velocity"):
            if arrays[name].ndim != 2:
                shape = arrays[name].shape
                raise ValueError(f"{name}: shape {shape}, expected ({count}, {self.dim})")
        for name, value in fields.items():
            arrays[name] = self._per_particle(name, value, count)

        group = self._frames.create_group(f"{len(self._frames):06d}")
        group.attrs["time"] = float(time)
        for name, array in arrays.items():
            dataset = group.create_dataset(name, data=array)
            if name in _SNAPSHOT_UNITS:
                dataset.attrs["units"] = _SNAPSHOT_UNITS[name]
        # flushed per frame so that a crashed run still leaves readable frames
        self._file.flush()

    def close(self) -> None:
        self._closed = True
        if self._file is None:
            return
        try:
            self._write_xdmf()
        finally:
            self._file.close()
            self._file = None

    def _write_xdmf(self) -> None:
        root = ET.Element("Xdmf", Version="3.0")
        domain = ET.SubElement(root, "Domain")
        series = ET.SubElement(
            domain, "Grid", Name="particles", GridType="Collection", CollectionType="Temporal"
        )
        for frame_name, group in self._frames.items():
            count = len(group["radius"])
            grid = ET.SubElement(series, "Grid", Name=f"frame_{frame_name}", GridType="Uniform")
            ET.SubElement(grid, "Time", Value=repr(float(group.attrs["time"])))
            ET.SubElement(
                grid,
                "Topology",
                TopologyType="Polyvertex",
                NumberOfElements=str(count),
                NodesPerElement="1",
            )
            geometry = ET.SubElement(grid, "Geometry", GeometryType="XYZ")
            self._data_item(geometry, group["position"])
            for name, dataset in group.items():
                if name == "position":
                    continue
                kind = "Scalar" if dataset.ndim == 1 else "Vector"
                attribute = ET.SubElement(
                    grid, "Attribute", Name=name, AttributeType=kind, Center="Node"
                )
                self._data_item(attribute, dataset)

        ET.indent(root)
        with atomic_target(self.xdmf_path) as tmp:
            ET.ElementTree(root).write(tmp, encoding="utf-8", xml_declaration=True)

    def _data_item(self, parent: ET.Element, dataset: h5py.Dataset) -> None:
        item = ET.SubElement(
            parent,
            "DataItem",
            Dimensions=" ".join(map(str, dataset.shape)),
            NumberType=_XDMF_NUMBER_TYPES[dataset.dtype.kind, dataset.dtype.itemsize],
            Precision=str(dataset.dtype.itemsize),
            Format="HDF",
        )
        # relative file name: the XDMF reader resolves it against the XDMF file's directory
        item.text = f"{self.path.name}:{dataset.name}"
