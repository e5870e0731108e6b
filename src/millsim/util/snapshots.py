"""Particle snapshots (HDF5 + an XDMF sidecar for ParaView), with the walls and, optionally,
the pair contacts of each frame as grids of their own (re-exported by millsim.io).

HDF5 layout, one group per frame and grid:

- ``/frames/NNNNNN``: the particles, datasets position (N x 3), radius (N), velocity (N x 3) and
  any extra per-particle fields; N may differ between frames. Attribute ``time`` [s].
- ``/walls/NNNNNN`` (when walls are given): ``points`` (P x 3), ``cells`` (C x 3 triangles, or
  C x 2 line segments in 2D) and per-cell fields (e.g. the wall's index). A dataset equal to the
  previous frame's is stored once, as a hard link (static walls cost nothing per frame).
- ``/contacts/NNNNNN`` (when contacts are given): the same, a segment per contact.

Every dataset has a CF-style ``units`` attribute, as in the netCDF files ("1": dimensionless).
The XDMF file holds one temporal collection per grid (particles, walls, contacts), which
ParaView's XDMF readers open as one multiblock data set with a time step per frame.

A disk that fills would make HDF5 fail inside its caches, where h5py cannot report it and the
process dies (SIGSEGV, measured). So each frame is written only where the disk has room for it
with a margin (its size measured on the frames so far); otherwise, or on any error of the
write, the snapshots stop: the partial files are removed and ``failure`` says why, and the run
goes on (its case file is not lost).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from .disk import format_bytes, free_bytes

__all__ = ["SnapshotWriter", "SNAPSHOT_UNITS"]

# XDMF names integer types of one byte Char/UChar and all others Int/UInt
_XDMF_NUMBER_TYPES = {("f", 4): "Float", ("f", 8): "Float", ("i", 1): "Char", ("u", 1): "UChar"}
_XDMF_NUMBER_TYPES.update({("i", n): "Int" for n in (2, 4, 8)})
_XDMF_NUMBER_TYPES.update({("u", n): "UInt" for n in (2, 4, 8)})

# units of every dataset the run writes, in the netCDF files' CF style
SNAPSHOT_UNITS = {
    "position": "m", "radius": "m", "velocity": "m s-1", "angular_velocity": "rad s-1",
    "kinematic": "1", "particle_id": "1", "parent_id": "1",
    # walls and contacts
    "points": "m", "cells": "1", "wall": "1", "kind": "1",
    "i": "1", "j": "1", "normal": "1", "overlap": "m", "contact_point": "m",
    "normal_force": "N", "tangential_force": "N", "force": "N",
}
_GRIDS = ("walls", "contacts")
# free space kept besides a frame: HDF5's metadata grows in blocks, and the XDMF file comes last
_MARGIN_BYTES = 256 * 1024
_DATASET_OVERHEAD = 2048  # object header, attributes and B-tree share per dataset (estimate)


class SnapshotWriter:
    """Particle snapshots to HDF5, one group per frame, plus an XDMF sidecar (module docstring).

    In 2-D (``dim=2``) vectors are given as N x 2 and padded with zeros, since XDMF XYZ geometry
    and Vector attributes need three components. The files are created with the first frame, so
    that a run refused before it starts leaves none; the XDMF file is written on close().
    ``failure``: None, or why the snapshots stopped (their files are then removed).
    """

    def __init__(self, path_h5: str | os.PathLike[str], dim: int):
        if dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3, got {dim}")
        self.path = Path(path_h5)
        self.xdmf_path = self.path.with_suffix(".xdmf")
        self.dim = dim
        self.failure: str | None = None
        self.frame_bytes = 0  # the largest growth of the file by one frame so far
        self._file: h5py.File | None = None
        self._closed = False
        self._previous: dict[str, dict[str, Any]] = {}
        # per grid, what each frame holds: (name, time, {dataset: (path, shape, dtype)}), so
        # that the XDMF file is written without reading the HDF5 file back (fast for many
        # frames, and independent of the file's state)
        self._index: dict[str, list[tuple[str, float, dict[str, tuple]]]] = {
            grid: [] for grid in ("frames", *_GRIDS)}

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

    # ---- checks ----------------------------------------------------------------------------
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

    def _cell_grid(self, grid: str, data: dict[str, Any]) -> dict[str, np.ndarray]:
        """The arrays of a walls or contacts grid, checked: points, cells, per-cell fields."""
        if "points" not in data or "cells" not in data:
            raise ValueError(f"{grid}: needs 'points' and 'cells'")
        points = np.asarray(data["points"], np.float64)
        points = self._per_particle(f"{grid}.points", points, len(points))
        cells = np.asarray(data["cells"], np.int64)
        if cells.ndim != 2 or cells.shape[1] not in (2, 3):
            raise ValueError(f"{grid}.cells: shape {cells.shape}, expected (C, 2) segments or "
                             "(C, 3) triangles")
        if len(cells) and (cells.min() < 0 or cells.max() >= len(points)):
            raise ValueError(f"{grid}.cells: indices outside the {len(points)} points")
        arrays = {"points": points, "cells": cells}
        for name, value in data.items():
            if name not in arrays:
                arrays[name] = self._per_particle(f"{grid}.{name}", value, len(cells))
        return arrays

    def _room(self, nbytes: int) -> None:
        """Raise OSError where the disk has not room for a frame of about ``nbytes``."""
        need = 2 * max(nbytes, self.frame_bytes) + _MARGIN_BYTES
        free = self.free_bytes()
        if free is not None and free < need:
            raise OSError(f"disk full: {format_bytes(free)} free, a frame needs about "
                          f"{format_bytes(max(nbytes, self.frame_bytes))}")

    def free_bytes(self) -> int | None:
        """Free space [B] on the snapshot file's disk (None where the system cannot say)."""
        return free_bytes(self.path)

    # ---- writing ---------------------------------------------------------------------------
    def write(self, time: float, position: Any, radius: Any, velocity: Any, *,
              walls: dict[str, Any] | None = None, contacts: dict[str, Any] | None = None,
              **fields: Any) -> None:
        """Append one frame at ``time`` (s). Extra fields are arrays of shape (N,) or (N, dim).

        ``walls``, ``contacts``: {"points": (P, dim), "cells": (C, 2 or 3), per-cell fields of
        shape (C,) or (C, dim)}, written as grids of their own at the same time. After a
        failure (``failure``) a write does nothing.
        """
        if self._closed:
            raise ValueError("SnapshotWriter is closed")
        if self.failure is not None:
            return
        if self._file is None:
            try:
                self._room(0)
                self._open()
            except (OSError, RuntimeError) as exc:
                self._abandon(exc)
                return
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
        grids = {grid: self._cell_grid(grid, data)
                 for grid, data in (("walls", walls), ("contacts", contacts)) if data is not None}

        nbytes = sum(a.nbytes + _DATASET_OVERHEAD for a in arrays.values())
        nbytes += sum(a.nbytes + _DATASET_OVERHEAD for g in grids.values() for a in g.values())
        try:
            self._room(nbytes)
            before = self.path.stat().st_size
            name = f"{len(self._index['frames']):06d}"
            self._write_group(self._frames, name, arrays, time)
            for grid, grid_arrays in grids.items():
                parent = self._file.require_group(grid)
                self._write_group(parent, name, grid_arrays, time, reuse=grid)
            # flushed per frame so that a crashed run still leaves readable frames
            self._file.flush()
            self.frame_bytes = max(self.frame_bytes, self.path.stat().st_size - before)
        except (OSError, RuntimeError) as exc:
            self._abandon(exc)

    def _write_group(self, parent: h5py.Group, name: str, arrays: dict[str, np.ndarray],
                     time: float, reuse: str | None = None) -> None:
        group = parent.create_group(name)
        group.attrs["time"] = float(time)
        previous = self._previous.get(reuse, {}) if reuse else {}
        held = {}
        for key, array in arrays.items():
            held[key] = (f"{group.name}/{key}", array.shape, array.dtype)
            if key in previous and np.array_equal(previous[key][0], array) \
                    and previous[key][0].dtype == array.dtype:
                group[key] = previous[key][1]  # a hard link: stored once
                continue
            dataset = group.create_dataset(key, data=array)
            if key in SNAPSHOT_UNITS:
                dataset.attrs["units"] = SNAPSHOT_UNITS[key]
            if reuse:
                previous[key] = (array, dataset)
        if reuse:
            self._previous[reuse] = previous
        self._index[parent.name.strip("/")].append((name, float(time), held))

    def _abandon(self, exc: BaseException) -> None:
        """Stop the snapshots: close and remove their files, keep why in ``failure``."""
        reason = " ".join(str(exc).split()) or type(exc).__name__
        if isinstance(exc, OSError) and exc.errno is not None:
            reason = f"{os.strerror(exc.errno)}"
        self.failure = f"{self.path}: {reason}"
        self._previous = {}
        if self._file is not None:
            try:
                self._file.close()
            except Exception:  # noqa: BLE001 - the file is removed anyway
                pass
            self._file = None
        self.path.unlink(missing_ok=True)
        self.xdmf_path.unlink(missing_ok=True)

    def discard(self) -> None:
        """Remove the files written so far and write no more (a run refused after its first
        frame)."""
        self._abandon(OSError("discarded"))
        self.failure = None
        self._closed = True

    def close(self) -> None:
        self._closed = True
        if self._file is None:
            return
        try:
            self._write_xdmf()
        except OSError as exc:  # e.g. the disk filled at the last moment
            self._abandon(exc)
            return
        finally:
            if self._file is not None:
                self._file.close()
                self._file = None

    # ---- the XDMF sidecar ------------------------------------------------------------------
    def _write_xdmf(self) -> None:
        from ..io import atomic_target  # here: millsim.io re-exports this module

        root = ET.Element("Xdmf", Version="3.0")
        domain = ET.SubElement(root, "Domain")
        series = ET.SubElement(
            domain, "Grid", Name="particles", GridType="Collection", CollectionType="Temporal"
        )
        for frame_name, time, held in self._index["frames"]:
            grid = ET.SubElement(series, "Grid", Name=f"frame_{frame_name}", GridType="Uniform")
            ET.SubElement(grid, "Time", Value=repr(time))
            ET.SubElement(
                grid,
                "Topology",
                TopologyType="Polyvertex",
                NumberOfElements=str(held["radius"][1][0]),
                NodesPerElement="1",
            )
            if self._empty(grid, held["radius"]):
                continue
            geometry = ET.SubElement(grid, "Geometry", GeometryType="XYZ")
            self._data_item(geometry, held["position"])
            for name, dataset in held.items():
                if name == "position":
                    continue
                kind = "Scalar" if len(dataset[1]) == 1 else "Vector"
                attribute = ET.SubElement(
                    grid, "Attribute", Name=name, AttributeType=kind, Center="Node"
                )
                self._data_item(attribute, dataset)
        for grid_name in _GRIDS:
            if self._index[grid_name]:
                self._cell_series(domain, grid_name)

        ET.indent(root)
        with atomic_target(self.xdmf_path) as tmp:
            ET.ElementTree(root).write(tmp, encoding="utf-8", xml_declaration=True)

    def _cell_series(self, domain: ET.Element, grid_name: str) -> None:
        """A temporal collection of unstructured grids: triangles or segments, with per-cell
        attributes."""
        series = ET.SubElement(
            domain, "Grid", Name=grid_name, GridType="Collection", CollectionType="Temporal"
        )
        for frame_name, time, held in self._index[grid_name]:
            _, (count, width), _ = held["cells"]
            grid = ET.SubElement(series, "Grid", Name=f"{grid_name}_{frame_name}",
                                 GridType="Uniform")
            ET.SubElement(grid, "Time", Value=repr(time))
            topology = ET.SubElement(
                grid, "Topology", TopologyType="Triangle" if width == 3 else "Polyline",
                NumberOfElements=str(count), NodesPerElement=str(width),
            )
            if self._empty(grid, held["cells"]):
                continue
            self._data_item(topology, held["cells"])
            geometry = ET.SubElement(grid, "Geometry", GeometryType="XYZ")
            self._data_item(geometry, held["points"])
            for name, dataset in held.items():
                if name in ("points", "cells"):
                    continue
                kind = "Scalar" if len(dataset[1]) == 1 else "Vector"
                attribute = ET.SubElement(
                    grid, "Attribute", Name=name, AttributeType=kind, Center="Cell"
                )
                self._data_item(attribute, dataset)

    @staticmethod
    def _empty(grid: ET.Element, dataset: tuple) -> bool:
        """Give a grid without cells (no contact at that frame) one point and nothing else:
        VTK's XDMF reader (ParaView's) fails on a data item of size 0 and drops the block."""
        if dataset[1][0]:
            return False
        geometry = ET.SubElement(grid, "Geometry", GeometryType="XYZ")
        ET.SubElement(geometry, "DataItem", Dimensions="1 3", NumberType="Float", Precision="8",
                      Format="XML").text = "0 0 0"
        return True

    def _data_item(self, parent: ET.Element, dataset: tuple) -> None:
        """A DataItem naming a dataset (path, shape, dtype) of the HDF5 file."""
        path, shape, dtype = dataset
        item = ET.SubElement(
            parent,
            "DataItem",
            Dimensions=" ".join(map(str, shape)),
            NumberType=_XDMF_NUMBER_TYPES[dtype.kind, dtype.itemsize],
            Precision=str(dtype.itemsize),
            Format="HDF",
        )
        # relative file name: the XDMF reader resolves it against the XDMF file's directory;
        # a stored-once dataset (a static wall) is named by this frame's link to it
        item.text = f"{self.path.name}:{path}"
