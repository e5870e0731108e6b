"""Damage law of the Tavares model (Tavares et al. 2021, eqs 5-6), compiled for the step loop.

Kept apart from :mod:`millsim.models.breakage.tavares` so that the loop imports it at module level: numba
caches a kernel only when what it calls is a global (a function handed in through a closure made
every new process compile the Tavares loop again), and the loop should not pull in scipy.
"""

from numba import njit


@njit(cache=True)
def _damage_rhs(D, r, gamma):
    c = 2.0 * gamma
    return (c / (c - 5.0 * D + 5.0) * r) ** (c / 5.0)


@njit(cache=True)
def damage_fraction(r, gamma):
    """Damage D of eq 6 for energy ratio r = Ek'/(m_p E) of an unbroken event.

    D = [2g/(2g - 5D + 5) r]^(2g/5) is implicit. Its right side f(D) is increasing and convex,
    so g(D) = D - f(D) has exactly one root in (0, 1) for 0 < r < 1, and D -> 1 as r -> 1 (the
    fracture energy vanishes exactly at the breakage threshold). Fixed-point iteration from D = 0
    (as the paper does) converges monotonically from below but slowly near r = 1, so after 50
    steps the root is finished by safeguarded Newton/bisection on [D, 1].
    """
    if not (r > 0.0):  # also NaN
        return 0.0
    if r >= 1.0:
        return 1.0
    D = 0.0
    for _ in range(50):
        Dn = _damage_rhs(D, r, gamma)
        if abs(Dn - D) <= 1e-15:
            return Dn
        D = Dn
    lo, hi = D, 1.0  # g(lo) < 0 < g(hi)
    c = 2.0 * gamma
    p = c / 5.0
    for _ in range(200):
        f = _damage_rhs(D, r, gamma)
        g = D - f
        if g < 0.0:
            lo = D
        else:
            hi = D
        if hi - lo <= 1e-15:
            break
        dg = 1.0 - f * p * 5.0 / (c - 5.0 * D + 5.0)
        step_ok = False
        if dg > 0.0:
            Dn = D - g / dg
            step_ok = lo < Dn < hi
        D = Dn if step_ok else 0.5 * (lo + hi)
    return 0.5 * (lo + hi) if hi - lo <= 1e-15 else D
