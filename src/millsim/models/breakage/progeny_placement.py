"""The replacement step of the Tavares model (Tavares et al. 2021): a broken particle becomes one
family of progeny spheres placed inside it.

``break_particle`` takes t10' from eq 8, draws a family (``progeny_families``) and places its
spheres (``place_fragments``: large fragments off the stress axis, fines near it, Fig 6 of Tavares
et al. 2021), turned about the load axis. Pure and deterministic in its arguments; the handler
that applies it to a simulation between chunks is ``replacement.TavaresReplacement``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .progeny_families import families, family_classes_for
from .tavares import T10_STEP, t10_prime


# ---- placement of progeny inside the parent -------------------------------------------------
def _unit_ball_points(n=384):
    """Deterministic quasi-uniform points in the unit ball (golden-angle spiral, cube-root radii)."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    rho = np.sqrt(1.0 - z * z)
    phi = i * math.pi * (3.0 - math.sqrt(5.0))
    dirs = np.stack([z, rho * np.cos(phi), rho * np.sin(phi)], axis=1)
    radial = ((i * 0.6180339887498949) % 1.0) ** (1.0 / 3.0)
    pts = dirs * radial[:, None]
    return np.vstack([np.zeros((1, 3)), dirs, pts])


_BALL = _unit_ball_points()  # columns: (along stress, across 1, across 2)


def _frame(direction, spin):
    """Orthonormal rows (s, e1, e2), e1/e2 turned by 2 pi spin about the stress direction s."""
    s = np.asarray(direction, dtype=float).reshape(3)
    norm = np.linalg.norm(s)
    s = s / norm if norm > 0 else np.array([0.0, 0.0, 1.0])
    a = np.array([1.0, 0.0, 0.0]) if abs(s[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = a - (a @ s) * s
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(s, e1)
    t = 2.0 * math.pi * spin
    return np.array([s, math.cos(t) * e1 + math.sin(t) * e2, -math.sin(t) * e1 + math.cos(t) * e2])


def place_fragments(radii, relax=40):
    """Centres (local frame, column 0 along the stress) of spheres of ``radii`` in a unit sphere.

    Largest first, each at the candidate position of least squared overlap with those placed,
    plus a bias: fragments larger than 0.3 of the parent radius avoid the stress axis (the
    split opens across the load, Fig 6 of Tavares et al. 2021) and smaller ones lean towards it
    (fines form near the loading points). Then a few relaxation sweeps push overlapping pairs apart,
    the smaller sphere moving more, always projected back inside.
    """
    r = np.asarray(radii, dtype=float)
    n = len(r)
    c = np.zeros((n, 3))
    for i in range(n):
        cand = _BALL * (1.0 - r[i])
        score = (r[i] - 0.3) * 0.5 * cand[:, 0] ** 2
        if i:
            dist = np.linalg.norm(cand[:, None, :] - c[None, :i, :], axis=2)
            score = score + (np.clip(r[i] + r[None, :i] - dist, 0.0, None) ** 2).sum(1)
        c[i] = cand[int(np.argmin(score))]
    vol = r**3
    iu, ju = np.triu_indices(n, 1)
    for _ in range(relax if n > 1 else 0):
        d = c[ju] - c[iu]
        dist = np.linalg.norm(d, axis=1)
        ov = r[iu] + r[ju] - dist
        hit = ov > 1e-12
        if not hit.any():
            break
        u = np.where(dist[:, None] > 1e-12, d / np.maximum(dist, 1e-12)[:, None],
                     np.array([0.0, 1.0, 0.0]))
        share_i = vol[ju] / (vol[iu] + vol[ju])
        move = np.zeros_like(c)
        np.add.at(move, iu[hit], -(0.5 * ov * share_i)[hit, None] * u[hit])
        np.add.at(move, ju[hit], (0.5 * ov * (1.0 - share_i))[hit, None] * u[hit])
        c += move
        lim = 1.0 - r
        norm = np.linalg.norm(c, axis=1)
        out = norm > lim
        c[out] *= (lim[out] / norm[out])[:, None]
    return c


# ---- the replacement step -------------------------------------------------------------------
class Progeny(NamedTuple):
    """Result of one breakage, parent-centred and in SI.

    offsets (k, 3) [m] and radii (k,) [m] of the spheres, largest first, dummies last; breakable
    (k,) bool: may break again (False for dummy spheres and resolved-unbreakable sizes);
    dummy (k,) bool: sphere stands for unresolved fines (never breaks; eq 11 afterwards);
    fines_mass [kg]: fines not put into spheres (dummy_as="fines"); t10: grid t10' [%] used;
    family: index of the family drawn; n_classes: resolved classes of that table.
    """

    offsets: np.ndarray
    radii: np.ndarray
    breakable: np.ndarray
    dummy: np.ndarray
    fines_mass: float
    t10: float
    family: int
    n_classes: int


def break_particle(mat, d_parent, specific_energy, fracture_energy, stress_direction, u_family,
                   u_spin, *, d_min=0.0, policy="standard", dummy_as="spheres"):
    """Replace a broken particle by one family of progeny spheres.

    mat, d_parent [m]; specific_energy: absorbed Ek'/m_p of the event [J/kg]; fracture_energy:
    the particle's current (damaged) E [J/kg] (together eq 8's t10'); stress_direction: unit
    vector of the breaking load; u_family, u_spin: the engine's uniforms in [0, 1) choosing the
    family and the arrangement's turn about the load axis; d_min [m]: global minimum resolved
    size; policy: see ``family_classes_for``; dummy_as: "spheres" (Tavares et al. 2021: dummy
    spheres of size x_min that never break) or "fines" (their mass is returned as fines_mass
    instead). Everything is deterministic in the arguments. Mass: sum of sphere masses + fines_mass
    equals the parent mass to round-off.
    """
    mat.require_breakage()
    if dummy_as not in ("spheres", "fines"):
        raise ValueError(f"dummy_as: {dummy_as!r} is not 'spheres' or 'fines'")
    K = family_classes_for(mat, d_parent, d_min, policy)
    if K == 0:
        raise ValueError(f"break_particle: a {d_parent:g} m particle is resolved-unbreakable "
                         f"with d_min = {d_min:g} m (policy {policy!r})")
    t10 = float(np.clip(t10_prime(mat, specific_energy, fracture_energy), T10_STEP, mat.A))
    table = families(mat, t10, K)
    cum = np.cumsum(table.probabilities)
    f = int(min(np.searchsorted(cum, float(u_family) * cum[-1], side="right"), len(cum) - 1))
    d_res = table.diameters[f]
    nd = int(table.dummy_counts[f])
    d_dum = float(table.dummy_diameter[f])
    fines_mass = 0.0
    if dummy_as == "fines":
        fines_mass = mat.density * math.pi / 6.0 * d_parent**3 * nd * d_dum**3
        nd = 0
    rel = np.concatenate([d_res, np.full(nd, d_dum)])
    local = place_fragments(rel)  # x/d of a diameter is also r/R of the radius
    R = 0.5 * d_parent
    frame = _frame(stress_direction, float(u_spin))
    offsets = (local @ frame) * R
    radii = rel * R
    dummy = np.arange(len(rel)) >= len(d_res)
    sizes = 2.0 * radii
    ok = np.array([family_classes_for(mat, s, d_min, policy) > 0 for s in sizes], dtype=bool)
    breakable = ok & ~dummy
    return Progeny(offsets, radii, breakable, dummy, fines_mass, table.t10, f, K)
