"""Neighbour search: cell lists feeding a half Verlet list in CSR form.

The list holds every pair (i, j > i) closer than r_i + r_j + skin, rows sorted by j. Each entry is a
contact slot ``k`` that owns the contact's state (tangential spring and any model-specific columns);
state survives a rebuild by matching (i, j) between the old and new rows. A reverse index lists, for
every particle, the slots where it is the ``j`` partner, so forces can be gathered per particle in a
fixed order: results do not depend on the number of threads.

Pairs of two kinematic-body particles are never listed: prescribed bodies do not act on each other.
"""

import math

import numpy as np
from numba import njit, prange


@njit(cache=True)
def wrap_periodic(x, body, box_lo, box_len):
    """Map free-particle positions on periodic axes (box_len > 0) back into [lo, lo + len).

    Kinematic-body particles are left alone: their pose is recomputed from the prescribed motion.
    """
    for i in range(x.shape[0]):
        if body[i] >= 0:
            continue
        for a in range(3):
            if box_len[a] > 0.0:
                x[i, a] = box_lo[a] + (x[i, a] - box_lo[a]) % box_len[a]


@njit(inline="always", cache=True)
def min_image(d, a, box_len):
    """Minimum-image component of a separation along axis a."""
    if box_len[a] > 0.0:
        d -= box_len[a] * math.floor(d / box_len[a] + 0.5)
    return d


@njit(cache=True)
def _cell_grid(x, cell_min, box_lo, box_len, dim, max_cells):
    lo = np.zeros(3)
    ext = np.zeros(3)
    ncell = np.ones(3, dtype=np.int64)
    n = x.shape[0]
    for a in range(3):
        if box_len[a] > 0.0:
            lo[a] = box_lo[a]
            ext[a] = box_len[a]
        elif n > 0:
            mn = np.inf
            mx = -np.inf
            for i in range(n):
                mn = min(mn, x[i, a])
                mx = max(mx, x[i, a])
            lo[a] = mn
            ext[a] = mx - mn
        if a < dim:
            ncell[a] = max(1, int(ext[a] / cell_min))
            # With two periodic cells the -1 and +1 neighbours coincide: use one cell instead.
            if box_len[a] > 0.0 and ncell[a] < 3:
                ncell[a] = 1
    # A few far-flying particles must not blow up the grid: coarsen non-periodic axes.
    coarsened = True
    while coarsened and ncell[0] * ncell[1] * ncell[2] > max_cells:
        coarsened = False
        for a in range(dim):
            if box_len[a] == 0.0 and ncell[a] > 1:
                ncell[a] = max(1, ncell[a] // 2)
                coarsened = True
    size = np.empty(3)
    for a in range(3):
        size[a] = ext[a] / ncell[a] if ext[a] > 0.0 else cell_min
    return lo, size, ncell


@njit(cache=True)
def _bin(x, lo, size, ncell, box_len):
    n = x.shape[0]
    cell_of = np.empty(n, dtype=np.int64)
    for i in range(n):
        c = 0
        for a in range(2, -1, -1):
            ci = int((x[i, a] - lo[a]) / size[a])
            ci = min(max(ci, 0), ncell[a] - 1)
            c = c * ncell[a] + ci
        cell_of[i] = c
    ntot = ncell[0] * ncell[1] * ncell[2]
    start = np.zeros(ntot + 1, dtype=np.int64)
    for i in range(n):
        start[cell_of[i] + 1] += 1
    for c in range(ntot):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    members = np.empty(n, dtype=np.int64)
    for i in range(n):
        c = cell_of[i]
        members[fill[c]] = i
        fill[c] += 1
    return cell_of, start, members


@njit(inline="always", cache=True)
def _scan_row(i, x, radius, body, skin, box_len, ncell, cell_of, start, members, out, write):
    """Count (write=False) or store into ``out`` (write=True) the list row of particle i."""
    c = cell_of[i]
    cx = c % ncell[0]
    cy = (c // ncell[0]) % ncell[1]
    cz = c // (ncell[0] * ncell[1])
    count = 0
    for dz in range(-1, 2):
        z = cz + dz
        if ncell[2] == 1 and dz != 0:
            continue
        if z < 0 or z >= ncell[2]:
            if box_len[2] == 0.0:
                continue
            z %= ncell[2]
        for dy in range(-1, 2):
            y = cy + dy
            if ncell[1] == 1 and dy != 0:
                continue
            if y < 0 or y >= ncell[1]:
                if box_len[1] == 0.0:
                    continue
                y %= ncell[1]
            for dx in range(-1, 2):
                xx = cx + dx
                if ncell[0] == 1 and dx != 0:
                    continue
                if xx < 0 or xx >= ncell[0]:
                    if box_len[0] == 0.0:
                        continue
                    xx %= ncell[0]
                cell = (z * ncell[1] + y) * ncell[0] + xx
                for m in range(start[cell], start[cell + 1]):
                    j = members[m]
                    if j <= i or (body[i] >= 0 and body[j] >= 0):
                        continue
                    d0 = min_image(x[i, 0] - x[j, 0], 0, box_len)
                    d1 = min_image(x[i, 1] - x[j, 1], 1, box_len)
                    d2 = min_image(x[i, 2] - x[j, 2], 2, box_len)
                    cut = radius[i] + radius[j] + skin
                    if d0 * d0 + d1 * d1 + d2 * d2 < cut * cut:
                        if write:
                            out[count] = j
                        count += 1
    return count


@njit(parallel=True, cache=True)
def build_verlet(x, radius, body, skin, dim, box_lo, box_len, old_start, old_j, old_state):
    """Build the half Verlet list and carry contact state over from the previous list.

    Returns (start, nbr, state, rev_start, rev_slot). ``state`` has the same number of columns as
    ``old_state``; rows of pairs that were not listed before start at zero.
    """
    n = x.shape[0]
    rmax = 0.0
    for i in range(n):
        rmax = max(rmax, radius[i])
    cell_min = 2.0 * rmax + skin
    lo, size, ncell = _cell_grid(x, cell_min, box_lo, box_len, dim, max(8 * n, 1000))
    cell_of, cstart, members = _bin(x, lo, size, ncell, box_len)

    counts = np.zeros(n + 1, dtype=np.int64)
    dummy = np.empty(0, dtype=np.int32)
    for i in prange(n):
        counts[i + 1] = _scan_row(i, x, radius, body, skin, box_len, ncell, cell_of, cstart, members,
                                  dummy, False)
    for i in range(n):
        counts[i + 1] += counts[i]
    start = counts
    nbr = np.empty(start[n], dtype=np.int32)
    ncol = old_state.shape[1]
    state = np.zeros((start[n], ncol))
    for i in prange(n):
        row = nbr[start[i]:start[i + 1]]
        _scan_row(i, x, radius, body, skin, box_len, ncell, cell_of, cstart, members, row, True)
        # Insertion sort: rows are short, and sorted rows make the state merge linear.
        for a in range(1, row.shape[0]):
            v = row[a]
            b = a - 1
            while b >= 0 and row[b] > v:
                row[b + 1] = row[b]
                b -= 1
            row[b + 1] = v
        if ncol > 0 and i + 1 < old_start.shape[0]:
            o = old_start[i]
            oend = old_start[i + 1]
            for k in range(start[i], start[i + 1]):
                j = nbr[k]
                while o < oend and old_j[o] < j:
                    o += 1
                if o < oend and old_j[o] == j:
                    for c in range(ncol):
                        state[k, c] = old_state[o, c]

    rev_start = np.zeros(n + 1, dtype=np.int64)
    for k in range(start[n]):
        rev_start[nbr[k] + 1] += 1
    for i in range(n):
        rev_start[i + 1] += rev_start[i]
    fill = rev_start[:-1].copy()
    rev_slot = np.empty(start[n], dtype=np.int64)
    for i in range(n):
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            rev_slot[fill[j]] = k
            fill[j] += 1
    return start, nbr, state, rev_start, rev_slot


def brute_force_pairs(x, radius, body, skin, box_len):
    """Reference O(N^2) pair set for tests: {(i, j)} with i < j closer than r_i + r_j + skin."""
    d = x[:, None, :] - x[None, :, :]
    for a in range(3):
        if box_len[a] > 0:
            d[..., a] -= box_len[a] * np.floor(d[..., a] / box_len[a] + 0.5)
    dist2 = (d ** 2).sum(-1)
    cut = radius[:, None] + radius[None, :] + skin
    both_body = (body[:, None] >= 0) & (body[None, :] >= 0)
    i, j = np.nonzero((dist2 < cut ** 2) & ~both_body)
    keep = i < j
    return set(zip(i[keep].tolist(), j[keep].tolist()))
