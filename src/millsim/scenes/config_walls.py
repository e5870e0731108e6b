"""Walls from the config: the ``walls`` parameter every scene takes (docs/walls.md, "Walls from
the config").

Its value is a list of wall declarations exactly as the wall registry (engine.walls) parses them,
given as YAML or JSON text, as the path of a YAML file holding that list, or as a list (the
Snakemake config). The walls are added to the scene's own. The value is checked when the
parameters are parsed, before any case is built: every entry through the registry (kind, keys,
values; a mesh file must be a closed, outward-oriented solid), the types of its keys, lengths
beyond ``MAX_LENGTH`` (a unit slip: CAD in millimetres read as metres), and, by the scene, its
materials against the scene's (``Scene.wall_materials``).
"""

import math
from dataclasses import dataclass, replace
from numbers import Real
from pathlib import Path

import numpy as np
import yaml

from ..engine import PhysicsSpec
from ..engine.mesh_io import read_mesh
from ..engine.walls import BY_NAME, wall_table
from .base import Param

# a wall longer or wider than this is taken for a unit slip, not a mill [m]
MAX_LENGTH = 100.0
_VECTORS = {"point": 3, "normal": 3, "axis": 3, "velocity": 3, "start": 2, "end": 2}
_NUMBERS = {"omega", "ramp", "radius", "inner_radius", "ring_radius", "tube_radius", "scale"}
_LENGTHS = ("radius", "inner_radius", "ring_radius", "tube_radius")
_STRINGS = {"kind", "material", "file"}


@dataclass(frozen=True)
class WallsParam(Param):
    """The ``walls`` parameter: a list of wall declarations (not a sweep when a list)."""

    sweepable = False

    def parse(self, raw):
        walls = load_walls(raw)
        check_walls(walls)
        return walls

    def describe(self):
        return f"{self.name} = [] [SI] list of walls (YAML text or file): {self.doc}"


WALLS_PARAM = WallsParam(
    "walls", [], "walls added to the scene's own: a list of {kind, material, geometry keys, "
    "omega, velocity, ramp} as docs/walls.md declares them, a mesh with file and scale",
    "SI")


def load_walls(raw):
    """The list of wall mappings of ``raw``: YAML/JSON text, a YAML file's path, or a list."""
    if isinstance(raw, str):
        text = raw.strip()
        path = Path(text)
        if path.suffix.lower() in (".yaml", ".yml", ".json") or (text and path.is_file()):
            if not path.is_file():
                raise ValueError(f"walls: {text}: no such file")
            text, where = path.read_text(), f"walls: {path}"
        else:
            where = "walls"
        try:
            raw = yaml.safe_load(text) if text else []
        except yaml.YAMLError as exc:
            reason = " ".join(str(exc).split())[:160]
            raise ValueError(f"{where}: not YAML ({reason})") from None
        if isinstance(raw, str):
            raise ValueError(f"walls: {raw!r} is neither a file nor a YAML list of walls")
    if raw is None:
        raw = []
    if not isinstance(raw, (list, tuple)):
        raise ValueError(f"walls: must be a list of walls ({{kind: ..., material: ...}}), got "
                         f"a {type(raw).__name__}")
    for k, wall in enumerate(raw):
        if not isinstance(wall, dict):
            raise ValueError(f"walls[{k}]: must be a mapping {{kind: ..., material: ...}}, got "
                             f"{wall!r}")
    return [dict(wall) for wall in raw]


def _is_number(value):
    return isinstance(value, Real) and not isinstance(value, bool)


def _check_types(key, wall):
    """One line naming the key for a value of the wrong shape (the registry checks its range)."""
    kind = BY_NAME.get(wall.get("kind"))
    for name in sorted(set(wall) & (kind.keys if kind else set())):
        value = wall[name]
        if name in _VECTORS:
            size = _VECTORS[name]
            ok = isinstance(value, (list, tuple)) and len(value) == size and \
                all(_is_number(x) and math.isfinite(x) for x in value)
            what = f"{size} finite numbers"
        elif name in _NUMBERS:
            ok, what = _is_number(value) and math.isfinite(value), "a finite number"
        elif name in _STRINGS:
            ok, what = isinstance(value, str), "a string"
        else:
            continue
        if not ok:
            raise ValueError(f"{key}.{name}: must be {what}, got {value!r}")
        if name in _LENGTHS and abs(value) > MAX_LENGTH:
            raise ValueError(f"{key}.{name}: {value:g} m is beyond {MAX_LENGTH:g} m; lengths are "
                             "in metres")


class _Probe:
    """What the wall registry reads of a Simulation, to parse declarations before any case:
    every wall switch on, any material accepted (the scene checks the names)."""

    def __init__(self, dim=3):
        self.spec = PhysicsSpec(dim=dim, walls=True, bounded_walls=True, translating_walls=True,
                                mesh_walls=dim == 3, ramped_walls=True)
        self._mesh_geometry = []

    def material_index(self, name):
        return 0


def check_walls(walls, dim=3):
    """Refuse, in one line naming the key, a wall the registry would refuse in a run of
    dimension ``dim``, or a mesh wider than MAX_LENGTH (a missing ``scale``)."""
    for k, wall in enumerate(walls):
        if "material" not in wall:
            raise ValueError(f"walls[{k}].material: required (a material of the scene)")
        _check_types(f"walls[{k}]", wall)
        if wall.get("kind") == "mesh" and "file" in wall:
            try:  # read here to name the key (the registry's read names only the file)
                read_mesh(wall["file"], wall.get("scale", 1.0))
            except ValueError as exc:
                raise ValueError(f"walls[{k}].file: {exc} (a path from the working directory)"
                                 ) from None
    probe = _Probe(dim)
    wall_table(probe, walls)
    for k, frame, _, _ in probe._mesh_geometry:
        span = float(np.ptp(frame, axis=0).max())
        if span > MAX_LENGTH:
            raise ValueError(f"walls[{k}].scale: the mesh spans {span:g} m after scale "
                             f"{walls[k].get('scale', 1.0):g}; CAD in mm needs scale: 0.001")


def check_wall_materials(scene, values):
    """Refuse walls for a scene that takes none, and materials the scene's table lacks."""
    walls = values.get("walls")
    if not walls:
        return
    if scene.wall_materials is None:
        raise ValueError(f"walls: scene {scene.name!r} takes no walls from the config: "
                         f"{scene.no_walls}")
    names = tuple(scene.wall_materials(values))
    for k, wall in enumerate(walls):
        given = [("material", wall["material"])]
        given += [(f"triangle_materials[{j}]", m)
                  for j, m in enumerate(wall.get("triangle_materials") or ())]
        for key, name in given:
            if name not in names:
                raise ValueError(f"walls[{k}].{key}: {name!r} is not a material of scene "
                                 f"{scene.name!r}; available: {', '.join(names)}")


def scene_walls(values, spec, walls):
    """(spec, walls): the scene's ``walls`` with those of the config (``values["walls"]``)
    after them, so that the scene's own keep their indices, and its spec with the switches they
    need (another compiled variant, the same physics); both unchanged without them."""
    extra = values.get("walls")
    if not extra:
        return spec, walls
    if spec.dim != 3:
        check_walls(extra, spec.dim)  # what a 2D run refuses (3D kinds, turning planes, vz)
    need = {"walls": True}
    for wall in extra:
        switch = BY_NAME[wall["kind"]].switch
        if switch:
            need[switch] = True
        if any(wall.get("velocity", (0.0, 0.0, 0.0))):
            need["translating_walls"] = True
        if wall.get("ramp", 0.0) > 0.0:
            need["ramped_walls"] = True
    return replace(spec, **need), [*walls, *extra]
