"""Time step from the stiffest interaction present, and the stability limit a step must meet.

Every interaction the models bring reports a :class:`StepBound` (its kind, a description, the
refusal limit and the recommended step): the contact law for every pair of materials that can
touch (free particles with each other, with walls and with kinematic bodies; the smallest particle
of each material sets the fastest contact), the fluid for its relaxation time. The policy, the same
in every scene:

- ``dt_factor`` x the recommended step of the particles present (the default, factor 1), followed
  as the particles change (fragments shrink it), or
- an absolute ``dt``, kept while it stays within the limit;
- a step above the limit is refused with a message naming the limit and the interaction that sets
  it.

Contact-law constants (the laws of models/contact/): the recommended step resolves a contact with 50 steps
(0.1 Rayleigh time for Hertz), the limit is 10 steps per contact (0.4 Rayleigh time, EDEM's upper
recommendation).
"""

import math
import sys
from dataclasses import dataclass

import numpy as np

from .integrators import DAMPING_LIMIT

# A step a few units of rounding above the limit is at the limit: dt_factor x the recommended step
# lands there when the factor is the ratio of the two (5 x t_c/50 against t_c/10), up to rounding.
ROUNDING = 4 * sys.float_info.epsilon
STEPS_PER_CONTACT_LIMIT = 10
STEPS_PER_CONTACT_RECOMMENDED = 50
RAYLEIGH_LIMIT = 0.4
RAYLEIGH_RECOMMENDED = 0.1
# Kinds of bound; each contact law adds those it gives when it is registered (models/contact/).
BOUND_KINDS = ["lubrication"]


def with_dashpot(limit, recommended, rate, integrator):
    """A contact's step bounds joined with its normal dashpot's explicit limit: (limit,
    recommended, whether the dashpot binds).

    A dashpot relaxing the relative normal speed at up to ``rate`` [1/s] needs rate dt <=
    DAMPING_LIMIT[integrator]. A share of the collision time stops shrinking as the damping grows
    (the linear one is capped, the Hertz one does not see the damping), so past some damping the
    dashpot binds; its recommended step then keeps the contacts' ratio of recommended to limit."""
    dashpot = DAMPING_LIMIT[integrator] / rate if rate > 0 else math.inf
    if dashpot >= limit:
        return limit, recommended, False
    return dashpot, min(recommended, dashpot * STEPS_PER_CONTACT_LIMIT
                        / STEPS_PER_CONTACT_RECOMMENDED), True


def register_bound_kinds(kinds):
    BOUND_KINDS.extend(k for k in kinds if k not in BOUND_KINDS)


class TimeStepError(ValueError):
    """A requested time step above the stability limit."""


@dataclass(frozen=True)
class StepBound:
    kind: str  # one of BOUND_KINDS
    interaction: str  # what sets it, for messages
    limit: float
    recommended: float
    advice: str = ""  # the way out beyond a smaller dt, for the refusal message


@dataclass(frozen=True)
class TimeStepReport:
    bounds: tuple
    # shortest contact time at the declared impact speed, that speed and the exponent of its
    # shortening with speed, t_c ~ v^-exponent (None: a law whose contact time does not shorten)
    hertz_contact_time: float = None
    impact_speed: float = None
    speed_exponent: float = None

    def steps_per_contact(self, dt, speed):
        """Steps resolving the shortest contact at ``speed`` (Hertz: t_c scales as v^-1/5)."""
        if self.hertz_contact_time is None or speed <= self.impact_speed:
            return math.inf
        return self.hertz_contact_time * (self.impact_speed / speed) ** self.speed_exponent / dt

    @property
    def limit(self):
        return min(b.limit for b in self.bounds)

    @property
    def recommended(self):
        return min(b.recommended for b in self.bounds)

    @property
    def binding(self) -> StepBound:
        return min(self.bounds, key=lambda b: b.limit)

    def of_kind(self, kind):
        """The tightest bound of one kind (None when no interaction of that kind is present)."""
        if kind not in BOUND_KINDS:
            raise ValueError(f"kind: must be one of {BOUND_KINDS}, got {kind!r}")
        found = [b for b in self.bounds if b.kind == kind]
        return min(found, key=lambda b: b.limit) if found else None

    def exceeds(self, dt):
        """Whether ``dt`` is above the limit (by more than rounding)."""
        return dt > self.limit * (1 + ROUNDING)

    def check(self, dt):
        """Return dt if it is within the limit; raise TimeStepError naming the limit otherwise."""
        if not dt > 0:
            raise TimeStepError(f"dt: must be > 0, got {dt}")
        b = self.binding
        if self.exceeds(dt):
            raise TimeStepError(
                f"dt: {dt:.4g} s exceeds the stability limit {b.limit:.4g} s set by {b.interaction}; "
                f"use dt <= {b.limit:.4g} s (recommended {self.recommended:.4g} s){b.advice}")
        return dt


def smallest_by_material(radius, mass, material, body):
    """{material: (radius, mass)} of the lightest free particle of each material."""
    free = body < 0
    smallest = {}
    for mat in np.unique(material[free]):
        sel = free & (material == mat)
        k = np.argmin(mass[sel])
        smallest[int(mat)] = (float(radius[sel][k]), float(mass[sel][k]))
    return smallest


def time_step_report(law, materials, params, dim, integrator, radius, mass, material, body,
                     boundary_materials, impact_speed, extra=()):
    """Bounds of every material pair that can be in contact, plus ``extra`` bounds (models).

    Args:
        law: the contact law (``pair_bounds``, ``contact_time_exponent``); materials, params: its material table's
            materials and parameter rows.
        radius, mass, material, body: per-particle arrays (body >= 0 marks kinematic particles).
        boundary_materials: material indices of walls and kinematic bodies.
        impact_speed: largest expected normal impact speed [m/s] (Hertz contact time).
    """
    smallest = smallest_by_material(radius, mass, material, body)
    bounds = []
    shortest = math.inf
    for a, (ra, ma) in smallest.items():
        partners = [(b, rb, mb, "particle") for b, (rb, mb) in smallest.items() if b >= a]
        partners += [(b, math.inf, math.inf, "wall/body") for b in sorted(set(boundary_materials))]
        for b, rb, mb, partner in partners:
            found, t_c = law.pair_bounds(materials, params, a, b, ra, ma, rb, mb, partner,
                                         impact_speed, dim, integrator)
            bounds += found
            shortest = min(shortest, t_c)
    if not bounds:
        raise ValueError("no free particles: nothing sets a time step")
    bounds += list(extra)
    if law.contact_time_exponent:  # only a contact that shortens with speed needs watching
        return TimeStepReport(tuple(bounds), shortest, float(impact_speed), law.contact_time_exponent)
    return TimeStepReport(tuple(bounds))
