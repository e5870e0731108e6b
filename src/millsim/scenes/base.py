"""What every scene shares: declared parameters with units and ranges, and the scene registry.

A scene is a declaration: its parameters, and ``build(values)``, which makes a
:class:`~millsim.scenes.driver.Case` (the Simulation with the physics it needs, what it records,
when it is done, its summaries); :func:`~millsim.scenes.driver.drive` runs every scene the same
way. Parameters are declared once, with type, default, unit and allowed range, so the command
line, the Snakemake schema and the case file all describe the same thing, and bad input is refused
with the key and its range before any work.
"""

import math
from dataclasses import dataclass, field
from typing import Any, Callable

from ..engine import StepPolicy

from ..util.validation import check_range


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
            try:
                value = int(float(raw)) if float(raw).is_integer() else None
            except (TypeError, ValueError):
                value = None
            if value is None:
                raise ValueError(f"{self.name}: must be an integer, got {raw!r}")
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


@dataclass
class RunContext:
    """How a run reports and runs: progress lines on stderr, optional particle snapshots (HDF5 +
    XDMF), the numba threads of the compiled loop (None: all), and the wall-time cadence of the
    checkpoints a run with an output file saves beside it (driver.Checkpoint; 0: none)."""

    progress: bool = False
    snapshots: Any = None  # a millsim.io.SnapshotWriter, or None
    threads: int = None
    checkpoint_every: float = 0.0  # [s]

    def snapshot(self, sim):
        """Write one frame of ``sim`` if snapshots were requested."""
        if self.snapshots is None:
            return
        p = sim.particles
        self.snapshots.write(sim.time, p.x, p.radius, p.v, angular_velocity=p.w,
                             kinematic=(p.body >= 0).astype("int32"))


REGISTRY: dict = {}


def register(scene: Scene) -> Scene:
    REGISTRY[scene.name] = scene
    return scene


def get_scene(name: str) -> Scene:
    from . import load_all

    load_all()
    if name not in REGISTRY:
        raise ValueError(f"scene: unknown scene {name!r}; available: {', '.join(sorted(REGISTRY))}")
    return REGISTRY[name]
