"""Time integrators, per particle: velocity Verlet and the 6-value Gear predictor-corrector.

Each step is "start" (Verlet drift / Gear predictor) before the forces are evaluated and "finish"
(Verlet kick / Gear corrector) after; the step loop calls them per particle. Plain functions of
array rows and scalars, so the same source compiles for CPU threads and for a GPU.
"""

from numba import njit

INTEGRATORS = ("verlet", "gear")

# Gear 6-value corrector for velocity-dependent forces (Allen & Tildesley table E.2).
GEAR_C0, GEAR_C1, GEAR_C3, GEAR_C4, GEAR_C5 = 3.0 / 16.0, 251.0 / 360.0, 11.0 / 18.0, 1.0 / 6.0, 1.0 / 60.0
GEAR_SLOTS = 6  # x''', x'''', x''''' and the same three for rotation

# Explicit stability of a pure decay v' = -g v (docs/lubrication.md): g dt <= 1 for this engine's
# Verlet (dashpots see v + dt a), g dt <= 0.163 for the 6-value Gear corrector.
DAMPING_LIMIT = {"verlet": 1.0, "gear": 0.163}
# Undamped linear oscillator: the Gear corrector goes unstable near w0 dt = 0.25 with damping
# (ballmill.md section 1); the engine keeps w0 dt <= 0.2.
GEAR_OMEGA_DT_LIMIT = 0.2


@njit(inline="always", cache=True)
def verlet_drift(i, dt, x, v, w, acc, alpha):
    """Velocity Verlet drift, leaving the velocities *predicted* to t + dt (v + dt a).

    Forces that depend on velocity (dashpots, friction) then see a second-order estimate of
    v(t + dt) instead of the half-step velocity, which would make the scheme first order for them;
    :func:`verlet_kick` turns the prediction into the exact Verlet velocity, so for
    velocity-independent forces this is velocity Verlet to the letter.
    """
    for a in range(3):
        x[i, a] += dt * (v[i, a] + 0.5 * dt * acc[i, a])
        v[i, a] += dt * acc[i, a]
        w[i, a] += dt * alpha[i, a]


@njit(inline="always", cache=True)
def verlet_kick(i, dt, v, w, acc, alpha, a0, a1, a2, b0, b1, b2):
    """Second half kick: v(t+dt) = v(t) + dt (a(t) + a(t+dt)) / 2, from the predicted velocity."""
    v[i, 0] += 0.5 * dt * (a0 - acc[i, 0])
    v[i, 1] += 0.5 * dt * (a1 - acc[i, 1])
    v[i, 2] += 0.5 * dt * (a2 - acc[i, 2])
    w[i, 0] += 0.5 * dt * (b0 - alpha[i, 0])
    w[i, 1] += 0.5 * dt * (b1 - alpha[i, 1])
    w[i, 2] += 0.5 * dt * (b2 - alpha[i, 2])
    acc[i, 0], acc[i, 1], acc[i, 2] = a0, a1, a2
    alpha[i, 0], alpha[i, 1], alpha[i, 2] = b0, b1, b2


@njit(inline="always", cache=True)
def gear_predict(i, dt, x, v, w, acc, alpha, gear):
    """Taylor predictor of the 6-value Gear scheme for translation and rotation."""
    h2 = dt * dt / 2.0
    h3 = h2 * dt / 3.0
    h4 = h3 * dt / 4.0
    h5 = h4 * dt / 5.0
    for a in range(3):
        b, c, d = gear[i, 0, a], gear[i, 1, a], gear[i, 2, a]
        x[i, a] += dt * v[i, a] + h2 * acc[i, a] + h3 * b + h4 * c + h5 * d
        v[i, a] += dt * acc[i, a] + h2 * b + h3 * c + h4 * d
        acc[i, a] += dt * b + h2 * c + h3 * d
        gear[i, 0, a] = b + dt * c + h2 * d
        gear[i, 1, a] = c + dt * d
        b, c, d = gear[i, 3, a], gear[i, 4, a], gear[i, 5, a]
        w[i, a] += dt * alpha[i, a] + h2 * b + h3 * c + h4 * d
        alpha[i, a] += dt * b + h2 * c + h3 * d
        gear[i, 3, a] = b + dt * c + h2 * d
        gear[i, 4, a] = c + dt * d


@njit(inline="always", cache=True)
def gear_correct(i, dt, x, v, w, acc, alpha, gear, a0, a1, a2, b0, b1, b2):
    """Corrector of the 6-value Gear scheme, given the evaluated accelerations (a, angular b)."""
    for a in range(3):
        ev = a0 if a == 0 else (a1 if a == 1 else a2)
        dA = ev - acc[i, a]
        x[i, a] += GEAR_C0 * dA * dt * dt / 2.0
        v[i, a] += GEAR_C1 * dA * dt / 2.0
        acc[i, a] = ev
        gear[i, 0, a] += GEAR_C3 * dA * 3.0 / dt
        gear[i, 1, a] += GEAR_C4 * dA * 12.0 / (dt * dt)
        gear[i, 2, a] += GEAR_C5 * dA * 60.0 / (dt * dt * dt)
        ev = b0 if a == 0 else (b1 if a == 1 else b2)
        dA = ev - alpha[i, a]
        w[i, a] += GEAR_C1 * dA * dt / 2.0
        alpha[i, a] = ev
        gear[i, 3, a] += GEAR_C3 * dA * 3.0 / dt
        gear[i, 4, a] += GEAR_C4 * dA * 12.0 / (dt * dt)
        gear[i, 5, a] += GEAR_C5 * dA * 60.0 / (dt * dt * dt)
