"""netCDF output (one writer for cases, aggregates and analysis results), optional particle
snapshots (HDF5 + XDMF) and the checkpoints of running cases (data only, no pickle:
:mod:`millsim.util.checkpoint`); the readers of the later stages (cases, aggregates, CSV tables,
snapshots), which refuse a missing, empty, truncated or foreign file with one line naming it.

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

import errno
import glob
import json
import operator
import os
import platform
import shlex
import sys
import tempfile
import time
import uuid
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

from .util import checkpoint
from .util.disk import format_bytes, free_bytes

__all__ = ["write_netcdf", "write_case", "read_case", "read_table", "case_parameters",
           "atomic_target", "check_writable", "WriteError", "open_snapshots", "SnapshotWriter",
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


class WriteError(OSError):
    """An output that could not be written, in one line naming the file and the cause (disk full,
    quota, permission, read-only filesystem); ``errno`` is the cause's."""


# what a user can act on, by errno
_WRITE_CAUSES = {
    errno.ENOSPC: "disk full (no space left on device)",
    errno.EDQUOT: "disk quota exceeded",
    errno.EROFS: "read-only filesystem",
    errno.EACCES: "permission denied",
    errno.EPERM: "permission denied",
    errno.EFBIG: "file too large for the filesystem",
}

# A failed writer that reports no usable errno (netCDF4: "NetCDF: HDF error", or even "Permission
# denied" on a full disk) is diagnosed by reserving this much beyond what it needs in its directory.
_PROBE_MARGIN = 256 * 1024
_PROBE_MAX = 64 * 1024**2  # reserving more would fill a tmpfs's RAM or take long where emulated


def _write_error(path: Path, code: int, need: int = 0) -> WriteError:
    cause = _WRITE_CAUSES.get(code) or os.strerror(code)
    free = free_bytes(path.parent) if code in (errno.ENOSPC, errno.EDQUOT) else None
    if free is not None:
        cause += f": {format_bytes(free)} free in {path.parent}"
        cause += f", at least {format_bytes(need)} needed" if need > free else ""
    error = WriteError(f"cannot write {path}: {cause}")
    error.errno = code
    return error


def _probe_space(directory: Path, need: int) -> int | None:
    """The errno of reserving ``need`` bytes in ``directory`` (None: it fits)."""
    free = free_bytes(directory)
    if free is not None and need > free:
        return errno.ENOSPC
    try:
        fd, probe = tempfile.mkstemp(prefix=".millsim.", suffix=".probe", dir=directory)
    except OSError as exc:
        return exc.errno
    try:
        os.posix_fallocate(fd, 0, max(1, min(need, _PROBE_MAX)))
    except OSError as exc:
        return exc.errno if exc.errno in _WRITE_CAUSES else None
    except AttributeError:  # no posix_fallocate (macOS): statvfs said it fits
        return None
    finally:
        os.close(fd)
        os.unlink(probe)
    return None


def _write_failure(path: Path, exc: BaseException, need: int) -> WriteError | None:
    """The one-line WriteError of a writer of ``path`` that raised ``exc``, or None when the
    failure is not the filesystem's (then ``exc`` stands)."""
    code = getattr(exc, "errno", None)
    if code in (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EFBIG):
        return _write_error(path, code, need)
    # netCDF4/HDF5 hide the errno (or give a wrong one): ask the directory itself
    found = _probe_space(path.parent, need + _PROBE_MARGIN) if path.parent.is_dir() else None
    if found in _WRITE_CAUSES:
        return _write_error(path, found, need)
    if code in _WRITE_CAUSES:
        return _write_error(path, code, need)
    return None


@contextmanager
def atomic_target(path: str | os.PathLike[str], size: int = 0) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it onto ``path`` only if the block succeeds.

    Same directory so that os.replace is an atomic rename on one filesystem; same suffix so that
    writers that pick the format by it (matplotlib) write the right one. The name is only
    reserved, not created, so the writer creates the file with the usual umask permissions. The
    temporary files of earlier writers of ``path`` that were killed are removed first.

    A write that fails for the filesystem's sake (disk full, quota, permission, read-only) raises
    :class:`WriteError`, one line naming ``path`` and the cause, and leaves no file. ``size``: the
    bytes the file will take, where known; less free space than that is refused before writing.
    """
    path = Path(path)
    check_writable(path)
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp{path.suffix}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        _remove_stale(path)
        free = free_bytes(path.parent)
        if free is not None and size > free:
            raise _write_error(path, errno.ENOSPC, size)
        yield tmp
        os.replace(tmp, path)
    except WriteError:
        raise
    except (OSError, RuntimeError) as exc:  # netCDF4 raises RuntimeError("NetCDF: HDF error")
        written = tmp.stat().st_size if tmp.exists() else 0
        tmp.unlink(missing_ok=True)  # first: its space counts as free for the diagnosis
        failure = _write_failure(path, exc, max(size, written))
        if failure is None:
            raise
        raise failure from None
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
        elif value and isinstance(value, (list, tuple)) and all(isinstance(v, dict)
                                                                for v in value):
            # a list of declarations (the walls): its YAML text (JSON is YAML)
            attrs[f"param_{key}"] = json.dumps(value, sort_keys=True, default=_json_default)

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
    # the data uncompressed, as netCDF4 writes it, plus its header and attributes
    with atomic_target(path, size=ds.nbytes + len(json.dumps(ds.attrs, default=str))) as tmp:
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


def _checkpoint_header(key: dict[str, Any]) -> dict[str, Any]:
    """``key`` and this process's software versions and engine hash, as JSON reads them back."""
    return json.loads(json.dumps({**key, **_software_attrs()}, default=_json_default))


def write_checkpoint(path: str | os.PathLike[str], key: dict[str, Any], state: Any,
                     packages: tuple[str, ...] = ()) -> Path:
    """Save ``state`` to ``path`` atomically (format: :mod:`millsim.util.checkpoint`), under a
    header of ``key`` (what the state belongs to, e.g. scene and parameters) and the software
    versions and engine hash of this process; ``packages``: those outside millsim whose classes
    the state holds (a user's scene)."""
    path = Path(path)
    with atomic_target(path) as tmp:
        checkpoint.write(tmp, _checkpoint_header(key), state, packages)
    return path


def read_checkpoint(path: str | os.PathLike[str], key: dict[str, Any],
                    packages: tuple[str, ...] = ()) -> Any:
    """The state :func:`write_checkpoint` saved at ``path`` under ``key`` and this process's
    software and engine hash; ValueError naming the difference when it was saved under others
    (checked on the header, before the state is read)."""
    expected = _checkpoint_header(key)

    def check(header: dict[str, Any]) -> None:
        def same(a: Any, b: Any) -> bool:  # as JSON text: NaN equals NaN
            return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)

        header = {k: v for k, v in header.items() if k not in ("format", "version")}
        differ = sorted(k for k in expected.keys() | header.keys()
                        if k != "parameters" and not same(header.get(k), expected.get(k)))
        params, theirs = expected.get("parameters", {}), header.get("parameters", {})
        if not isinstance(theirs, dict):
            raise ValueError("not a checkpoint (parameters are no mapping)")
        differ += [f"parameter {k}" for k in sorted(params.keys() | theirs.keys())
                   if not same(params.get(k), theirs.get(k))]
        if differ:
            raise ValueError(f"written under another {', '.join(differ)}")

    return checkpoint.read(path, check, packages)


# the snapshot writer lives in util.snapshots (with the walls and contacts grids); imported
# here, at the end, because it uses atomic_target of this module
from .util.snapshots import SNAPSHOT_UNITS, SnapshotWriter  # noqa: E402, F401
