"""Counter-based random numbers for compiled kernels.

A uniform number is a hash of (seed, step, a, b): it does not depend on the order in which threads
reach it, so stochastic decisions made inside the step loop are reproducible for any thread count.
"""

import numpy as np
from numba import njit

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)


@njit(inline="always", cache=True)
def _splitmix(z):
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    return z ^ (z >> np.uint64(31))


@njit(cache=True)
def hash_uniform(seed, step, a, b):
    """Uniform number in [0, 1) determined by four integers (splitmix64 finaliser chain)."""
    z = _splitmix(np.uint64(seed) + _GOLDEN)
    z = _splitmix(z ^ (np.uint64(step) + _GOLDEN))
    z = _splitmix(z ^ (np.uint64(a) + _GOLDEN))
    z = _splitmix(z ^ (np.uint64(b) + _GOLDEN))
    return (z >> np.uint64(11)) * (1.0 / 9007199254740992.0)
