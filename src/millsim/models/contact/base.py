"""What a contact law plug-in declares, and what the engine and the material table ask of it.

Every law receives the contact geometry and kinematics of one contact and returns the normal force
magnitude (never attractive unless the spec's convention is ``unclipped``, where the Coulomb limit
takes |F_n| as EDEM and LIGGGHTS do) and the tangential force vector acting on body ``i``. The
caller turns these into forces and torques on both bodies, so the same law serves
particle-particle and particle-wall contacts (for a wall, m_eff = m_i and r_eff = r_i).

Conventions (shared with the rest of the engine):
- ``n`` is the unit normal pointing from body j (or the wall) to body i.
- ``vrel`` is the velocity of i's material point at the contact minus j's, so the normal overlap rate
  is ``xi_dot = -vrel . n``.
- ``hist`` is the contact's tangential spring (3 values), updated in place; laws without a spring
  ignore it.

A law is one module of this package holding one :class:`ContactLaw` subclass: the constants it
reads from an :class:`~millsim.models.materials.Interaction` (``parameters``), its parameter row
(``columns``, filled by ``row``), its step bounds and contact time, its restitution mapping and its
compiled force kernel. The laws are separate compiled functions (LLVM inlines them): a step loop
whose spec does not use a law never types or compiles it, which the tests check.
"""

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ...engine.jit_options import FAST
from ...engine.models import stable_identity
from ...util.validation import check_range

# Width of a parameter row: one table (n_materials, n_materials, N_PARAMS) serves every law.
N_PARAMS = 8


@dataclass(frozen=True)
class Parameter:
    """One constant of a law's interaction: key, default (None: required), allowed range, meaning."""

    name: str
    default: float = None
    lo: float = 0.0
    hi: float = None
    lo_open: bool = False
    hi_open: bool = False
    doc: str = ""


# ---- the uniform kernel the step loop calls: (fn, F_t on i (3), elastic normal force) -----------
# Each kernel in two builds: the law called as a compiled function (LLVM inlines it where its
# heuristics choose: the slot-record pass and the wall contacts keep their rounding), and the law
# inlined by numba into every caller (the colour sums' pass, where LLVM left it out of line and
# the call took a third of the time: docs/results/engine_speed.md, "Colour sums").
def kernel(make, law, name, inlined=False):
    if inlined:
        law = stable_identity(njit(inline="always", cache=True, fastmath=FAST)(law.py_func),
                              f"contact.{name}.law_inlined")
        name += ".inlined"
    return stable_identity(njit(inline="always", cache=True, fastmath=FAST)(make(law)),
                           f"contact.{name}")


class ContactLaw:
    """One contact law, as the engine, the material table and the scenes see it.

    Class attributes a law declares: name (its key in ``LAWS``); parameters (the
    :class:`Parameter` entries an interaction gives it); columns (names of its parameter-row
    columns, in the order its kernel reads them); spring_columns (per-contact state it keeps, the
    tangential spring); rolling_column (row column of the rolling-friction coefficient, -1: none);
    elastic (``"linear"``: k xi, or ``"hertz"``: xi^3/2, the shape of its elastic normal force);
    dims (2: disks, 3: spheres); bound_kinds (the ``StepBound`` kinds it gives);
    contact_time_exponent (t_c ~ v^-exponent: 0 where the contact
    time does not depend on the impact speed). Built once per law: force (the compiled kernel (p,
    xi, n, vrel, m_eff, r_eff, clip, hist, k, dt) -> (fn, F_t (3), elastic fn)) and inlined_force
    (the same kernel with the law inlined into its caller, for the colour sums).
    """

    name = ""
    parameters = ()
    columns = ()
    spring_columns = 0
    rolling_column = -1
    elastic = "linear"
    dims = (2, 3)
    bound_kinds = ("linear_contact",)
    contact_time_exponent = 0.0

    def __init__(self, make, law):
        self.force = kernel(make, law, self.name)
        self.inlined_force = kernel(make, law, self.name, inlined=True)

    def __repr__(self):
        return f"ContactLaw({self.name!r})"

    @property
    def parameter_names(self):
        return tuple(p.name for p in self.parameters)

    def column(self, name):
        """Index of a named column of the parameter row (-1: the law has none of that name)."""
        return self.columns.index(name) if name in self.columns else -1

    def values(self, given, pair):
        """The law's interaction constants from the given ones (defaults filled in, ranges checked;
        keys of other laws are ignored)."""
        key = f"interaction[{pair[0]}, {pair[1]}]"
        values = {}
        for p in self.parameters:
            value = given.get(p.name, p.default)
            if value is None:
                raise ValueError(f"{key}.{p.name}: required by contact_law {self.name!r} ({p.doc})")
            values[p.name] = check_range(f"{key}.{p.name}", value, p.lo, p.hi, p.lo_open, p.hi_open)
        return values

    def parameter_row(self, a, b, given, convention):
        """The parameter row of materials a and b with the given interaction constants."""
        cells = self.row(a, b, self.values(given, (a.name, b.name)), convention)
        row = np.zeros(N_PARAMS)
        for k, name in enumerate(self.columns):
            row[k] = cells[name]
        return row

    def pair_bounds(self, materials, params, a, b, ra, ma, rb, mb, partner, impact_speed, dim,
                    integrator):
        """Step bounds of the contact of the smallest particles of materials a and b (mb = inf: a
        wall or kinematic body; params: the table's parameter rows); returns (bounds, contact
        time at impact_speed)."""
        m_eff = 1.0 / (1.0 / ma + (0.0 if math.isinf(mb) else 1.0 / mb))
        r_eff = ra if math.isinf(rb) else ra * rb / (ra + rb)
        names = f"{materials[a].name}-{materials[b].name} {partner} contact"
        return self.bounds(materials[a], params[a, b], ra, m_eff, r_eff, names, impact_speed, dim,
                           integrator)

    # ---- what each law defines --------------------------------------------------------------
    def row(self, a, b, values, convention):
        """{column name: value} of materials a and b (``values``: the law's checked constants);
        the damping is set so that a head-on collision returns the asked restitution in the
        end-of-contact convention (``PhysicsSpec.convention``)."""
        raise NotImplementedError

    def bounds(self, mat, p, ra, m_eff, r_eff, names, impact_speed, dim, integrator):
        """(StepBound entries, contact time) of one contact; ``mat``: material of the smallest
        particle (radius ra), ``names``: the contact, for messages."""
        raise NotImplementedError

    def contact_time(self, p, m_eff, r_eff, speed):
        """Duration of a contact of row p at normal impact speed ``speed`` (the step bounds')."""
        raise NotImplementedError

    def stiffness_and_damping(self, p, m_eff):
        """(k_n [N/m], normal damping rate [1/s]) of a linear law for a contact of mass m_eff;
        (0, 0) for a law with other contact bounds, used by the lubrication bound."""
        return 0.0, 0.0

    def restitution(self, p, m_eff, convention):
        """Restitution of a head-on collision of a contact of row p (the inverse of ``row``'s
        damping for laws that take a restitution, a result for laws that take a damping)."""
        raise NotImplementedError

    def collision_time(self, p, m_eff, r_eff, speed, clipped):
        """Reference duration of a head-on collision at ``speed``, ending at zero force (clipped)
        or at zero overlap (the ``collision`` scene's analytic value)."""
        raise NotImplementedError
