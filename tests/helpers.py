"""Small builders shared by the tests."""

import numpy as np


def random_gas(n, box, radius_range, rng, dim=3):
    """Non-overlapping random spheres (or disks with dim = 2) in a periodic box, by rejection."""
    x, r = [], []
    while len(x) < n:
        ri = rng.uniform(*radius_range)
        xi = rng.uniform(0, box, 3)
        if dim == 2:
            xi[2] = 0.0
        d = np.array(x).reshape(-1, 3) - xi
        d -= box * np.round(d / box)
        if len(x) and (np.linalg.norm(d, axis=1) < np.array(r) + ri).any():
            continue
        x.append(xi)
        r.append(ri)
    return np.array(x), np.array(r)
