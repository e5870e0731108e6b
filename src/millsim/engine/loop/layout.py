"""The loop's fixed sizes, guard codes and column layout (``Layout``), shared by its passes."""

from dataclasses import dataclass

BLOCK = 256  # particles per reduction block (fixed, so sums do not depend on the thread count)
SLOT_BASE = 8  # slot record: force on i (3), n x F_t (3), overlap, normal force
# Energy audit terms [J]: contact normal damping, tangential force x centre slip, tangential force x
# rotational slip, lubrication normal (squeeze), lubrication tangential, rolling friction. A slot
# record carries the first SLOT_AUDIT; rolling friction is booked per particle (particles.py).
N_AUDIT = 6
SLOT_AUDIT = 5
ROLLING_AUDIT = 5  # the rolling-friction term's index
AUDIT_TERMS = ("contact_normal_damping", "contact_tangential_translation",
               "contact_tangential_rotation", "lubrication_normal", "lubrication_tangential",
               "rolling_friction")
# Guard codes written to err[0]; err = [code, step, particle, partner]. With threads the particle
# recorded is whichever got there first; the Python side names a deterministic one.
# ERR_MESH_SLOTS: a particle touches more mesh triangles at once than it has history slots.
ERR_OVERLAP, ERR_NONFINITE, ERR_SPEED, ERR_MESH_SLOTS = 1, 2, 3, 4
# Collision spectra (engine.loop.spectra): per contact after the breakage model's columns, open
# (1; walls: the wall's material + 1), dissipated normal and tangential energy so far [J], and
# the last step's normal and tangential power [W] (the audit's trapezoid, per contact); per slot
# record after the audit's, the collision that ended in this step (1, normal, tangential).
SPECTRA_COLUMNS = 5
SPECTRA_SLOT = 3


@dataclass(frozen=True)
class Layout:
    """Where each model's columns sit in the contact state, wall state and slot record."""

    spring: int  # contact law's per-contact state (tangential spring)
    contact_model: int  # breakage model's per-contact columns
    wall_model: int
    slot_model: int  # breakage model's slot-record columns
    fluid: bool
    audit: bool
    implicit: bool = False  # the fluid's resistance is integrated implicitly (engine.implicit)
    spectra: bool = False  # collision spectra (PhysicsSpec.collision_spectra)

    @property
    def contact_spectra(self):  # the first spectra column of a pair's contact state
        return self.spring + self.contact_model

    @property
    def wall_spectra(self):  # the first spectra column of a wall contact's state
        return self.spring + self.wall_model

    @property
    def contact_columns(self):
        return self.contact_spectra + (SPECTRA_COLUMNS if self.spectra else 0)

    @property
    def wall_columns(self):
        return self.wall_spectra + (SPECTRA_COLUMNS if self.spectra else 0)

    @property
    def slot_fluid(self):  # explicit lubrication torques on i and j (implicit: Scratch.lub_slots)
        return SLOT_BASE + self.slot_model

    @property
    def slot_audit(self):
        return self.slot_fluid + (6 if self.fluid and not self.implicit else 0)

    @property
    def slot_spectra(self):
        return self.slot_audit + (SLOT_AUDIT if self.audit else 0)

    @property
    def slot_width(self):
        return self.slot_spectra + (SPECTRA_SLOT if self.spectra else 0)

    @classmethod
    def of(cls, spec, law, breakage=None, fluid=None):
        """The layout of one physics variant: the law's spring columns, the breakage model's
        columns, the fluid (and its scheme), the spec's energy audit and collision spectra."""
        return cls(law.spring_columns,
                   len(breakage.contact_columns) if breakage else 0,
                   len(breakage.wall_columns) if breakage else 0,
                   len(breakage.slot_columns) if breakage else 0,
                   fluid is not None, spec.energy_audit, fluid is not None and fluid.implicit,
                   spec.collision_spectra)
