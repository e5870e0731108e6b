"""Force chains after Buchholtz et al. 2000, section 5 (pure numpy).

Grains i, j, k belong to one chain when (1) i-j and j-k are in contact, (2) the pressure on each of
the three exceeds a threshold, and (3) the angle i-j-k exceeds 150 degrees (the centres almost lie
on a line). Chains are the connected groups of grains linked by such triples.
"""

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

CHAIN_ANGLE_DEG = 150.0


def find_chains(x, pairs_i, pairs_j, load, threshold, angle_deg=CHAIN_ANGLE_DEG):
    """Chains as lists of grain indices, each ordered along its principal direction.

    Args:
        x: positions (N, 2 or 3).
        pairs_i, pairs_j: contacts (grain indices).
        load: per-grain chain criterion value (Buchholtz et al. 2000: sum of contact normal
            forces) [N].
        threshold: criterion (2) threshold, same units as ``load``.
    """
    n = len(x)
    strong = load > threshold
    keep = strong[pairs_i] & strong[pairs_j]
    a = np.concatenate([pairs_i[keep], pairs_j[keep]])
    b = np.concatenate([pairs_j[keep], pairs_i[keep]])
    order = np.argsort(a, kind="stable")
    a, b = a[order], b[order]
    starts = np.searchsorted(a, np.arange(n + 1))
    cos_max = np.cos(np.radians(angle_deg))
    link_i, link_j = [], []
    for j in np.flatnonzero(strong):
        nb = b[starts[j]:starts[j + 1]]
        if len(nb) < 2:
            continue
        u = x[nb] - x[j]
        u /= np.linalg.norm(u, axis=1)[:, None]
        cos = u @ u.T
        p, q = np.nonzero(np.triu(cos < cos_max, 1))
        for s, t in zip(nb[p], nb[q]):
            link_i += [s, j]
            link_j += [j, t]
    if not link_i:
        return []
    graph = coo_matrix((np.ones(len(link_i)), (link_i, link_j)), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    members = np.unique(np.concatenate([link_i, link_j]))
    chains = []
    for lab in np.unique(label[members]):
        idx = members[label[members] == lab]
        c = x[idx] - x[idx].mean(0)
        axis = np.linalg.svd(c, full_matrices=False)[2][0]
        chains.append(idx[np.argsort(c @ axis)])
    return chains


def chain_statistics(records, max_length=20, position_bins=10):
    """Length distribution, mean maximum pressure per length, mean load vs relative position.

    Args:
        records: iterable of (chains, load, pressure), one per analysed configuration; ``chains``
            from :func:`find_chains`, ``load`` and ``pressure`` per grain of that configuration.

    Returns dict of arrays: lengths (3..max_length; longer chains count as max_length), count,
    max_pressure (NaN where no chain), position (bin centres in [0, 1]), load_profile.
    """
    lengths = np.arange(3, max_length + 1)
    count = np.zeros(len(lengths))
    pmax_sum = np.zeros(len(lengths))
    edges = np.linspace(0.0, 1.0, position_bins + 1)
    prof_sum = np.zeros(position_bins)
    prof_n = np.zeros(position_bins)
    for chains, load, pressure in records:
        for chain in chains:
            k = min(len(chain), max_length) - 3
            count[k] += 1
            pmax_sum[k] += pressure[chain].max()
            b = np.clip(np.digitize(np.linspace(0.0, 1.0, len(chain)), edges) - 1, 0, position_bins - 1)
            np.add.at(prof_sum, b, load[chain])
            np.add.at(prof_n, b, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return {
            "lengths": lengths,
            "count": count,
            "max_pressure": np.where(count > 0, pmax_sum / count, np.nan),
            "position": 0.5 * (edges[1:] + edges[:-1]),
            "load_profile": np.where(prof_n > 0, prof_sum / prof_n, np.nan),
        }
