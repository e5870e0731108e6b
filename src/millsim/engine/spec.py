"""Which engine options a scene uses: the switches the step loop is compiled with.

The contact law, the breakage model and the fluid are objects handed to the Simulation (they bring
their own hooks and state); the spec holds the rest of the compile-time shape.
"""

from dataclasses import dataclass

from .integrators import INTEGRATORS

CONVENTIONS = ("clipped", "unclipped")
FORCE_SUMS = ("records", "colour")

_RUNNERS = {}


@dataclass(frozen=True)
class PhysicsSpec:
    """The compile-time shape of a simulation (besides its models).

    Attributes:
        dim: 2 (disks in the xy plane) or 3 (spheres).
        integrator: ``verlet`` (velocity Verlet) or ``gear`` (6-value Gear predictor-corrector).
        rolling_friction: EDEM "standard" constant directional rolling torque (a law with a
            rolling-friction coefficient: Hertz-Mindlin).
        convention: end of a contact. ``clipped`` (default): the normal force never pulls and the
            contact ends when it reaches zero; ``unclipped``: the force may pull and the contact
            ends at zero overlap (EDEM, LIGGGHTS ``limitForce off``, MercuryDPM; for cross-code
            comparisons). Either way the damping is set so that a head-on collision returns the
            asked restitution (each law's ``row``, ``models.contact``).
        gravity, walls, bodies, periodic: whether those terms exist at all.
        bounded_walls: frustum and annulus walls (engine.kinematics) compiled in (needs walls).
        translating_walls: walls that translate at a constant velocity compiled in (needs walls).
        mesh_walls: triangle-mesh walls (engine.mesh) compiled in (needs walls; 3D).
        ramped_walls: walls whose omega and velocity ramp up from rest (a wall's ``ramp``,
            engine.kinematics) compiled in (needs walls).
        normal_force_sum: keep each particle's sum of contact normal forces (pressure maps,
            force chains).
        energy_audit: integrate the power dissipated by contact damping, by the tangential force
            (centre slip and rotational slip) and by lubrication (normal, tangential).
        force_sum: how the pair contacts become particle forces, both the same numbers on any
            thread count. ``records`` (default): each slot writes a record, and each particle
            sums its records in a fixed order (what breakage models and lubrication read).
            ``colour``: the list's slots are coloured so that no two of a colour share a
            particle, and each contact is added straight into both particles' sums, colour by
            colour (faster; other rounding than ``records``; no breakage model, fluid or energy
            audit; docs/engine.md, "Force sums").
        collision_spectra: record each collision's dissipated normal and tangential energy (the
            energy audit's contact terms over the contact's life) in log-spaced bins per contact
            type when the contact ends (engine.spectra; needs energy_audit).
    """

    dim: int = 3
    integrator: str = "verlet"
    rolling_friction: bool = False
    convention: str = "clipped"
    gravity: bool = True
    walls: bool = False
    bounded_walls: bool = False
    translating_walls: bool = False
    mesh_walls: bool = False
    ramped_walls: bool = False
    bodies: bool = False
    periodic: bool = False
    normal_force_sum: bool = False
    energy_audit: bool = False
    force_sum: str = "records"
    collision_spectra: bool = False

    def __post_init__(self):
        if self.dim not in (2, 3):
            raise ValueError(f"dim: must be 2 or 3, got {self.dim}")
        if self.integrator not in INTEGRATORS:
            raise ValueError(f"integrator: must be one of {INTEGRATORS}, got {self.integrator!r}")
        if self.convention not in CONVENTIONS:
            raise ValueError(f"convention: must be one of {CONVENTIONS}, got {self.convention!r}")
        if self.bounded_walls and not self.walls:
            raise ValueError("bounded_walls: needs walls=True")
        if self.translating_walls and not self.walls:
            raise ValueError("translating_walls: needs walls=True")
        if self.ramped_walls and not self.walls:
            raise ValueError("ramped_walls: needs walls=True")
        if self.mesh_walls and not (self.walls and self.dim == 3):
            raise ValueError("mesh_walls: needs walls=True and dim=3")
        if self.force_sum not in FORCE_SUMS:
            raise ValueError(f"force_sum: must be one of {FORCE_SUMS}, got {self.force_sum!r}")
        if self.force_sum == "colour" and self.energy_audit:
            raise ValueError("force_sum: 'colour' keeps no slot records, which energy_audit "
                             "reads; use 'records'")
        if self.collision_spectra and not self.energy_audit:
            raise ValueError("collision_spectra: needs energy_audit=True (the spectra bin the "
                             "audit's dissipation per contact)")

    @property
    def clip_normal(self):
        return self.convention == "clipped"


def chunk_runner(spec, law, breakage=None, fluid=None):
    """The compiled step loop for a spec and model kinds (built once per process, cached on disk
    by numba)."""
    key = (spec, law.name, breakage.name if breakage else "", fluid.name if fluid else "")
    if key not in _RUNNERS:
        from .loop import build_chunk_runner

        _RUNNERS[key] = build_chunk_runner(spec, law, breakage, fluid)
    return _RUNNERS[key]
