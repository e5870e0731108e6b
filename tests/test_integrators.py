"""The compiled integrators and a kinematic body against closed forms written here.

- The integrators inside the compiled loop on a damped linear oscillator (a particle pressed into a
  plane by a constant body force): observed order, the Verlet phase-error constant
  w^3 dt^2 t / 24, and step-by-step agreement with the textbook recurrences (velocity Verlet with
  predicted velocities for the dashpot; 6-value Gear with the Allen & Tildesley table E.2
  coefficients) coded here in a different form (amplification matrix, scaled Pascal form).
- Stability: Verlet bound w dt = 2 (closed form), Gear bound from the spectral radius of its
  amplification matrix, bounded just below, growing at the predicted rate just above.
- A rotating kinematic body: Rodrigues pose (scipy's rotation), and the work it does on an
  elastic, frictionless particle equal to that particle's kinetic energy gain and to
  rate x (angular impulse about the body's axis).
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from millsim.engine.oscillator_stability import stability_dt

from helpers import clipped_damping_ratio
from one_particle import (
    BODY_HERTZ,
    K_N,
    MASS,
    W0,
    WALL_GEAR,
    WALL_VERLET,
    R,
    make_sim,
    perpendicular_basis,
    unit,
)

# ---- 1. integrators in the compiled loop: damped linear oscillator ----------------------------

# Textbook coefficients: 6-value Gear corrector for x'' = f(x, x') (Allen & Tildesley 1987,
# table E.2; ballmill.md section 1).
GEAR_TEXTBOOK = (3.0 / 16.0, 251.0 / 360.0, 1.0, 11.0 / 18.0, 1.0 / 6.0, 1.0 / 60.0)
XI_EQ = 0.1 * R  # equilibrium overlap under the pressing force
AMP = 0.5 * XI_EQ  # initial extra compression: the contact never opens (clip irrelevant)


def _on_the_plane(spec, z, restitution, **kw):
    """A particle at height z over the plane z = 0, pressed into it by a body force (gravity
    scaled so that the equilibrium overlap is XI_EQ = 0.1 R)."""
    return make_sim(spec, [[0.0, 0.0, z]], restitution=restitution,
                    gravity=(0, 0, -XI_EQ * K_N / MASS),
                    walls=[dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="m")],
                    **kw)


def _oscillator(spec, restitution, dt, checked=True):
    """The particle on the plane, started at rest AMP below equilibrium: y = z - z_eq obeys
    y'' = -w0^2 y - 2 zeta w0 y' while in contact. Returns the simulation and zeta."""
    sim = _on_the_plane(spec, R - XI_EQ - AMP, restitution)
    # The engine evaluates the start state's force (contact included) before the first step:
    # the scheme starts from the exact initial acceleration W0^2 AMP.
    if checked:
        sim.set_time_step(dt)
    else:
        sim.dt = dt  # beyond the refusal limit on purpose (stability tests below)
    zeta = clipped_damping_ratio(restitution)
    return sim, zeta


def _y(sim):
    return sim.particles.x[0, 2] - (R - XI_EQ)


def _exact(zeta, t):
    """y(t) of the damped oscillator from y(0) = -AMP, y'(0) = 0."""
    beta, wd = zeta * W0, W0 * math.sqrt(1 - zeta**2)
    return -AMP * math.exp(-beta * t) * (math.cos(wd * t) + beta / wd * math.sin(wd * t))


def _verlet_recurrence(zeta, dt, n):
    """This engine's Verlet on y'' = -w0^2 y - 2 zeta w0 y' as an amplification matrix on
    (y, v, a): y1 = y + dt v + dt^2 a / 2; the dashpot sees the predicted v + dt a;
    v1 = v + dt (a + a1) / 2 (docs/engine.md, Integrators)."""
    w2, g = W0**2, 2 * zeta * W0
    # a1 = -w2 y1 - g (v + dt a), as a row acting on (y, v, a)
    a1 = -w2 * np.array([1.0, dt, dt * dt / 2]) - g * np.array([0.0, 1.0, dt])
    step = np.array([[1.0, dt, dt * dt / 2],
                     np.array([0.0, 1.0, dt / 2]) + dt / 2 * a1,
                     a1])
    return (np.linalg.matrix_power(step, n) @ np.array([-AMP, 0.0, W0**2 * AMP]))[0]


def _gear_recurrence(zeta, dt, n, c=GEAR_TEXTBOOK):
    """6-value Gear (PEC, one force evaluation) in scaled form r_k = dt^k/k! y^(k): Pascal
    predictor p_k = sum_j C(j, k) r_j, error Delta = a(p) dt^2/2 - p_2, r = p + c Delta; start-up
    with r3 = r4 = r5 = 0 as the engine does (ballmill.md section 1)."""
    r = np.array([-AMP, 0.0, W0**2 * AMP * dt * dt / 2, 0.0, 0.0, 0.0])
    pascal = np.array([[math.comb(j, k) for j in range(6)] for k in range(6)], dtype=float)
    c = np.asarray(c)
    for _ in range(n):
        p = pascal @ r
        a = -W0**2 * p[0] - 2 * zeta * W0 * p[1] / dt
        r = p + c * (a * dt * dt / 2 - p[2])
    return r[0]


@pytest.mark.parametrize("spec,recurrence", [(WALL_VERLET, _verlet_recurrence),
                                             (WALL_GEAR, _gear_recurrence)])
def test_integrator_order_and_recurrence_in_compiled_loop(spec, recurrence):
    """Damped oscillator (e = 0.5, zeta = 0.255), two periods at dt = T/100, T/200, T/400.

    Expected global order 2 for both: Verlet is second order (dashpot fed v + dt a); the 6-value
    Gear starts x''', x'''' and x^(5) at zero, and that start-up error makes it second order
    too (ballmill.md section 1, check_gear.py: 2.00; ~5 only with an exact start-up). The
    engine's trajectory must also reproduce the textbook recurrence, coded here, to round-off
    (1e-11 AMP; z ~ R = 20 AMP and <= 800 steps: round-off ~1e-13 AMP). That pins the error
    constant (3.0e-4 AMP for Verlet, 2.8e-6 AMP for Gear at T/100) where the order alone would
    accept any second-order scheme: a wrong Gear coefficient (3/16 -> 3/20 shifts y by 8e-9 AMP
    at T/100) or a wrong Verlet kick cannot hide."""
    period = 2 * math.pi / W0
    errors = []
    for per_period in (100, 200, 400):
        sim, zeta = _oscillator(spec, 0.5, period / per_period)
        steps = 2 * per_period
        sim.run(steps, chunk=steps)
        y = _y(sim)
        errors.append(abs(y - _exact(zeta, steps * sim.dt)))
        assert y == pytest.approx(recurrence(zeta, sim.dt, steps), abs=1e-11 * AMP)
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    np.testing.assert_allclose(orders, 2.0, atol=0.1)


def test_gear_turns_the_spin_as_it_moves_the_centre():
    """A sphere at rest at its equilibrium overlap on a plane, sticking (friction 10), started
    sideways at V: the tangential spring's force F (along x) and its torque -L F (about y, L the
    lever) stay in a fixed ratio, so w_y' = k v_x' with k = -L m / I. The 6-value Gear is linear
    and the same for spin and velocity (its slots start at zero, the start accelerations already
    in that ratio), so w_y - k v_x must stay at its start value to rounding through the rocking,
    and k lie between -R m / I and -(R - overlap) m / I (I = 2 m R^2 / 5). A wrong coefficient in
    the spin's predictor or corrector alone breaks the ratio (seed 57, `integrators:67`, `68`,
    `89`)."""
    V = 0.01
    sim = _on_the_plane(WALL_GEAR, R - XI_EQ, 1.0, v=[[V, 0.0, 0.0]], friction=10.0)
    ratios = []
    for _ in range(40):
        sim.run(2, chunk=2)
        dv = sim.particles.v[0, 0] - V
        if abs(dv) > 0.1 * V:
            ratios.append(sim.particles.w[0, 1] / dv)
    assert abs(sim.particles.v[0, 0] - V) > 0.5 * V  # rocked well away from the start
    assert len(ratios) > 10
    np.testing.assert_allclose(ratios, ratios[0], rtol=1e-10)
    inertia = 0.4 * MASS * R * R
    assert -R * MASS / inertia <= ratios[0] <= -(R - XI_EQ) * MASS / inertia


def test_verlet_phase_error_constant():
    """Undamped (e = 1): velocity Verlet from rest gives y_n = y0 cos(n theta), cos theta =
    1 - (w dt)^2/2, so theta = w dt (1 + (w dt)^2/24 + ...): at t = 2.25 T (where cos w t = 0)
    the error is AMP sin(w t) w^3 dt^2 t / 24. The next term of theta, 3 (w dt)^5 / 640, adds
    0.1125 (w dt)^2 = 1.1e-3 relative at 64 steps per period: 3e-3 tolerance."""
    period = 2 * math.pi / W0
    for per_period in (64, 128):
        sim, _ = _oscillator(WALL_VERLET, 1.0, period / per_period)
        steps = per_period * 9 // 4
        sim.run(steps, chunk=steps)
        t = steps * sim.dt
        lead = AMP * math.sin(W0 * t) * W0**3 * sim.dt**2 * t / 24
        assert _y(sim) - _exact(0.0, t) == pytest.approx(lead, rel=3e-3)


# ---- 2. stability bounds -----------------------------------------------------------------------

def _gear_spectral_radius(h, c=GEAR_TEXTBOOK, damping=0.0):
    """Largest |eigenvalue| of one Gear step (scaled form) on y'' = -w^2 y - g y', h = w dt,
    damping = g dt (the force at the predicted position and velocity, p1 = v dt)."""
    pascal = np.array([[math.comb(j, k) for j in range(6)] for k in range(6)], dtype=float)
    # Delta = a dt^2/2 - p2 = -(h^2/2) p0 - (g dt / 2) p1 - p2
    delta = np.array([-h * h / 2, -damping / 2, -1.0, 0.0, 0.0, 0.0])
    step = (np.eye(6) + np.outer(c, delta)) @ pascal
    return max(abs(np.linalg.eigvals(step)))


@pytest.mark.parametrize("lambda_c, lambda_k", [(0.0, 1.0), (1.0, 0.0), (3.0, 7.0), (1e3, 1e8)])
def test_gear_stability_dt_is_where_the_textbook_gear_step_turns_unstable(lambda_c, lambda_k):
    """engine.oscillator_stability.stability_dt(..., "gear") (the step the lubrication limit
    quotes) against the first dt at which the Gear step coded here from the textbook
    coefficients grows (spectral radius above 1 + 1e-9, the function's own margin): a grid then
    brentq. Undamped w dt = 0.3130, damped only g dt = 0.1633 (docs/lubrication.md)."""
    def excess(dt):
        return _gear_spectral_radius(math.sqrt(lambda_k) * dt, damping=lambda_c * dt) - 1 - 1e-9

    grid = np.linspace(1e-3, 1.0, 2000) / (lambda_c + math.sqrt(lambda_k))
    first = next(k for k, dt in enumerate(grid) if excess(dt) > 0)
    dt_star = brentq(excess, grid[first - 1], grid[first], xtol=1e-15 * grid[first])
    assert stability_dt(lambda_c, lambda_k, "gear") == pytest.approx(dt_star, rel=1e-7)
    if lambda_c == 0.0:
        assert dt_star * math.sqrt(lambda_k) == pytest.approx(0.3130, abs=5e-4)
    if lambda_k == 0.0:
        assert dt_star * lambda_c == pytest.approx(0.1633, abs=5e-4)


def _window_amplitude(sim, steps):
    """Largest |y| over ``steps`` single steps (many periods: the maximum of the orbit)."""
    ys = []
    for _ in range(steps):
        sim.run(1)
        ys.append(abs(_y(sim)))
    return max(ys)


def test_verlet_stability_bound():
    """Undamped oscillator: Verlet is stable for w dt <= 2 (cos theta = 1 - h^2/2 >= -1).
    Just below (h = 1.99) |y_n| = |y0 cos n theta| <= AMP over 20000 steps; just above
    (h = 2.01) it grows by |lambda| = |1 - h^2/2| + sqrt((1 - h^2/2)^2 - 1) = 1.2213 per step.
    set_time_step would refuse these steps (limit t_c/10, w dt = 0.31), so dt is set directly:
    the point is the integrator's own bound, beyond the engine's safety margin."""
    period = 2 * math.pi / W0
    sim, _ = _oscillator(WALL_VERLET, 1.0, 1.99 / W0, checked=False)
    peaks = []
    sim.run(20000, chunk=7, observer=lambda s: peaks.append(abs(_y(s))))
    assert len(peaks) > 2800 and 20000 * sim.dt > 3000 * period
    assert AMP * 0.9 < max(peaks) <= AMP * (1 + 1e-9)
    # Above: start tiny so that 60 steps of growth (~1.6e5) stay in contact.
    h = 2.01
    sim, _ = _oscillator(WALL_VERLET, 1.0, h / W0, checked=False)
    sim.particles.x[0, 2] = R - XI_EQ - 1e-6 * AMP  # the first chunk evaluates its force
    sim.run(40, chunk=40)
    y40 = _y(sim)
    sim.run(20, chunk=20)
    y60 = _y(sim)
    c = 1 - h * h / 2
    lam = abs(c) + math.sqrt(c * c - 1)
    assert abs(y60) > 1e3 * 1e-6 * AMP
    assert abs(y60 / y40) ** (1 / 20) == pytest.approx(lam, rel=1e-6)


def test_gear_stability_bound():
    """Undamped oscillator: the 6-value Gear (3/16 ...) is stable up to w dt = h*, where the
    spectral radius of its amplification matrix (coded here) crosses 1: h* = 0.3130 (the engine
    refuses w0 dt > 0.2 as a margin, GEAR_OMEGA_DT_LIMIT; dt is set directly here for that
    reason). Below (0.95 h*) the amplitude decays as rho^N, rho - 1 = -5.9e-7; above (1.05 h*)
    it grows as rho^N, rho - 1 = +1.1e-6: over 30000 steps ln(growth) = -0.018 and +0.033,
    measured to 2e-3 (the orbit's maximum over a 300-step window, ~16 periods, misses the true
    maximum by < 1e-4; the spurious modes, |lambda| < 0.5, are gone after 100 steps)."""
    h_star = brentq(lambda h: _gear_spectral_radius(h) - 1.0, 0.25, 0.4, xtol=1e-10)
    assert h_star == pytest.approx(0.3130, abs=5e-4)
    n = 30000
    for f in (0.95, 1.05):
        h = f * h_star
        sim, _ = _oscillator(WALL_GEAR, 1.0, h / W0, checked=False)
        sim.run(100)
        before = _window_amplitude(sim, 300)
        sim.run(n - 300, chunk=n)
        after = _window_amplitude(sim, 300)
        expected = n * math.log(_gear_spectral_radius(h))
        assert math.log(after / before) == pytest.approx(expected, abs=2e-3)
        assert (after > before) == (f > 1)


# ---- 3. kinematic rotating body ----------------------------------------------------------------

def test_rotating_body_pose_and_work_on_a_struck_particle():
    """A paddle particle of a body rotating about an oblique axis strikes a free particle
    (Hertz, elastic e = 1, frictionless, no gravity). The paddle stays on the exact circle
    (pose from scipy's rotation by rate t about a); the body's work (torque x rate, summed)
    equals the struck particle's kinetic energy gain and rate x the angular momentum it gained
    about the axis (the contact force passes through both centres, so the body's torque is
    minus that). Tolerances: Verlet's energy error after a contact resolved by ~50 steps,
    O((dt/t_c)^2) = 4e-4; the angular-momentum balance is exact up to round-off (trapezoidal
    torque sum, see the rotating-cylinder test)."""
    a = unit((1.0, 2.0, 2.0))
    c = np.array([0.003, -0.002, 0.001])
    rate, arm = 25.0, 0.01  # paddle speed 0.25 m/s
    e1, e2 = perpendicular_basis(a)
    paddle0 = c + arm * e1
    # free particle (radius 1.5 R) ahead on the paddle's path, a small gap away
    r2 = 1.5 * R
    chord = R + r2 + 0.02 * R
    phi = 2 * math.asin(chord / (2 * arm))
    free0 = c + arm * (math.cos(phi) * e1 + math.sin(phi) * e2)
    sim = make_sim(BODY_HERTZ, [paddle0, free0], radius=[R, r2], restitution=1.0, friction=0.0,
                   body=[0, -1], bodies=[dict(kind="rotate", center=c, axis=a, rate=rate)],
                   impact_speed=2 * rate * arm)
    m = 1.0 / sim.particles.inv_mass[1]
    steps = int(0.004 / sim.dt)
    sim.run(steps, chunk=steps)
    p = sim.particles
    # pose of the body point at t (Rodrigues via scipy, right-handed about a)
    rot = Rotation.from_rotvec(rate * sim.time * a)
    np.testing.assert_allclose(p.x[0], c + rot.apply(paddle0 - c), rtol=0, atol=1e-12)
    np.testing.assert_allclose(p.v[0], rate * np.cross(a, p.x[0] - c), rtol=0, atol=1e-12)
    assert np.linalg.norm(p.x[1] - p.x[0]) > R + r2  # struck and gone
    ke = 0.5 * m * p.v[1] @ p.v[1]
    paddle_dir = unit(np.cross(a, paddle0 - c))  # the paddle's velocity at the start
    assert np.dot(p.v[1], paddle_dir) > 0.5 * rate * arm  # pushed the way the paddle moves
    dl = np.dot(np.cross(p.x[1] - c, m * p.v[1]), a)  # from rest: angular momentum gained
    assert sim.work(body=0) == pytest.approx(ke, rel=4e-4)
    assert sim.work(body=0) == pytest.approx(rate * dl, rel=1e-9)
    assert -np.dot(sim.angular_impulse(body=0), a) == pytest.approx(dl, rel=1e-9)
