"""Drive power of the mills: what a rotating body or wall puts into the particles.

The engine books a kinematic body's work (``sim.work(body=b)``) and angular impulse
(``sim.angular_impulse(body=b)``, the load the body receives), and the same for walls
(``sim.work(wall=k)``, ``sim.angular_impulse(wall=k)``). Checked
against expectations that do not come from that bookkeeping:

- power = drive torque x angular velocity, with the angular velocity computed here from the
  scene's inputs (rpm * 2 pi / 60; n/n_c * 2 pi n_c with n_c = sqrt(g / R_eff) / (2 pi));
- the angular momentum the driven beads gain (from their own masses, radii and velocities);
- the energy balance: drive work = change of kinetic energy + dissipation (the engine's audit);
- the sign: a drive that drags particles along puts energy in.

Engine runs use the stirred mill's wet periodic variant and the ball mill's force-chain variant,
which tests/test_stirred_mill.py and tests/test_ballmill.py compile anyway: no kernel of its own.
"""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from millsim.engine import PhysicsSpec, Simulation, StepPolicy
from millsim.engine.kinematics import CYLINDER_OUTER, W_KIND
from millsim.models import Interaction, Lubrication, Material, MaterialTable
from millsim.scenes.base import RunContext, get_scene

G = 9.81
X_AXIS = np.array([1.0, 0.0, 0.0])

# The stirred mill's axially periodic variant (scenes/stirred_mill.py, physics_spec(True)); with
# the linear_history table and a Lubrication fluid it is the scene's wet loop.
WET_PERIODIC = PhysicsSpec(dim=3, gravity=True, walls=True, bodies=True, periodic=True,
                           energy_audit=True)
K_N = 1500.0  # N/m: the stirred mill's soft beads (LIGGGHTS hooke k_n of 5 MPa, 2 mm beads)
BEAD_DENSITY = 6000.0
ETA = 0.01  # Pa s


def make_sim(x, radius, material, *, dt_factor=1.0, scheme="explicit",
             box=((-0.01, 0, 0), (0.02, 0, 0)), **kw):
    """The one place a Simulation is built here: wet periodic box along x, no gravity."""
    table = MaterialTable([Material("bead", BEAD_DENSITY), Material("steel", 7800.0)],
                          {"*": Interaction(restitution=0.5, friction=0.3, normal_stiffness=K_N)},
                          "linear_history")
    return Simulation(WET_PERIODIC, table, x=x, radius=radius, material=material, gravity=(0, 0, 0),
                      box=box, step=StepPolicy(dt_factor=dt_factor),
                      fluid=Lubrication(eta=ETA, h_min=0.001, h_max=0.05, scheme=scheme), **kw)


def run_scene(name, **overrides):
    scene = get_scene(name)
    return scene.run(scene.resolve(overrides), RunContext())


def stirred_mill_sim(**overrides):
    """The stirred mill scene's Simulation, before any step (scene builder)."""
    from millsim.scenes.stirred_mill import build

    return build(get_scene("stirred_mill").resolve(overrides))[0]


# ------------------------------------------------------------------------------------------------
# independent observables of the free particles (masses from the engine, the rest from the state)
# ------------------------------------------------------------------------------------------------

def _free_state(sim):
    p = sim.particles
    free = sim.free
    m = sim.masses()[free]
    inertia = 0.4 * m * p.radius[free] ** 2  # solid spheres
    return m, inertia, p.x[free], p.v[free], p.w[free]


def angular_momentum_x(sim):
    """Angular momentum of the free spheres about the x axis through the origin."""
    m, inertia, x, v, w = _free_state(sim)
    return float((m * (x[:, 1] * v[:, 2] - x[:, 2] * v[:, 1])).sum() + (inertia * w[:, 0]).sum())


def kinetic_energy(sim):
    m, inertia, _, v, w = _free_state(sim)
    return float(0.5 * (m * (v**2).sum(1)).sum() + 0.5 * (inertia * (w**2).sum(1)).sum())


# ------------------------------------------------------------------------------------------------
# (1) a paddle and a shaft drive one bead through contact friction and the lubrication film
# ------------------------------------------------------------------------------------------------

PADDLE_RATE = 100.0  # rad/s about +x
SHAFT_RATE = 300.0  # rad/s about +x
A, RB = 1.0e-3, 0.9e-3  # paddle sphere and bead radii


def paddle_or_shaft(kind, dt_factor, ramp=0.0):
    """(sim, rate, work(sim), drive angular impulse(sim)) of one driven bead.

    paddle: a rotate body of two spheres at radius 8-10 mm sweeping (+y at z < 0) into a bead
    0.2 mm ahead, hitting it obliquely (centre 0.8 mm lower). shaft: a cylinder_outer wall of
    3.6 mm turning under a bead thrown at it radially at 0.5 m/s, 0.4 mm off the vertical.
    Both start beyond the lubrication range (h_max = 0.09 mm) and end beyond it (checked), so no
    force acts at either end and the balances below close without end corrections.
    """
    if kind == "paddle":
        R = 8e-3
        sim = make_sim([[0, 0, -R], [0, 0, -R - 2 * A], [0, A + RB + 0.2e-3, -R - 0.8 * A]],
                       [A, A, RB], ["steel", "steel", "bead"], body=[0, 0, -1],
                       bodies=[dict(kind="rotate", center=(0, 0, 0), axis=X_AXIS, rate=PADDLE_RATE,
                                    ramp=ramp)],
                       dt_factor=dt_factor)
        return (sim, PADDLE_RATE, lambda s: s.work(body=0),
                lambda s: -float(s.angular_impulse(body=0)[0]))
    Rs = 3.6e-3
    sim = make_sim([[0, 0.4e-3, Rs + RB + 0.3e-3]], [RB], ["bead"], v=[[0, 0, -0.5]],
                   walls=[dict(kind="cylinder_outer", point=(0, 0, 0), axis=X_AXIS, radius=Rs,
                               omega=SHAFT_RATE, material="steel")],
                   dt_factor=dt_factor)
    return (sim, SHAFT_RATE, lambda s: s.work(wall=0),
            lambda s: -float(s.angular_impulse(wall=0)[0]))


def drive_books(kind, dt_factor, ramp=0.0):
    sim, rate, work, impulse = paddle_or_shaft(kind, dt_factor, ramp)
    L0, K0 = angular_momentum_x(sim), kinetic_energy(sim)
    # (a ramping paddle hits later and pushes the bead longer: it is clear of it after 4 ms)
    duration = 3e-3 if kind == "shaft" else 4e-3 if ramp else 2.5e-3
    steps = int(round(duration / sim.dt))
    sim.run(steps, chunk=steps, threads=1)
    p = sim.particles
    bead = np.flatnonzero(sim.free)[0]
    if kind == "paddle":
        gaps = np.linalg.norm(p.x[:2] - p.x[bead], axis=1) - (A + RB)
    else:
        gaps = np.array([math.hypot(p.x[bead, 1], p.x[bead, 2]) - 3.6e-3 - RB])
    assert gaps.min() > 0.05 * 2 * RB  # out of the lubrication range: nothing acts at the end
    return dict(rate=rate, work=work(sim), impulse=impulse(sim), dL=angular_momentum_x(sim) - L0,
                dK=kinetic_energy(sim) - K0, dissipated=sum(sim.energy_audit().values()))


@pytest.mark.parametrize("kind", ["paddle", "shaft"])
def test_drive_work_is_torque_times_rate_and_closes_the_energy_balance(kind):
    """A rotate body (paddle) and a rotating cylinder_outer wall (shaft) each drag a bead through
    contact friction and lubrication, at the recommended step and at half of it.

    - work = (drive angular impulse) x rate: the work is booked from the same loads as the
      impulse, so they agree to rounding (rtol 1e-9);
    - drive angular impulse = angular momentum the bead gained (about the x axis, from its own
      mass, radius and velocities). Contact torques close exactly (lever arms r - xi/2);
      lubrication pair torques close about the surfaces, not the centres, which leaks
      (h / (a_i + a_j)) of the tangential lubrication impulse (h <= h_max = 0.05 d): measured
      2e-6 of the impulse, allowed 1e-4;
    - the work is positive (the drive puts energy in) and equals the bead's kinetic energy change
      plus the audited dissipation: Verlet and the trapezoidal audit are second order, so the
      residual (measured 2e-4 and 6e-4 of the work at ~50 steps per contact) must stay below
      2e-3 and shrink by at least 2.5x when the step is halved (4x expected).
    """
    residuals = []
    for dt_factor in (1.0, 0.5):
        b = drive_books(kind, dt_factor)
        assert b["work"] > 0, "the drive must put energy into the bead"
        assert b["work"] == pytest.approx(b["impulse"] * b["rate"], rel=1e-9)
        assert b["dL"] == pytest.approx(b["impulse"], rel=1e-4)
        # a lossy load: friction, damping and the film take a good part of the work (25 % for
        # the paddle, more than the work for the shaft, whose bead loses kinetic energy)
        assert b["dissipated"] > 0.1 * b["work"]
        residuals.append((b["work"] - b["dK"] - b["dissipated"]) / b["work"])
    assert abs(residuals[0]) < 2e-3, residuals
    assert abs(residuals[1]) < abs(residuals[0]) / 2.5, residuals


# x -> (2, 3, 6) / 7: an axis with three unequal components, so that a load component read in the
# wrong place, or one of them left out, shows in the work
TILT = Rotation.align_vectors([[2.0, 3.0, 6.0]], [X_AXIS])[0].as_matrix()
WIDE_BOX = ((-0.05, 0, 0), (0.1, 0, 0))  # the tilted paddle reaches x = +-7 mm


def tilted_drive_books(kind, shift=(0.0, 0.0, 0.0)):
    """The paddle above turned by TILT (rotate), or a pusher of two spheres moving along
    TILT x at 0.5 m/s into a bead 0.2 mm ahead and 0.8 mm off its line (translate); the whole
    set-up moved by ``shift`` (the paddle's centre with it)."""
    shift = np.asarray(shift)
    if kind == "rotate":
        R = 8e-3
        x = [[0, 0, -R], [0, 0, -R - 2 * A], [0, A + RB + 0.2e-3, -R - 0.8 * A]]
        body = dict(kind="rotate", center=tuple(shift), axis=TILT @ X_AXIS, rate=PADDLE_RATE)
    else:
        x = [[0, 0, 0], [-2 * A, 0, 0], [A + RB + 0.2e-3, 0, 0.8 * A]]
        body = dict(kind="translate", axis=TILT @ X_AXIS, rate=0.5)
    sim = make_sim(np.asarray(x) @ TILT.T + shift, [A, A, RB], ["steel", "steel", "bead"],
                   body=[0, 0, -1], bodies=[body], box=WIDE_BOX)
    K0 = kinetic_energy(sim)
    steps = int(round(2.5e-3 / sim.dt))
    sim.run(steps, chunk=steps, threads=1)
    p = sim.particles
    assert (np.linalg.norm(p.x[:2] - p.x[2], axis=1) - (A + RB)).min() > 0.05 * 2 * RB
    load = sim.angular_impulse(body=0) if kind == "rotate" else sim.impulse(body=0)
    return dict(rate=body["rate"], work=sim.work(body=0), along=float(load @ body["axis"]),
                load=load, dK=kinetic_energy(sim) - K0,
                dissipated=sum(sim.energy_audit().values()))


@pytest.mark.parametrize("kind", ["rotate", "translate"])
def test_a_body_books_its_work_about_a_tilted_axis(kind):
    """Issue 47, seed 57 (`reductions:23`, `:32`, `:34`): a body whose axis has three unequal
    components, (2, 3, 6) / 7. Its work is minus the load it received along the axis times its
    rate (rel 1e-9: the same loads); no two of the load's components are within a tenth of the
    largest (so one read in place of another shows); the work closes the energy balance with the
    bead's kinetic energy and the audited dissipation within 2e-3 of the work (as above); and the
    turned paddle does the work of the untilted one (the same collision turned; rel 1e-6)."""
    b = tilted_drive_books(kind)
    assert b["work"] > 0
    assert b["work"] == pytest.approx(-b["along"] * b["rate"], rel=1e-9)
    gaps = np.abs(b["load"][:, None] - b["load"][None, :])[np.triu_indices(3, 1)]
    assert gaps.min() > 0.1 * np.abs(b["load"]).max()
    assert abs(b["work"] - b["dK"] - b["dissipated"]) < 2e-3 * b["work"]
    if kind == "rotate":
        assert b["work"] == pytest.approx(drive_books("paddle", 1.0)["work"], rel=1e-6)


def test_a_turning_body_s_loads_about_its_centre_do_not_depend_on_where_it_stands():
    """The tilted paddle's collision moved as a whole, its centre from the origin to (1, -2, 3)
    mm: the paddle's work and its angular impulse about its centre, every component, are those
    of the unmoved paddle (the physics is translation invariant; rel 1e-9, measured to
    rounding). A body's moments are taken about its centre: a lever measured from the origin, or
    one of the centre's coordinates read from another column, shows only once the centre leaves
    the origin (every other body test turns about it)."""
    here = tilted_drive_books("rotate")
    there = tilted_drive_books("rotate", shift=(1e-3, -2e-3, 3e-3))
    assert here["work"] > 0
    assert there["work"] == pytest.approx(here["work"], rel=1e-9)
    np.testing.assert_allclose(there["load"], here["load"], rtol=0,
                               atol=1e-9 * np.linalg.norm(here["load"]))


def angular_momentum(sim):
    """Angular momentum vector of the free spheres about the origin."""
    m, inertia, x, v, w = _free_state(sim)
    return (m[:, None] * np.cross(x, v)).sum(0) + (inertia[:, None] * w).sum(0)


def test_a_wall_receives_the_whole_angular_impulse_vector_the_bead_gains():
    """Issue 47, seed 54 (`wall_pass:83`): the turning shaft of the test above, the bead struck
    1 mm along the axis from the wall's point, so the contact's lever has all three components.
    The wall's angular impulse about its point (the origin) is minus the bead's angular momentum
    change about it, component by component (measured 2e-15 of the whole, allowed 1e-9: one
    sphere and a wall, no pair film to leak); the angular impulses about y and z are 0.7 and
    0.2 of the one about the axis here, so a lever component read from the wrong coordinate
    shows (the x-axis balance alone does not see it)."""
    Rs = 3.6e-3
    sim = make_sim([[1e-3, 0.4e-3, Rs + RB + 0.3e-3]], [RB], ["bead"], v=[[0, 0, -0.5]],
                   walls=[dict(kind="cylinder_outer", point=(0, 0, 0), axis=X_AXIS, radius=Rs,
                               omega=SHAFT_RATE, material="steel")])
    L0 = angular_momentum(sim)
    steps = int(round(3e-3 / sim.dt))
    sim.run(steps, chunk=steps, threads=1)
    gained, received = angular_momentum(sim) - L0, sim.angular_impulse(wall=0)
    assert np.linalg.norm(received) > 0
    assert abs(received[1:]).max() > 0.1 * abs(received[0])
    np.testing.assert_allclose(-received, gained, rtol=0, atol=1e-9 * np.linalg.norm(gained))


@pytest.mark.parametrize("scheme", ["explicit", "implicit"])
def test_the_film_of_a_turning_shaft_drags_alike_about_every_axis(scheme):
    """Issue 47, seeds 55 (`lubrication:527`, `:567`): the bead at rest in the film of the turning
    shaft (gap 40 um, inside the film's 90 um, no contact), 40 degrees round and 1 mm along the
    axis from the wall's point, which is off the origin, so every offset has three nonzero
    components. The set-up turned by the cyclic permutation (x, y, z) -> (y, z, x), once and
    twice, puts the shaft along y and z: a rotation, so the bead's velocity and spin after 1 ms
    are the permuted ones (measured to round-off; 1e-9 of their size allowed), in both schemes.
    The wall's velocity at the bead has one term per pair of components; a term or a coordinate
    lost for one axis shows (all the other drive tests turn about x). The wall's work is the
    same about every axis, and is its rate times the torque it exerts along its axis: minus
    omega a . L, L its angular impulse about its point (to 1e-9 of the work; the power it books
    and the torque it receives are two sums over the same film)."""
    Rs, gap, angle = 3.6e-3, 40e-6, math.radians(40.0)
    rho = Rs + RB + gap
    point = np.array([0.4e-3, -0.3e-3, 0.5e-3])
    start = point + np.array([1e-3, rho * math.cos(angle), rho * math.sin(angle)])
    moved = []
    for k in range(3):
        sim = make_sim([np.roll(start, k)], [RB], ["bead"], scheme=scheme,
                       walls=[dict(kind="cylinder_outer", point=tuple(np.roll(point, k)),
                                   axis=np.roll(X_AXIS, k), radius=Rs, omega=SHAFT_RATE,
                                   material="steel")])
        steps = int(round(1e-3 / sim.dt))
        sim.run(steps, chunk=steps, threads=1)
        off = sim.particles.x[0] - np.roll(point, k)
        assert off @ off - (np.roll(X_AXIS, k) @ off) ** 2 > (Rs + RB) ** 2  # apart
        moved.append((sim.particles.v[0].copy(), sim.particles.w[0].copy(), sim.work(wall=0),
                      -SHAFT_RATE * np.roll(X_AXIS, k) @ sim.angular_impulse(wall=0)))
    v0, w0, work0, _ = moved[0]
    assert np.linalg.norm(v0) > 1e-3  # dragged: mm/s in 1 ms
    assert work0 > 0
    for k, (v, w, work, torque_work) in enumerate(moved):
        np.testing.assert_allclose(v, np.roll(v0, k), rtol=0, atol=1e-9 * np.linalg.norm(v0))
        np.testing.assert_allclose(w, np.roll(w0, k), rtol=0, atol=1e-9 * np.linalg.norm(w0))
        assert work == pytest.approx(work0, rel=1e-9)
        assert work == pytest.approx(torque_work, rel=1e-9)


def test_a_ramping_drive_follows_its_start_up_and_books_its_work_at_the_current_rate():
    """The paddle starts from rest and reaches its rate at constant acceleration over 2 ms; it
    hits the bead at about 1.4 ms, at three quarters of its rate, and is clear of it after 4 ms.

    - pose: the paddle's angle at the end is the closed form of a constant-acceleration start
      (rate t^2 / (2 t_r) during the ramp, rate (t - t_r / 2) after it), its particles' velocity
      and spin those of the rate at that time;
    - power: the energy balance closes as for a constant-rate drive (residual below 2e-3 and
      shrinking with the step). Booking the work at the final rate instead of the current one
      would give about twice the work.
    """
    t_r = 2e-3
    residuals = []
    for dt_factor in (1.0, 0.5):
        b = drive_books("paddle", dt_factor, ramp=t_r)
        assert b["work"] > 0
        residuals.append((b["work"] - b["dK"] - b["dissipated"]) / b["work"])
    assert abs(residuals[0]) < 2e-3, residuals
    assert abs(residuals[1]) < abs(residuals[0]) / 2.5, residuals

    sim = paddle_or_shaft("paddle", 1.0, ramp=t_r)[0]
    x0 = sim.particles.x[0].copy()
    for steps in (int(1e-3 / sim.dt), int(3e-3 / sim.dt)):  # during the ramp, then after it
        sim.run(steps - sim.step, chunk=97, threads=1)
        t = sim.time
        angle = PADDLE_RATE * t * t / (2 * t_r) if t < t_r else PADDLE_RATE * (t - t_r / 2)
        rate = PADDLE_RATE * min(t / t_r, 1.0)
        c, s_ = math.cos(angle), math.sin(angle)
        expected = [x0[0], c * x0[1] - s_ * x0[2], s_ * x0[1] + c * x0[2]]  # about +x
        np.testing.assert_allclose(sim.particles.x[0], expected, rtol=0, atol=1e-12)
        np.testing.assert_allclose(sim.particles.v[0], rate * np.cross(X_AXIS, expected),
                                   rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(sim.particles.w[0], rate * X_AXIS, rtol=1e-12, atol=0)


def test_a_negative_ramp_is_refused():
    with pytest.raises(ValueError, match=r"bodies\[0\]\.ramp"):
        paddle_or_shaft("paddle", 1.0, ramp=-1e-3)


# ------------------------------------------------------------------------------------------------
# (2) the stirred mill: agitator body and shaft wall turn at rpm * 2 pi / 60 and drive the charge
# ------------------------------------------------------------------------------------------------

STIRRED_TINY = dict(scale=0.3, slice=True, n_beads=250, eta=0.05, records_per_revolution=16,
                    cg_cells=6, seed=3)


def rad_per_s(rpm):
    return rpm * 2.0 * math.pi / 60.0


@pytest.mark.parametrize("rpm", [1500.0, 3000.0])
def test_stirred_mill_agitator_and_shaft_turn_at_the_set_speed_and_drive(rpm):
    """A quarter revolution of the tiny wet slice: the agitator spheres' measured rotation angle
    over time and their speed |v| / rho equal rpm * 2 pi / 60 (two speeds: the conversion, not a
    coincidence at one of them); the disks (rotate body) and the shaft (cylinder_outer wall)
    each book work = drive torque x that angular velocity, and both put energy in."""
    omega = rad_per_s(rpm)
    sim = stirred_mill_sim(rpm=rpm, **STIRRED_TINY)
    p = sim.particles
    agitator = np.flatnonzero(p.body == 0)
    phi0 = np.arctan2(p.x[agitator, 2], p.x[agitator, 1])
    steps = int(round(0.25 * 60.0 / rpm / sim.dt))
    sim.run(steps, chunk=steps)
    x = sim.particles.x[agitator]
    turned = np.angle(np.exp(1j * (np.arctan2(x[:, 2], x[:, 1]) - phi0)))  # wrapped to (-pi, pi]
    np.testing.assert_allclose(turned / sim.time, omega, rtol=1e-9)
    speed = np.linalg.norm(sim.particles.v[agitator], axis=1) / np.hypot(x[:, 1], x[:, 2])
    np.testing.assert_allclose(speed, omega, rtol=1e-9)

    # the disks: torque about +x the body supplies = minus the load it receives
    disk_torque_impulse = -sim.angular_impulse(body=0)[0]
    assert sim.work(body=0) == pytest.approx(disk_torque_impulse * omega, rel=1e-9)
    assert sim.work(body=0) > 0
    # the shaft: the only cylinder_outer wall
    (shaft,) = np.flatnonzero(sim.walls[:, W_KIND] == CYLINDER_OUTER)
    shaft_torque_impulse = -sim.angular_impulse(wall=shaft)[0]
    assert sim.work(wall=shaft) == pytest.approx(shaft_torque_impulse * omega, rel=1e-9)
    assert sim.work(wall=shaft) > 0, "the turning shaft must drag the beads along, not brake them"


def test_stirred_mill_results_do_not_depend_on_the_chunking():
    """The engine's chunking test with a moving body: the tiny slice run in one chunk and in
    chunks of 25 steps must give the same bits (a scene's recording interval must not steer its
    trajectory; the time once summed chunk by chunk differed in its last bit, and the slice's
    positions by 2.7e-16 m after 600 steps)."""
    states = []
    for chunk in (300, 25):
        sim = stirred_mill_sim(rpm=3000.0, **STIRRED_TINY)
        sim.run(300, chunk=chunk, threads=1)
        states.append((sim.time, sim.particles.x.copy(), sim.particles.v.copy()))
    (t_one, x_one, v_one), (t_many, x_many, v_many) = states
    assert t_one == t_many
    assert np.array_equal(x_one, x_many)
    assert np.array_equal(v_one, v_many)


def test_a_change_of_step_keeps_the_trajectory_independent_of_the_chunking():
    """The step changed mid-run (as breakage and set_time_step do): the time restarts its count
    from there, so chunks of 25 still give the bits of whole chunks, and the time is the sum of
    the two legs (100 steps of dt, then 200 of 0.8 dt)."""
    states = []
    for chunk in (None, 25):
        sim = stirred_mill_sim(rpm=3000.0, **STIRRED_TINY)
        dt = sim.dt
        sim.run(100, chunk=chunk or 100, threads=1)
        sim.set_time_step(dt=0.8 * dt)
        sim.run(200, chunk=chunk or 200, threads=1)
        states.append((sim.time, sim.particles.x.copy(), sim.particles.w.copy()))
    (t_one, x_one, w_one), (t_many, x_many, w_many) = states
    assert t_one == t_many
    assert t_one == pytest.approx(100 * dt + 200 * 0.8 * dt, rel=1e-12)
    assert np.array_equal(x_one, x_many)
    assert np.array_equal(w_one, w_many)


def test_stirred_mill_net_power_is_the_agitator_work_rate():
    """The scene's power outputs against their definition in engine quantities (1.5 revolutions
    at 1500 rpm). There is no idle (no-load) power to subtract in the model: the agitator's
    "net power" is the whole work rate of disks + shaft on the charge. So:

    - every record: agitator_power = agitator_torque x rpm * 2 pi / 60 (rtol 1e-9);
    - net_power = mean of the records after statistics_start = mean_torque x omega;
    - statistics_start is the end of the transient here (steady state detected at once), so
      net_power x (t_end - statistics_start) = energy_in, the agitator work over that window
      read from the engine's work counters (rounding only);
    - the agitator drives the charge: net_power > 0.
    """
    rpm = 1500.0
    omega = rad_per_s(rpm)
    ds, _ = run_scene("stirred_mill", rpm=rpm, revolutions=1.5, transient_revolutions=0.75,
                      **STIRRED_TINY)
    np.testing.assert_allclose(ds["agitator_power"], ds["agitator_torque"] * omega, rtol=1e-9,
                               atol=1e-12 * float(abs(ds["agitator_power"]).max()))
    t = ds["time"].values
    start = float(ds["statistics_start"])
    after = t > start + 1e-12
    net = float(ds["net_power"])
    assert net == pytest.approx(float(ds["agitator_power"].values[after].mean()), rel=1e-12)
    assert float(ds["mean_torque"]) * omega == pytest.approx(net, rel=1e-9)
    record = t[1] - t[0]
    assert int(ds["steady_state_detected"]) == 1
    assert start == pytest.approx(0.75 * 60.0 / rpm, abs=0.5 * record)
    assert net * (t[-1] - start) == pytest.approx(float(ds["energy_in"]), rel=1e-9)
    assert net > 0
    assert ds["net_power"].attrs["units"] == "W" and ds["agitator_torque"].attrs["units"] == "N m"


# ------------------------------------------------------------------------------------------------
# (3) the ball mill: drive power = drive torque x angular velocity from n / n_c
# ------------------------------------------------------------------------------------------------

def critical_speed(drum_radius, grain_radius):
    """n_c [rev/s] at which a grain touching the wall (centre at R_eff) feels zero normal force
    at the top: omega^2 R_eff = g (ballmill.md; Buchholtz et al. 2000)."""
    return math.sqrt(G / (drum_radius - grain_radius)) / (2.0 * math.pi)


@pytest.mark.parametrize("n_over_nc", [0.6, 1.3])
def test_ballmill_drive_power_is_torque_times_the_drum_rate(n_over_nc):
    """Tiny drum (2 cm, 2 mm grains, no fragmentation), 0.04 s: n_c from the formula above, and
    each record's drive_power = drive_torque x (-omega), omega = 2 pi n/n_c n_c (the drum turns
    clockwise, rate -omega about +z). Spinning the charge up from rest takes work: the drive's
    total work over the run is positive."""
    drum, grain, duration = 0.02, 0.002, 0.04
    ds, prov = run_scene("ballmill2d", n_over_nc=n_over_nc, drum_radius=drum, grain_radius=grain,
                         filling=0.3, duration=duration, transient=0.01, record_interval=0.005,
                         fragmentation=False, seed=3)
    n_c = critical_speed(drum, grain)
    assert float(ds["n_c"]) == pytest.approx(n_c, rel=1e-12)
    omega = 2.0 * math.pi * n_over_nc * n_c
    power, torque = ds["drive_power"].values, ds["drive_torque"].values
    assert np.abs(torque).max() > 0  # the charge touched the drum
    np.testing.assert_allclose(power, -omega * torque, rtol=1e-9, atol=1e-12 * np.abs(power).max())
    span = np.diff(np.r_[0.0, ds["time"].values])
    assert float((power * span).sum()) > 0
    assert prov["steps"] == round(duration / prov["dt"])
    assert ds["drive_power"].attrs["units"] == "W" and ds["drive_torque"].attrs["units"] == "N m"
    assert ds["n_c"].attrs["units"] == "s-1"
