"""What every scene shares: declared parameters with units and ranges, and the scene registry.

A scene is a declaration: its parameters, and ``build(values)``, which makes a
:class:`~millsim.scenes.driver.Case` (the Simulation with the physics it needs, what it records,
when it is done, its summaries); :func:`~millsim.scenes.driver.drive` runs every scene the same
way. Parameters are declared once, with type, default, unit and allowed range, so the command
line, the Snakemake schema and the case file all describe the same thing, and bad input is refused
with the key and its range before any work.
"""

import math
import numbers
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

from ..engine import BYTES_PER_PARTICLE, StepPolicy
from ..util.memory import check_memory
from ..util.validation import check_range

# Integer parameters are stored as 64-bit netCDF attributes; a float holds every integer only up
# to 2^53, beyond which one given as a float (1e17, 2.0**60) may already have been rounded.
INT64_MAX = 2**63 - 1
FLOAT_EXACT = 2**53


@dataclass(frozen=True)
class Param:
    name: str
    default: Any
    doc: str
    units: str = "1"
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple = ()
    sweepable = True  # a list of values in the study config sweeps it (the walls' is one value)

    @property
    def kind(self):
        return type(self.default)

    def parse(self, raw):
        """Convert a command-line string (or a value) and check it against the declared range."""
        kind = self.kind
        if kind is bool:
            if isinstance(raw, str):
                low = raw.strip().lower()
                if low not in ("true", "false", "1", "0", "yes", "no"):
                    raise ValueError(f"{self.name}: must be true or false, got {raw!r}")
                value = low in ("true", "1", "yes")
            else:
                value = bool(raw)
        elif kind is int:
            value = self._integer(raw)
        elif kind is float:
            try:
                value = float(raw)
            except (TypeError, ValueError):
                raise ValueError(f"{self.name}: must be a number, got {raw!r}") from None
        else:
            value = str(raw)
        if self.choices and value not in self.choices:
            raise ValueError(f"{self.name}: must be one of {list(self.choices)}, got {value!r}")
        if kind in (int, float) and (self.lo is not None or self.hi is not None):
            check_range(self.name, value, self.lo, self.hi, self.lo_open, self.hi_open)
        if kind is float and not math.isfinite(value):
            raise ValueError(f"{self.name}: must be finite, got {value!r}")
        return value

    def _integer(self, raw):
        """An integer exactly as given: digits are read as they are, a number only where a float
        is exact; and within 64 bits."""
        if isinstance(raw, numbers.Integral):
            value = int(raw)
        elif isinstance(raw, str) and re.fullmatch(r"\s*[+-]?\d+\s*", raw):
            value = int(raw)
        else:
            try:
                number = float(raw)
            except (TypeError, ValueError):
                number = math.nan
            if not number.is_integer():
                raise ValueError(f"{self.name}: must be an integer, got {raw!r}")
            if abs(number) >= FLOAT_EXACT:
                raise ValueError(f"{self.name}: {raw!r} is beyond 2^53, where a floating-point "
                                 "number may be rounded; write the integer with digits")
            value = int(number)
        if not -INT64_MAX - 1 <= value <= INT64_MAX:
            raise ValueError(f"{self.name}: {value} is outside the allowed range "
                             f"[{-INT64_MAX - 1}, {INT64_MAX}] (64-bit integers)")
        return value

    def describe(self):
        if self.choices:
            allowed = "|".join(map(str, self.choices))
        elif self.lo is not None or self.hi is not None:
            left = "(" if self.lo_open or self.lo is None else "["
            right = ")" if self.hi_open or self.hi is None else "]"
            lo = "-inf" if self.lo is None else f"{self.lo:g}"
            hi = "inf" if self.hi is None else f"{self.hi:g}"
            allowed = f"{left}{lo}, {hi}{right}"
        else:
            allowed = self.kind.__name__
        return f"{self.name} = {self.default!r} [{self.units}] {allowed}: {self.doc}"


@dataclass(frozen=True)
class Scene:
    name: str
    summary: str
    params: tuple
    build: Callable  # build(values: dict) -> driver.Case
    checks: tuple = field(default=())  # callables(values) raising ValueError on inconsistent combos
    # the materials a wall from the config may name (values -> names; scenes/config_walls.py);
    # None: the scene takes no walls from the config, for the reason ``no_walls``
    wall_materials: Callable = None
    no_walls: str = "it names no materials for them (Scene.wall_materials)"

    def run(self, values, ctx=None, out=None):
        """Drive one case with resolved ``values`` (see :func:`~millsim.scenes.driver.drive`)."""
        from .driver import drive

        return drive(self, values, ctx or RunContext(), out)

    def resolve(self, overrides: dict) -> dict:
        """Defaults overridden by ``overrides`` (strings or values), each parsed and range-checked."""
        known = {p.name: p for p in self.params}
        for key in overrides:
            if key not in known:
                raise ValueError(f"{key}: unknown parameter of scene {self.name!r}; known: "
                                 f"{', '.join(sorted(known))}")
        values = {p.name: p.parse(overrides[p.name]) if p.name in overrides else p.default
                  for p in self.params}
        if "walls" in values:
            from .config_walls import check_wall_materials

            check_wall_materials(self, values)
        for check in self.checks:
            check(values)
        return values


# Particle size and material constants shared by the engine-level scenes (the LIGGGHTS baseline's).
SOLID_PARAMS = (
    Param("radius", 1e-3, "particle radius", "m", 0.0, lo_open=True),
    Param("density", 2500.0, "particle density", "kg m-3", 0.0, lo_open=True),
    Param("youngs_modulus", 5e6, "Young's modulus (hertz_mindlin)", "Pa", 0.0, lo_open=True),
    Param("poisson_ratio", 0.3, "Poisson ratio (hertz_mindlin)", "1", -1.0, 0.5, True, True),
    Param("restitution", 0.5, "coefficient of restitution (linear_history, hertz_mindlin)", "1", 0.0, 1.0,
          lo_open=True),
    Param("friction", 0.3, "sliding friction coefficient", "1", 0.0),
)

# End of a contact: the restitution is what a head-on collision returns in either convention.
CONVENTION_PARAM = Param(
    "convention", "clipped", "clipped: the normal force never pulls (physical); unclipped: it may "
    "pull, the contact ends at zero overlap (EDEM, LIGGGHTS limitForce off, MercuryDPM)",
    choices=("clipped", "unclipped"))


# Every scene takes the engine's time-step policy (engine.timestep): a factor on the recommended
# step of the particles present, or an absolute step.
TIME_STEP_PARAMS = (
    Param("dt_factor", 1.0, "time step as a multiple of the engine's recommended step (followed as "
          "fragments appear); the limit is 5x the recommended step for contacts", "1", 0.0,
          lo_open=True),
    Param("dt", 0.0, "absolute time step; 0 = dt_factor x the recommended step", "s", 0.0),
)


def step_policy(values, **kw):
    """The engine's StepPolicy from a scene's TIME_STEP_PARAMS (and impact_speed etc. in kw)."""
    return StepPolicy(dt=values["dt"] or None, dt_factor=values["dt_factor"], **kw)


def check_particle_memory(key, count, others=0):
    """Refuse, naming ``key``, a particle count whose engine arrays alone (with ``others``
    particles besides, walls made of particles) would not fit in the memory the run may use
    (util.memory: RAM, cgroup, SLURM, --max-memory); a MemoryError or the OOM killer later,
    after the placement, otherwise."""
    check_memory(key, count, lambda n: (n + others) * BYTES_PER_PARTICLE, "particles",
                 f"{BYTES_PER_PARTICLE} B each")


class DriveMark(NamedTuple):
    """What a drive had supplied up to ``time``: a record's interval-mean torque and power are the
    differences from the last mark over the time between."""

    angular_impulse: float  # about the drive's axis [N m s]
    work: float  # [J]
    time: float  # [s]


def record_steps(values, dt, key="record_interval"):
    """Steps between records of the interval ``values[key]`` [s] at the time step ``dt``.

    An interval below the step is refused: it would record (and snapshot) every step, gigabytes
    for a quick case.
    """
    interval = values[key]
    if interval < dt:
        raise ValueError(f"{key}: {interval:g} s is below the time step {dt:.4g} s; allowed "
                         f"[{dt:.4g}, inf) s")
    return int(round(interval / dt))


@dataclass
class RunContext:
    """How a run reports and runs: progress lines on stderr, optional particle snapshots (HDF5 +
    XDMF), the numba threads of the compiled loop (None: all), and the wall-time cadence of the
    checkpoints a run with an output file saves beside it (driver.Checkpoint; 0: none)."""

    progress: bool = False
    snapshots: Any = None  # a millsim.io.SnapshotWriter, or None
    threads: int = None
    checkpoint_every: float = 0.0  # [s]
    snapshot_contacts: bool = False  # the pair contacts and their forces in every frame too
    _walls: Any = field(default=None, repr=False)  # the WallTessellator of the run

    def snapshot(self, sim):
        """Write one frame of ``sim`` (particles, walls, contacts if asked) if snapshots were
        requested; a frame that does not fit on the disk stops them with a warning (the run
        goes on)."""
        writer = self.snapshots
        if writer is None or writer.failure is not None:
            return
        from ..engine.wall_geometry import WallTessellator

        if self._walls is None:
            self._walls = WallTessellator()
        p = sim.particles
        writer.write(sim.time, p.x, p.radius, p.v, walls=self._walls(sim),
                     contacts=_contact_grid(sim) if self.snapshot_contacts else None,
                     angular_velocity=p.w, kinematic=(p.body >= 0).astype("int32"),
                     particle_id=sim.particle_ids, parent_id=sim.parent_ids)
        if writer.failure is not None:
            print(f"millsim: warning: --snapshots: {writer.failure}; snapshots stopped and their "
                  "files removed, the run goes on", file=sys.stderr, flush=True)

    def check_snapshot_space(self, values):
        """After the first frame: refuse snapshots that would not fit on their disk (frames x
        the first frame's size, where the scene's parameters give the number of frames), warn
        above SNAPSHOT_WARN_BYTES."""
        writer = self.snapshots
        if writer is None or writer.failure is not None or not writer.frame_bytes:
            return
        counted = _snapshot_frames(values)
        if counted is None:
            return
        from ..util.disk import format_bytes

        frames, how = counted
        total, free = frames * writer.frame_bytes, writer.free_bytes()
        what = (f"--snapshots: about {format_bytes(total)} for {frames} frames ({how}, "
                f"{format_bytes(writer.frame_bytes)} each)")
        if free is not None and total > free:
            writer.discard()
            raise ValueError(f"{what}, more than the {format_bytes(free)} free on the disk of "
                             f"{writer.path}; record less often or write them elsewhere")
        if total > SNAPSHOT_WARN_BYTES:
            print(f"millsim: warning: {what}", file=sys.stderr, flush=True)


SNAPSHOT_WARN_BYTES = 10**9
# (frames, how counted) from a scene's parameters: duration or its bound over the record cadence
_FRAME_COUNTS = (("duration", "record_interval"), ("max_time", "record_interval"),
                 ("steps", "record_every"), ("revolutions", "records_per_revolution"))


def _snapshot_frames(values):
    for span, cadence in _FRAME_COUNTS:
        if span in values and cadence in values and values[cadence] > 0:
            if cadence == "records_per_revolution":
                frames = values[span] * values[cadence]
            else:
                frames = values[span] / values[cadence]
            return int(frames) + 1, f"{span} = {values[span]:g} / {cadence} = {values[cadence]:g}"
    return None


def _contact_grid(sim):
    """The touching pairs of ``sim`` as a grid of segments between the particles' centres (the
    partner's by the minimum image in a periodic box), with the contact forces per segment."""
    import numpy as np

    from ..engine.wall_geometry import pair_contact_forces

    c = pair_contact_forces(sim)
    i, j = c.pop("i"), c.pop("j")
    x = sim.particles.x
    points = np.empty((2 * len(i), 3))
    points[0::2] = x[i]
    points[1::2] = x[i] - sim.separation(i, j)
    return {"points": points, "cells": np.arange(2 * len(i)).reshape(-1, 2), "i": i, "j": j,
            "force": c["normal_force"] + c["tangential_force"], **c}


REGISTRY: dict = {}


def register(scene: Scene) -> Scene:
    """Register ``scene``, with the ``walls`` parameter every scene takes (scenes/config_walls.py)
    added to its parameters."""
    from .config_walls import WALLS_PARAM

    if "walls" not in {p.name for p in scene.params}:
        scene = replace(scene, params=(*scene.params, WALLS_PARAM))
    REGISTRY[scene.name] = scene
    return scene


def get_scene(name: str) -> Scene:
    from . import load_all

    load_all()
    if name not in REGISTRY:
        raise ValueError(f"scene: unknown scene {name!r}; available: {', '.join(sorted(REGISTRY))}")
    return REGISTRY[name]
