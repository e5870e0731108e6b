"""Compiled pieces the laws share: the split of the relative velocity and the tangential spring."""

import math

from numba import njit

from ...engine.jit_options import FAST


@njit(inline="always", cache=True, fastmath=FAST)
def _split(n0, n1, n2, v0, v1, v2):
    """Normal speed and tangential velocity components of vrel."""
    vn = v0 * n0 + v1 * n1 + v2 * n2
    return vn, v0 - vn * n0, v1 - vn * n1, v2 - vn * n2


@njit(inline="always", cache=True, fastmath=FAST)
def _spring_friction(kt, ct, mu_fn, t0, t1, t2, n0, n1, n2, hist, k, dt):
    """Tangential spring + dashpot with Coulomb limit; returns the tangential force on i.

    The stored spring is first projected on the current tangent plane (keeping its length) so that it
    follows the rotating contact, then advanced by v_t dt. While sliding, the trial force is scaled to
    the Coulomb limit and the spring reset to carry it alone (MUSEN convention).
    """
    h0 = hist[k, 0]
    h1 = hist[k, 1]
    h2 = hist[k, 2]
    hn = h0 * n0 + h1 * n1 + h2 * n2
    if hn != 0.0:
        h0 -= hn * n0
        h1 -= hn * n1
        h2 -= hn * n2
        new = h0 * h0 + h1 * h1 + h2 * h2
        if hn * hn < 0.01 * new:
            # Restore the length after a small rotation of the contact plane: sqrt(1 + hn^2/new)
            # to second order. A spring (nearly) along the normal is round-off and is dropped.
            scale = 1.0 + 0.5 * hn * hn / new
            h0 *= scale
            h1 *= scale
            h2 *= scale
    h0 += t0 * dt
    h1 += t1 * dt
    h2 += t2 * dt
    f0 = -kt * h0 - ct * t0
    f1 = -kt * h1 - ct * t1
    f2 = -kt * h2 - ct * t2
    f2sum = f0 * f0 + f1 * f1 + f2 * f2
    if f2sum > mu_fn * mu_fn:
        scale = mu_fn / math.sqrt(f2sum)
        f0 *= scale
        f1 *= scale
        f2 *= scale
        h0, h1, h2 = -f0 / kt, -f1 / kt, -f2 / kt
    hist[k, 0] = h0
    hist[k, 1] = h1
    hist[k, 2] = h2
    return f0, f1, f2
