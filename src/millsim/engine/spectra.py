"""Collision energy spectra (``PhysicsSpec(collision_spectra=True)``): per contact type, the
number of collisions in log-spaced bins of the energy each dissipated, normal and tangential
apart, as mechanistic and population-balance mill models take them (docs/engine.md, "Collision
spectra"). The compiled half is :mod:`millsim.engine.loop.spectra`.

A collision is a contact from the step it starts touching to the step it is found apart; its
energies are the energy audit's contact terms over that time (normal: the dashpot; tangential:
the tangential force against the slip of the centres and of the surfaces' rotation; rolling
friction is the audit's own term, booked per particle). Contact types: pairs by their two
materials (a, b), a <= b; walls (analytic and mesh) by (particle material, wall or triangle
material), in a table of their own.
"""

import math
from dataclasses import dataclass

import numpy as np

from .loop.layout import SPECTRA_COLUMNS
from .loop.spectra import E_N, E_T, OPEN, P_N, P_T, PAIR, WALL, book_collisions
from .mesh import TAG_COLUMNS
from .state import SpectraAccumulators


@dataclass(frozen=True)
class SpectraBins:
    """``n`` log-spaced bins of dissipated energy from ``lo`` to ``hi`` [J]; an underflow bin
    below ``lo`` (energies <= 0 too) and an overflow bin at ``hi`` and above come with them."""

    lo: float = 1e-9
    hi: float = 10.0
    n: int = 40

    def __post_init__(self):
        if not (math.isfinite(self.lo) and self.lo > 0.0):
            raise ValueError(f"spectra: lo must be a finite energy > 0 J, got {self.lo!r}")
        if not (math.isfinite(self.hi) and self.hi > self.lo):
            raise ValueError(f"spectra: hi must be finite and > lo = {self.lo!r} J, got "
                             f"{self.hi!r}")
        if not (isinstance(self.n, (int, np.integer)) and self.n >= 1):
            raise ValueError(f"spectra: n must be a whole number of bins >= 1, got {self.n!r}")

    @property
    def edges(self):
        """The n + 1 bin edges [J]."""
        return np.exp(np.linspace(math.log(self.lo), math.log(self.hi), self.n + 1))


@dataclass(frozen=True)
class CollisionSpectra:
    """The spectra since the start of a run (or between two moments: ``since``).

    ``pair_normal`` / ``pair_tangential``: collisions per (material a, material b, bin), a <= b,
    bins [underflow, the n bins of ``edges``, overflow]; ``wall_normal`` / ``wall_tangential``:
    per (particle material, wall material, bin). ``pair_energy`` / ``wall_energy``: the energy of
    the counted collisions per type, [..., 0] normal, [..., 1] tangential [J]. ``open_normal`` /
    ``open_tangential``: what contacts still touching have dissipated so far [J] (counted when
    they end). ``materials``: the names of the indices; ``duration``: the time covered [s].
    """

    edges: np.ndarray
    materials: tuple
    duration: float
    pair_normal: np.ndarray
    pair_tangential: np.ndarray
    wall_normal: np.ndarray
    wall_tangential: np.ndarray
    pair_energy: np.ndarray
    wall_energy: np.ndarray
    open_normal: float
    open_tangential: float

    @property
    def pair_collisions(self):
        return self.pair_normal.sum(axis=-1)

    @property
    def wall_collisions(self):
        return self.wall_normal.sum(axis=-1)

    def per_second(self, name):
        """Collisions per second per bin of the table ``name`` (e.g. ``"wall_normal"``)."""
        return getattr(self, name) / self.duration

    def since(self, earlier):
        """The collisions ended between ``earlier`` (a spectra of the same run) and these; the
        open energies are these."""
        if not np.array_equal(earlier.edges, self.edges) or earlier.materials != self.materials:
            raise ValueError("since: spectra of other bins or materials")
        tables = ("pair_normal", "pair_tangential", "wall_normal", "wall_tangential",
                  "pair_energy", "wall_energy")
        return CollisionSpectra(self.edges, self.materials, self.duration - earlier.duration,
                                *(getattr(self, t) - getattr(earlier, t) for t in tables),
                                self.open_normal, self.open_tangential)


def spectra_accumulators(accumulators, bins, n_materials):
    """The Simulation's accumulators with the spectra's totals and bins (empty counts)."""
    if not isinstance(bins, SpectraBins):
        raise ValueError(f"spectra: expected SpectraBins(lo, hi, n), got {bins!r}")
    types = 2 * n_materials * n_materials * 2  # table, a, b, normal/tangential
    row = np.array([bins.lo, math.log(bins.lo), bins.n / math.log(bins.hi / bins.lo),
                    n_materials])
    return SpectraAccumulators(*accumulators, np.zeros((types, bins.n + 2), np.int64),
                               np.zeros(types), row)


def _open_contacts(sim):
    """Every open contact as (table, material a, material b, its spectra columns, particle i,
    partner j (-1 for walls), wall (-1 for pairs)), one array each, pairs first."""
    lay, p, c = sim.layout, sim.particles, sim.contacts
    i = np.repeat(np.arange(sim.n_particles), np.diff(c.start))
    j = c.nbr.astype(np.int64)
    rows = c.state[:, lay.contact_spectra:lay.contact_spectra + SPECTRA_COLUMNS]
    keep = rows[:, OPEN] != 0.0
    a, b = p.material[i[keep]], p.material[j[keep]]
    parts = [(np.full(keep.sum(), PAIR), np.minimum(a, b), np.maximum(a, b), rows[keep],
              i[keep], j[keep], np.full(keep.sum(), -1))]
    walls = [(sim._W.hist, None)]
    if sim._mesh_geometry:  # each slot's wall is its tag - 1
        walls.append((sim._W.mesh_hist, lay.wall_columns + TAG_COLUMNS - 1))
    for hist, tag in walls:
        rows = hist[:, :, lay.wall_spectra:lay.wall_spectra + SPECTRA_COLUMNS]
        owner, col = np.nonzero(rows[:, :, OPEN] != 0.0)
        wall = col if tag is None else hist[owner, col, tag].astype(np.int64) - 1
        rows = rows[owner, col]
        parts.append((np.full(len(owner), WALL), p.material[owner],
                      rows[:, OPEN].astype(np.int64) - 1, rows, owner, np.full(len(owner), -1),
                      wall))
    return [np.concatenate(field) for field in zip(*parts)]


def close_open(sim, removed=None, wall=None, tail=0.0):
    """End, between chunks, the collisions of the open contacts the Simulation is about to
    discard, and count them: those of the particles where ``removed`` is true, or those with
    wall ``wall`` (an index), or every wall contact (neither given). ``tail``: the step in which
    the loop would have booked their last half step (the audit's trapezoid; 0 where the audit
    forgets its last powers)."""
    table, a, b, rows, i, j, w = _open_contacts(sim)
    if removed is not None:
        removed = np.asarray(removed, dtype=bool)
        sel = removed[i] | ((j >= 0) & removed[np.maximum(j, 0)])
    else:
        sel = (table == WALL) & ((w == wall) if wall is not None else True)
    A = sim.accumulators
    rows = rows[sel]
    book_collisions(A.spectra_counts[None], A.spectra_energy[None], A.spectra_bins,
                    table[sel].astype(np.int64), a[sel].astype(np.int64),
                    b[sel].astype(np.int64), rows[:, E_N] + 0.5 * tail * rows[:, P_N],
                    rows[:, E_T] + 0.5 * tail * rows[:, P_T])


def collision_spectra(sim, bins):
    """Simulation.collision_spectra: the counts, energies and open energies now."""
    A = sim.accumulators
    m = len(sim.pair_params)
    counts = A.spectra_counts.reshape(2, m, m, 2, bins.n + 2)
    energy = A.spectra_energy.reshape(2, m, m, 2)
    rows = _open_contacts(sim)[3]
    names = tuple(sorted(sim.table.index, key=sim.table.index.get))
    return CollisionSpectra(bins.edges, names, float(sim.time), counts[PAIR, :, :, 0].copy(),
                            counts[PAIR, :, :, 1].copy(), counts[WALL, :, :, 0].copy(),
                            counts[WALL, :, :, 1].copy(), energy[PAIR].copy(),
                            energy[WALL].copy(), float(rows[:, E_N].sum()),
                            float(rows[:, E_T].sum()))
