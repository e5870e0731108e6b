"""Struct-of-arrays particle state and the contact list, as numba-compatible named tuples.

One :class:`ParticleArrays` holds every per-particle array the compiled loop touches. 2D scenes use
the same 3-component arrays with z = 0 (disks spin about z only), so one set of kernels serves both
dimensions; only masses, inertias and the cell grid depend on ``dim``.
"""

from collections import namedtuple

import numpy as np

ParticleArrays = namedtuple(
    "ParticleArrays",
    ["x", "v", "w", "acc", "alpha", "radius", "inv_mass", "inv_inertia", "material", "body",
     "x_ref", "x_body0", "gear", "fn_sum", "e_acc", "e_frac", "break_at_end", "t10_recorded"],
)
ContactList = namedtuple("ContactList", ["start", "nbr", "state", "rev_start", "rev_slot"])

GEAR_SLOTS = 6  # x''', x'''', x''''' and the same three for rotation


def disk_or_sphere_mass(radius, density, dim, thickness):
    """Mass of a 3D sphere, or of a 2D disk of the given thickness [kg]."""
    radius = np.asarray(radius, dtype=float)
    if dim == 3:
        return density * 4.0 / 3.0 * np.pi * radius**3
    return density * np.pi * radius**2 * thickness


def moment_of_inertia(mass, radius, dim):
    """Solid sphere 2/5 m r^2 in 3D, solid disk 1/2 m r^2 about its axis in 2D [kg m^2]."""
    return (0.4 if dim == 3 else 0.5) * mass * np.asarray(radius) ** 2


def allocate(x, v, w, radius, inv_mass, inv_inertia, material, body, x_body0, gear):
    """Assemble ParticleArrays with C-contiguous, correctly typed arrays and fresh scratch arrays."""
    n = len(radius)
    as3 = lambda a: np.ascontiguousarray(np.asarray(a, dtype=np.float64).reshape(n, 3))
    x = as3(x)
    return ParticleArrays(
        x=x, v=as3(v), w=as3(w), acc=np.zeros((n, 3)), alpha=np.zeros((n, 3)),
        radius=np.ascontiguousarray(radius, dtype=np.float64),
        inv_mass=np.ascontiguousarray(inv_mass, dtype=np.float64),
        inv_inertia=np.ascontiguousarray(inv_inertia, dtype=np.float64),
        material=np.ascontiguousarray(material, dtype=np.int32),
        body=np.ascontiguousarray(body, dtype=np.int32),
        x_ref=x.copy(), x_body0=as3(x_body0),
        gear=np.zeros((n if gear else 0, GEAR_SLOTS, 3)),
        fn_sum=np.zeros(n),
        # Tavares breakage: energy absorbed in the current stressing event [J] and the current
        # (damaged) specific fracture energy [J/kg]; inf = never breaks.
        e_acc=np.zeros(n), e_frac=np.full(n, np.inf),
        # Tavares breakage decided at the end of the stressing event with its whole energy
        # instead of when the energy first reaches E; the t10' [%] recorded for a
        # resolved-unbreakable particle's first breaking event (seed 002 section 2.3; NaN: none).
        break_at_end=np.zeros(n, dtype=np.bool_), t10_recorded=np.full(n, np.nan),
    )


def select(p: ParticleArrays, keep) -> ParticleArrays:
    """Particles where ``keep`` is true (a boolean mask or an index array), all arrays consistent."""
    return ParticleArrays(*(a[keep].copy() if a.shape[0] == p.x.shape[0] else a for a in p))


def concatenate(a: ParticleArrays, b: ParticleArrays) -> ParticleArrays:
    """Append the particles of ``b`` to ``a``."""
    return ParticleArrays(*(np.ascontiguousarray(np.concatenate([u, w])) for u, w in zip(a, b)))


def empty_contacts(n: int, state_columns: int) -> ContactList:
    """A contact list with no pairs (forces a rebuild before the first step)."""
    return ContactList(
        start=np.zeros(n + 1, dtype=np.int64), nbr=np.zeros(0, dtype=np.int32),
        state=np.zeros((0, state_columns)), rev_start=np.zeros(n + 1, dtype=np.int64),
        rev_slot=np.zeros(0, dtype=np.int64),
    )
