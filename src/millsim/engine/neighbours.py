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

from .state import ContactList


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


# Particles per block of the rebuild's front (bounding box, size classes, binning): each block's
# minimum or maximum is found in parallel and the blocks' are combined in order. Minima and maxima
# are exact, so the list does not depend on the blocks or the threads; on 16 threads the serial
# front took half the 2D mill's rebuild (docs/results/scaling.md).
FRONT_BLOCK = 4096


@njit(parallel=True, cache=True)
def _extent(x, box_lo, box_len):
    """Lower corner and extent of the grid: the periodic box, or the particles' bounding box."""
    lo = np.zeros(3)
    ext = np.zeros(3)
    n = x.shape[0]
    n_blocks = (n + FRONT_BLOCK - 1) // FRONT_BLOCK
    block_min = np.empty((n_blocks, 3))
    block_max = np.empty((n_blocks, 3))
    for b in prange(n_blocks):
        for a in range(3):
            mn = np.inf
            mx = -np.inf
            for i in range(b * FRONT_BLOCK, min(n, (b + 1) * FRONT_BLOCK)):
                mn = min(mn, x[i, a])
                mx = max(mx, x[i, a])
            block_min[b, a] = mn
            block_max[b, a] = mx
    for a in range(3):
        if box_len[a] > 0.0:
            lo[a] = box_lo[a]
            ext[a] = box_len[a]
        elif n > 0:
            lowest = np.inf
            highest = -np.inf
            for b in range(n_blocks):
                lowest = min(lowest, block_min[b, a])
                highest = max(highest, block_max[b, a])
            lo[a] = lowest
            ext[a] = highest - lowest
    return lo, ext


@njit(cache=True)
def _cell_grid(ext, cell_min, box_len, dim, max_cells):
    ncell = np.ones(3, dtype=np.int64)
    for a in range(dim):
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
    return size, ncell


@njit(inline="always", cache=True)
def _cell_index(xa, lo, size, ncell):
    return min(max(int((xa - lo) / size), 0), ncell - 1)


@njit(parallel=True, cache=True)
def _size_levels(radius):
    """Level of each particle and the number of levels: radius classes a factor 2 apart.

    Multi-level grid of Ogarko & Luding (2012, Comput. Phys. Commun. 183:931): each level has
    cells sized by its own largest particle, so a few large spheres do not make the cells of
    thousands of small ones large. Radii within a factor 2 of the smallest share one level (one
    grid, as a single-level cell list); empty classes are dropped.
    """
    n = radius.shape[0]
    level = np.zeros(n, dtype=np.int64)
    n_blocks = (n + FRONT_BLOCK - 1) // FRONT_BLOCK
    block_min = np.empty(n_blocks)
    block_max = np.empty(n_blocks)
    for b in prange(n_blocks):
        mn = np.inf
        mx = 0.0
        for i in range(b * FRONT_BLOCK, min(n, (b + 1) * FRONT_BLOCK)):
            if radius[i] > 0.0:
                mn = min(mn, radius[i])
            mx = max(mx, radius[i])
        block_min[b] = mn
        block_max[b] = mx
    rmin = np.inf
    rmax = 0.0
    for b in range(n_blocks):
        rmin = min(rmin, block_min[b])
        rmax = max(rmax, block_max[b])
    if n == 0 or rmax <= 0.0 or rmax < 2.0 * rmin:
        return level, 1
    nclass = 1 + int(math.floor(math.log2(rmax / rmin)))
    block_used = np.zeros((n_blocks, nclass), dtype=np.int64)
    for b in prange(n_blocks):
        for i in range(b * FRONT_BLOCK, min(n, (b + 1) * FRONT_BLOCK)):
            if radius[i] > 0.0:
                level[i] = min(int(math.floor(math.log2(radius[i] / rmin))), nclass - 1)
            block_used[b, level[i]] = 1
    rank = np.zeros(nclass, dtype=np.int64)
    nlev = 0
    for c in range(nclass):
        rank[c] = nlev
        for b in range(n_blocks):
            if block_used[b, c]:
                nlev += 1
                break
    for b in prange(n_blocks):
        for i in range(b * FRONT_BLOCK, min(n, (b + 1) * FRONT_BLOCK)):
            level[i] = rank[level[i]]
    return level, nlev


@njit(parallel=True, cache=True)
def _bin_levels(x, radius, level, nlev, skin, lo, ext, box_len, dim, max_cells):
    """One cell grid per level, binned into shared CSR arrays.

    Returns (rmax, size, ncell, cell_base, cstart, members): level l's cells are
    ``cell_base[l] ... cell_base[l + 1] - 1`` of ``cstart``; members are particle indices.
    """
    n = x.shape[0]
    n_blocks = (n + FRONT_BLOCK - 1) // FRONT_BLOCK
    block_max = np.zeros((n_blocks, nlev))
    for b in prange(n_blocks):
        for i in range(b * FRONT_BLOCK, min(n, (b + 1) * FRONT_BLOCK)):
            block_max[b, level[i]] = max(block_max[b, level[i]], radius[i])
    rmax = np.zeros(nlev)
    for b in range(n_blocks):
        for lv in range(nlev):
            rmax[lv] = max(rmax[lv], block_max[b, lv])
    size = np.empty((nlev, 3))
    ncell = np.empty((nlev, 3), dtype=np.int64)
    cell_base = np.zeros(nlev + 1, dtype=np.int64)
    for lv in range(nlev):
        size[lv], ncell[lv] = _cell_grid(ext, 2.0 * rmax[lv] + skin, box_len, dim, max_cells)
        cell_base[lv + 1] = cell_base[lv] + ncell[lv, 0] * ncell[lv, 1] * ncell[lv, 2]
    cell_of = np.empty(n, dtype=np.int64)
    for b in prange(n_blocks):
        for i in range(b * FRONT_BLOCK, min(n, (b + 1) * FRONT_BLOCK)):
            lvi = level[i]
            ci = 0
            for a in range(2, -1, -1):
                ci = ci * ncell[lvi, a] + _cell_index(x[i, a], lo[a], size[lvi, a], ncell[lvi, a])
            cell_of[i] = cell_base[lvi] + ci
    # the counting sort stays serial: members of a cell in index order
    ntot = cell_base[nlev]
    cstart = np.zeros(ntot + 1, dtype=np.int64)
    for i in range(n):
        cstart[cell_of[i] + 1] += 1
    for c in range(ntot):
        cstart[c + 1] += cstart[c]
    fill = cstart[:-1].copy()
    members = np.empty(n, dtype=np.int64)
    for i in range(n):
        c = cell_of[i]
        members[fill[c]] = i
        fill[c] += 1
    return rmax, size, ncell, cell_base, cstart, members


@njit(inline="always", cache=True)
def _cell_range(xa, reach, lo, size, ncell, periodic):
    """First cell and count of cells to visit along one axis (wrapped when periodic)."""
    c = _cell_index(xa, lo, size, ncell)
    k = int(math.ceil(reach / size))
    if ncell == 1 or (periodic and 2 * k + 1 >= ncell):
        return 0, ncell  # every cell of the axis, each once
    if periodic:
        return c - k, 2 * k + 1
    first = max(c - k, 0)
    return first, min(c + k, ncell - 1) - first + 1


@njit(inline="always", cache=True)
def _wrap(c, ncell):
    """Periodic image of a cell index at most one box away (cheaper than %)."""
    if c < 0:
        return c + ncell
    if c >= ncell:
        return c - ncell
    return c


@njit(inline="always", cache=True)
def _scan_row(i, x, radius, body, skin, box_len, lo, rmax, size, ncell, cell_base, cstart, members,
              out, write):
    """Count (write=False) or store into ``out`` (write=True) the list row of particle i.

    Every level is searched within r_i + r_max(level) + skin of particle i.
    """
    count = 0
    for lv in range(rmax.shape[0]):
        reach = radius[i] + rmax[lv] + skin
        z0, nz = _cell_range(x[i, 2], reach, lo[2], size[lv, 2], ncell[lv, 2], box_len[2] > 0.0)
        y0, ny = _cell_range(x[i, 1], reach, lo[1], size[lv, 1], ncell[lv, 1], box_len[1] > 0.0)
        x0, nx = _cell_range(x[i, 0], reach, lo[0], size[lv, 0], ncell[lv, 0], box_len[0] > 0.0)
        for dz in range(nz):
            z = _wrap(z0 + dz, ncell[lv, 2])
            for dy in range(ny):
                y = _wrap(y0 + dy, ncell[lv, 1])
                for dx in range(nx):
                    xx = _wrap(x0 + dx, ncell[lv, 0])
                    cell = cell_base[lv] + (z * ncell[lv, 1] + y) * ncell[lv, 0] + xx
                    for m in range(cstart[cell], cstart[cell + 1]):
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
    ``old_state``; rows of pairs that were not listed before start at zero. Rows are sorted by j,
    so the list (and everything computed from it) does not depend on how the grid was cut.
    """
    n = x.shape[0]
    lo, ext = _extent(x, box_lo, box_len)
    level, nlev = _size_levels(radius)
    rmax, size, ncell, cell_base, cstart, members = _bin_levels(
        x, radius, level, nlev, skin, lo, ext, box_len, dim, max(8 * n, 1000))

    counts = np.zeros(n + 1, dtype=np.int64)
    dummy = np.empty(0, dtype=np.int32)
    for i in prange(n):
        counts[i + 1] = _scan_row(i, x, radius, body, skin, box_len, lo, rmax, size, ncell,
                                  cell_base, cstart, members, dummy, False)
    for i in range(n):
        counts[i + 1] += counts[i]
    start = counts
    nbr = np.empty(start[n], dtype=np.int32)
    ncol = old_state.shape[1]
    state = np.zeros((start[n], ncol))
    for i in prange(n):
        row = nbr[start[i]:start[i + 1]]
        _scan_row(i, x, radius, body, skin, box_len, lo, rmax, size, ncell, cell_base, cstart,
                  members, row, True)
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


def rebuilt_contacts(p, old, reach, dim, box_lo, box_len, periodic):
    """The contact list of particles ``p`` (ParticleArrays) rebuilt from ``old`` (state carried
    over), periodic images wrapped first; the positions become the list's reference."""
    if periodic:
        wrap_periodic(p.x, p.body, box_lo, box_len)
    lists = build_verlet(p.x, p.radius, p.body, reach, dim, box_lo, box_len, old.start, old.nbr,
                         old.state)
    p.x_ref[:] = p.x
    return ContactList(*lists)


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
