"""Collision spectra in the step loop (``PhysicsSpec.collision_spectra``; the Python side is
:mod:`millsim.engine.spectra`).

Each contact integrates its own share of the energy audit's contact terms (normal damping;
tangential force against centre and rotational slip) with the audit's trapezoid, in its
spectra columns (``Layout.contact_spectra`` / ``wall_spectra``). In the step a contact is found
apart its collision ends: the pair pass leaves it in the slot record, the wall pass has it at
hand, and the particle pass counts it in its block's bins (``spectra_book``); the serial end of
the step folds the blocks' energies in block order (``spectra_reduce``), the runner the counts
(integers) once a chunk. No number depends on the thread count or on where a run is cut into
chunks.
"""

import math

from numba import njit

from ..jit_options import FAST
from .layout import N_AUDIT

# offsets within a contact's spectra columns (layout.SPECTRA_COLUMNS)
OPEN, E_N, E_T, P_N, P_T = 0, 1, 2, 3, 4
PAIR, WALL = 0, 1  # the two tables: pair contacts, wall contacts (analytic and mesh)
# spectra_bins: lowest edge [J], its log, bins per unit of log E, number of materials
B_LO, B_LOG_LO, B_PER_LOG, B_MATERIALS = 0, 1, 2, 3


@njit(inline="always", cache=True, fastmath=FAST)
def forgotten(audit_part):
    """Whether the audit forgot its last powers (particles added or removed): it then takes the
    step's own power for the whole step, and so does each contact. Column N_AUDIT of every
    block's audit share holds it for the chunk's first step (ChunkRunner)."""
    return audit_part[0, N_AUDIT] != 0.0


@njit(inline="always", cache=True, fastmath=FAST)
def spectra_step(row, c, pn, pt, dt, forget):
    """One step of a touching contact (its spectra columns from ``c`` of ``row``) that
    dissipates the powers pn (normal) and pt (tangential) [W]: the audit's trapezoid."""
    prev_n, prev_t = row[c + P_N], row[c + P_T]
    if forget:
        prev_n, prev_t = pn, pt
    row[c + E_N] += 0.5 * (prev_n + pn) * dt
    row[c + E_T] += 0.5 * (prev_t + pt) * dt
    row[c + P_N] = pn
    row[c + P_T] = pt


@njit(inline="always", cache=True, fastmath=FAST)
def spectra_end(row, c, dt, forget):
    """A contact found apart in this step: (its open flag, normal and tangential energy of the
    collision, last half step included: the trapezoid to power 0), and its columns cleared.
    (0, 0, 0) for a contact that was not open."""
    was = row[c + OPEN]
    if was == 0.0:
        return 0.0, 0.0, 0.0
    tail = 0.0 if forget else 0.5 * dt
    en = row[c + E_N] + tail * row[c + P_N]
    et = row[c + E_T] + tail * row[c + P_T]
    for q in range(5):
        row[c + q] = 0.0
    return was, en, et


@njit(inline="always", cache=True, fastmath=FAST)
def bin_index(e, bins, n):
    """The bin of energy e [J]: 0 below the lowest edge (e <= 0 and NaN too), then
    1 + floor(log(e / lo) x bins per unit of log), n + 1 at and above the highest edge."""
    if not e >= bins[B_LO]:
        return 0
    k = int((math.log(e) - bins[B_LOG_LO]) * bins[B_PER_LOG])
    return n + 1 if k >= n else k + 1


@njit(inline="always", cache=True, fastmath=FAST)
def spectra_book(counts, energy, bins, blk, table, a, b, en, et):
    """Count one collision of materials (a, b) (pairs: a <= b; walls: particle, wall) of
    ``table`` with normal and tangential energy en, et [J] in block ``blk``'s share."""
    m = int(bins[B_MATERIALS])
    t = ((table * m + a) * m + b) * 2
    n = counts.shape[2] - 2
    counts[blk, t, bin_index(en, bins, n)] += 1
    counts[blk, t + 1, bin_index(et, bins, n)] += 1
    energy[blk, t] += en
    energy[blk, t + 1] += et


@njit(inline="always", cache=True, fastmath=FAST)
def spectra_close_wall(row, c, dt, S, blk, material):
    """A wall contact found apart (or within its progeny reference) in this step: its collision
    counted in the block's share (the wall's material is its open flag - 1)."""
    was, en, et = spectra_end(row, c, dt, forgotten(S.audit_part))
    if was != 0.0:
        spectra_book(S.spectra_counts, S.spectra_energy, S.spectra_bins, blk, WALL, material,
                     int(was) - 1, en, et)


@njit(cache=True, _nrt=False)
def spectra_reduce(part, total, audit_part, n_blocks):
    """Serial end of a step: the blocks' binned energies into the totals, in block order, and
    the audit's forgotten-powers flag cleared (it holds for one step)."""
    for blk in range(n_blocks):
        for t in range(part.shape[1]):
            total[t] += part[blk, t]
            part[blk, t] = 0.0
        audit_part[blk, N_AUDIT] = 0.0


@njit(cache=True)
def book_collisions(counts, energy, bins, table, a, b, en, et):
    """Count collisions ended between chunks (a particle removed, a wall taken away, a restart
    from free flight) into ``counts`` and ``energy`` (the totals as one block): the same bins as
    in the loop."""
    for q in range(a.shape[0]):
        spectra_book(counts, energy, bins, 0, table[q], a[q], b[q], en[q], et[q])
