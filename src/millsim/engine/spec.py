"""Which physics a scene uses: the switches that decide what the step loop is compiled with."""

from dataclasses import dataclass
from functools import lru_cache

from .contact import LAW_IDS

INTEGRATORS = ("verlet", "gear")
FRACTURE_MODELS = ("", "weibull", "tavares")


@dataclass(frozen=True)
class PhysicsSpec:
    """The compile-time shape of a simulation.

    Attributes:
        dim: 2 (disks in the xy plane) or 3 (spheres).
        contact_law: ``linear_hw`` (seed 000), ``linear_history`` (seed 004) or ``hertz_mindlin``
            (seed 002).
        integrator: ``verlet`` (velocity Verlet) or ``gear`` (6-value Gear predictor-corrector).
        rolling_friction: EDEM "standard" constant directional rolling torque (Hertz-Mindlin only).
        clip_normal: normal force never attractive. Only analytic verification of the textbook
            "contact ends at zero overlap" convention turns this off.
        gravity, walls, bodies, periodic: whether those terms exist at all.
        normal_force_sum: keep each particle's sum of contact normal forces (pressure maps,
            force chains).
        fracture: "" (none), "weibull" (seed 000: fracture trial per contact event at its peak
            force, twin-fragment relief; needs the linear_hw law) or "tavares" (seed 002: loading
            work per stressing event against a damaged fracture energy; needs hertz_mindlin).
        lubrication: pairwise Jeffrey-Onishi lubrication between near-contacting particles and
            between particles and walls (seed 004), on top of the contact law.
        energy_audit: integrate the power dissipated by contact damping, by the tangential force
            (centre slip and rotational slip) and by lubrication (normal, tangential).
    """

    dim: int = 3
    contact_law: str = "hertz_mindlin"
    integrator: str = "verlet"
    rolling_friction: bool = False
    clip_normal: bool = True
    gravity: bool = True
    walls: bool = False
    bodies: bool = False
    periodic: bool = False
    normal_force_sum: bool = False
    fracture: str = ""
    lubrication: bool = False
    energy_audit: bool = False

    def __post_init__(self):
        if self.dim not in (2, 3):
            raise ValueError(f"dim: must be 2 or 3, got {self.dim}")
        if self.contact_law not in LAW_IDS:
            raise ValueError(f"contact_law: must be one of {sorted(LAW_IDS)}, got {self.contact_law!r}")
        if self.integrator not in INTEGRATORS:
            raise ValueError(f"integrator: must be one of {INTEGRATORS}, got {self.integrator!r}")
        if self.fracture not in FRACTURE_MODELS:
            raise ValueError(f"fracture: must be one of {FRACTURE_MODELS}, got {self.fracture!r}")
        if self.fracture == "weibull" and self.contact_law != "linear_hw":
            raise ValueError("fracture: 'weibull' (seed 000) goes with contact_law 'linear_hw'")
        if self.fracture == "tavares" and self.contact_law != "hertz_mindlin":
            raise ValueError("fracture: 'tavares' (seed 002) goes with contact_law 'hertz_mindlin'")
        if self.rolling_friction and self.contact_law != "hertz_mindlin":
            raise ValueError("rolling_friction: only available with contact_law 'hertz_mindlin'")


@lru_cache(maxsize=None)
def chunk_runner(spec: PhysicsSpec):
    """The compiled step loop for ``spec`` (built once per process, cached on disk by numba)."""
    from .loop import build_chunk_runner

    return build_chunk_runner(spec)
