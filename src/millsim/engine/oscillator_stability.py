"""Largest stable step of the engine's explicit integrators on the damped linear oscillator
x'' = -lambda_k x - lambda_c x' (docs/lubrication.md, "Time step (explicit scheme)";
reference/lubrication.md 4.2-4.5).

The fluid models' step bounds come from here: lubrication is a damping rate lambda_c, the contact
spring a rate lambda_k. ``verlet_half_step`` is not an engine integrator: it is classic velocity
Verlet as LAMMPS and HLGD run it, kept to compare bounds with theirs.
"""

import math

import numpy as np

from .integrators import GEAR_C0, GEAR_C1, GEAR_C3, GEAR_C4, GEAR_C5

INTEGRATORS = ("verlet", "verlet_half_step", "gear")


def _gear_map(W2, G):
    """One step of the engine's 6-value Gear scheme (integrators.gear_*) on x'' = -w^2 x - g x' (dt = 1)."""
    m = np.empty((6, 6))
    for k in range(6):
        x, v, a, b, c, d = (1.0 if j == k else 0.0 for j in range(6))
        x = x + v + a / 2 + b / 6 + c / 24 + d / 120
        v = v + a + b / 2 + c / 6 + d / 24
        a = a + b + c / 2 + d / 6
        b = b + c + d / 2
        c = c + d
        ev = -W2 * x - G * v
        da = ev - a
        m[:, k] = (x + GEAR_C0 * da / 2, v + GEAR_C1 * da / 2, ev, b + 3 * GEAR_C3 * da,
                   c + 12 * GEAR_C4 * da, d + 60 * GEAR_C5 * da)
    return m


def _spectral_radius(m):
    return float(np.max(np.abs(np.linalg.eigvals(m))))


def _gear_dt(lambda_c, lambda_k):
    """Smallest dt at which the Gear map on (lambda_k, lambda_c) goes unstable (scan + bisection)."""
    tol = 1e-9

    def stable(dt):
        return _spectral_radius(_gear_map(lambda_k * dt * dt, lambda_c * dt)) <= 1.0 + tol

    rate = lambda_c + math.sqrt(lambda_k)
    lo = 1e-3 / rate
    hi = lo
    while stable(hi):
        lo, hi = hi, hi * 1.05
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if stable(mid):
            lo = mid
        else:
            hi = mid
    return lo


def stability_dt(lambda_c, lambda_k, integrator="verlet"):
    """Largest stable dt for x'' = -lambda_k x - lambda_c x' with the given integrator.

    - ``verlet``: this engine's Verlet, whose velocity-dependent forces see v + dt a (engine.integrators):
      lambda_k dt^2/4 + lambda_c dt <= 1 (damping alone: g dt <= 1).
    - ``verlet_half_step``: classic velocity Verlet with the half-step velocity in the force
      (LAMMPS/HLGD, lubrication.md 4.2): lambda_k dt^2/2 + lambda_c dt <= 2.
    - ``gear``: this engine's 6-value Gear corrector, found numerically (damping alone:
      g dt <= 0.1633).
    """
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator: {integrator!r} is not one of {INTEGRATORS}")
    if lambda_c < 0.0 or lambda_k < 0.0 or lambda_c + lambda_k <= 0.0:
        raise ValueError(f"stability_dt: need lambda_c, lambda_k >= 0, not both 0; got "
                         f"{lambda_c:g}, {lambda_k:g}")
    if integrator == "verlet":
        return 2.0 / (lambda_c + math.sqrt(lambda_c * lambda_c + lambda_k))
    if integrator == "verlet_half_step":
        return 4.0 / (lambda_c + math.sqrt(lambda_c * lambda_c + 4.0 * lambda_k))
    return _gear_dt(lambda_c, lambda_k)
