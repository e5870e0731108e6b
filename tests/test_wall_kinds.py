"""Walls and kinematic walls against closed forms written here.

- A particle against every wall kind (plane, drum shell ``cylinder_inner``, shaft
  ``cylinder_outer``), oblique and negative normals, several azimuths, axes not along z: rebound
  direction, restitution of the clipped linear spring-dashpot (closed form derived below), wall
  impulse equal and opposite to the particle's momentum change; rotating cylinders drag the
  particle along omega a x r (Coulomb sliding, |J_t| = mu J_n) and put in work = omega x the
  angular impulse the particle received about the axis; a ball on a plane turning about its
  normal (a turntable) circles at 2/7 of the table's rate; an annulus reflects like a plane on
  either face, about the line to the nearest rim point at its rims, lets a particle through its
  hole; a hopper cone reflects about its normal from either side, a bounded shell ends at its
  rim; turning disks and cones drag like the rotating cylinders. A translating plane hits a
  resting particle as a static one is hit (Galilean invariance, to rounding) and carries one
  riding on it at its speed, giving m g V.
"""

import math

import numpy as np
import pytest

from millsim.engine import PhysicsSpec, Simulation
from millsim.models import Interaction, Material, MaterialTable

from helpers import clipped_damping_ratio, clipped_linear_restitution
from one_particle import (
    K_N,
    MASS,
    RHO,
    W0,
    WALL_BOUNDED,
    WALL_TRANSLATING,
    WALL_VERLET,
    ZERO_G,
    R,
    make_sim,
    perpendicular_basis,
    unit,
)

# Contact resolved by ~400 steps.
DT_WALL = math.pi / W0 / 400.0
V_N = 0.2  # normal impact speed [m/s]; largest overlap V_N / W0 = 0.014 R
GAP = 0.02 * R


def _rebound_tolerance(restitution):
    """Error bound of the rebound velocity / V_N at DT_WALL. The dashpot force jumps from 0 to
    c V_N at contact onset, which falls somewhere inside a step; the trapezoidal kick misses at
    most half a step of that jump: c V_N dt / (2 m) = zeta w0 dt V_N (first order in dt). The
    rest is O((w0 dt)^2) = 6e-5: 1e-4 allowed."""
    return clipped_damping_ratio(restitution) * W0 * DT_WALL + 1e-4


def _collide(walls, x0, v0, restitution=0.5, friction=0.0):
    """Run one particle into the walls until it has left them; return the simulation and m."""
    bounded = any(w["kind"] in ("frustum", "annulus") for w in walls)
    sim = make_sim(WALL_BOUNDED if bounded else WALL_VERLET, [x0], [v0], restitution=restitution,
                   friction=friction, walls=walls)
    sim.set_time_step(DT_WALL)
    # approach + the whole (undamped) contact time + a margin to leave
    steps = int((GAP / V_N + 1.3 * math.pi / W0) / DT_WALL)
    sim.run(steps, chunk=steps)
    return sim, 1.0 / sim.particles.inv_mass[0]


def _assert_impulses_balance(sim, m, v0):
    """Velocity Verlet: m (v_N - v_0) = sum_k F_k dt exactly when the force is zero at both ends
    (apart at start and end); the wall accumulates -F_k dt each step: equal and opposite."""
    dp = m * (sim.particles.v[0] - v0)
    np.testing.assert_allclose(-sim.impulse(wall=0), dp, rtol=0, atol=1e-10 * m * V_N)


# ---- 1. rebound from every wall kind ----------------------------------------------------------

PLANES = [  # (point, normal): axis-aligned, negative, oblique
    ((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    ((0.01, -0.02, 0.003), (0.0, -1.0, 0.0)),
    ((-0.004, 0.002, 0.0), (-1.0, 0.0, 0.0)),
    ((0.001, 0.002, -0.003), (1.0, 2.0, -2.0)),
    ((0.0, 0.005, 0.0), (-0.6, 0.0, -0.8)),
]


@pytest.mark.parametrize("point,normal", PLANES)
@pytest.mark.parametrize("restitution", [0.5, 0.9])
def test_plane_rebound_reflects_about_its_normal(point, normal, restitution):
    """Frictionless oblique impact: the tangential velocity is kept, the normal one reversed and
    scaled by the asked e; wall impulse = -m dv."""
    n = unit(normal)
    t, _ = perpendicular_basis(n)
    x0 = np.asarray(point) + (R + GAP) * n + 3e-3 * t
    v0 = -V_N * n + 0.15 * t
    wall = dict(kind="plane", point=point, normal=normal, material="m")
    sim, m = _collide([wall], x0, v0, restitution)
    e = restitution
    assert np.dot(sim.particles.x[0] - np.asarray(point), n) > R  # it has left the plane
    np.testing.assert_allclose(sim.particles.v[0], 0.15 * t + e * V_N * n, rtol=0,
                               atol=_rebound_tolerance(restitution) * V_N)
    _assert_impulses_balance(sim, m, v0)
    # Velocity Verlet changes (x - p) x m v by the trapezoidal sum of the torques about p, the
    # plain sum when the force is zero at both ends; frictionless, the force lies along n, so its
    # torque is (x - p) x F whatever the lever to the contact point: the wall's angular impulse
    # about its point is minus that change, every component (the drum tests read the axis's only).
    lever0, lever1 = x0 - np.asarray(point), sim.particles.x[0] - np.asarray(point)
    dl = np.cross(lever1, m * sim.particles.v[0]) - np.cross(lever0, m * v0)
    np.testing.assert_allclose(-sim.angular_impulse(wall=0), dl, rtol=0,
                               atol=1e-9 * m * V_N * np.linalg.norm(lever0))


CYLINDERS = [  # (axis point, axis, azimuth of the impact point [deg])
    ((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 0.0),
    ((0.002, -0.001, 0.004), (0.0, 0.0, -1.0), 135.0),
    ((0.0, 0.003, 0.0), (1.0, 0.0, 0.0), 250.0),
    ((0.001, 0.002, -0.003), (2.0, -1.0, 2.0), 40.0),
    ((-0.002, 0.0, 0.001), (-1.0, 3.0, 1.0), 300.0),
]
R_DRUM, R_SHAFT = 0.01, 0.004


def _cylinder_start(kind, point, axis, azimuth_deg, v_axial):
    """Start next to the cylinder at the given azimuth, moving radially into it (plus an axial
    velocity); returns the wall, x0, v0, the wall's unit normal there (pointing to the side the
    particle is on) and the unit axis."""
    a = unit(axis)
    e1, e2 = perpendicular_basis(a)
    phi = math.radians(azimuth_deg)
    u = math.cos(phi) * e1 + math.sin(phi) * e2  # radial direction from the axis
    if kind == "cylinder_inner":
        rho, n = R_DRUM - R - GAP, -u  # inside a drum: the wall pushes towards the axis
    else:
        rho, n = R_SHAFT + R + GAP, u  # outside a shaft: the wall pushes away from it
    x0 = np.asarray(point) + 0.003 * a + rho * u
    v0 = -V_N * n + v_axial * a
    wall = dict(kind=kind, point=point, axis=axis, radius=R_DRUM if kind == "cylinder_inner"
                else R_SHAFT, material="m")
    return wall, x0, v0, n, a


@pytest.mark.parametrize("kind", ["cylinder_inner", "cylinder_outer"])
@pytest.mark.parametrize("point,axis,azimuth", CYLINDERS)
def test_cylinder_rebound_reflects_about_the_radial_normal(kind, point, axis, azimuth):
    """Radial impact with an axial velocity on a drum shell (from inside) and a shaft (from
    outside): the normal is radial (computed here from the axis), so the axial velocity is kept
    and the radial one reversed and scaled by e; wall impulse = -m dv."""
    wall, x0, v0, n, a = _cylinder_start(kind, point, axis, azimuth, v_axial=0.1)
    sim, m = _collide([wall], x0, v0)
    e = 0.5
    d = sim.particles.x[0] - np.asarray(point)
    rho = np.linalg.norm(d - np.dot(d, a) * a)
    assert (rho < R_DRUM - R) if kind == "cylinder_inner" else (rho > R_SHAFT + R)  # has left
    np.testing.assert_allclose(sim.particles.v[0], e * V_N * n + 0.1 * a, rtol=0,
                               atol=_rebound_tolerance(0.5) * V_N)
    _assert_impulses_balance(sim, m, v0)


# ---- 1b'. bounded walls: the annulus (disk with a hole, touched on both faces and both rims) --

R_OUT, R_IN = 0.01, 0.003
ANNULI = [((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)), ((0.002, -0.001, 0.004), (2.0, -1.0, 2.0))]


def _annulus(point, normal, omega=0.0):
    return dict(kind="annulus", point=point, normal=normal, radius=R_OUT, inner_radius=R_IN,
                omega=omega, material="m")


@pytest.mark.parametrize("point,normal", ANNULI)
@pytest.mark.parametrize("side", [1.0, -1.0])
def test_annulus_face_rebound_as_a_plane_from_either_side(point, normal, side):
    """Oblique impact on either face, between the rims: reflected about that face's normal with
    the asked e, as from a plane (closed form as above); wall impulse = -m dv."""
    a = unit(normal)
    t, _ = perpendicular_basis(a)
    n = side * a
    x0 = np.asarray(point) + (R + GAP) * n + 0.006 * t
    v0 = -V_N * n + 0.15 * t
    sim, m = _collide([_annulus(point, normal)], x0, v0)
    np.testing.assert_allclose(sim.particles.v[0], 0.15 * t + 0.5 * V_N * n, rtol=0,
                               atol=_rebound_tolerance(0.5) * V_N)
    _assert_impulses_balance(sim, m, v0)


@pytest.mark.parametrize("point,normal", ANNULI)
@pytest.mark.parametrize("rim,height", [(R_OUT, 0.0), (R_OUT, 0.6 * R), (R_IN, -0.5 * R)])
def test_annulus_rim_rebound_about_the_line_to_the_nearest_rim_point(point, normal, rim, height):
    """A particle beside the rim (outside the outer one, or in the hole by the inner one, in the
    plane or above/below it) moving at the nearest rim point: the normal is the line from that
    point (computed here from the circle) to the centre, the rebound e V_N along it."""
    a = unit(normal)
    u, _ = perpendicular_basis(a)
    c = np.asarray(point) + rim * u  # rim point
    outward = 1.0 if rim == R_OUT else -1.0  # away from the ring's material
    offset = outward * math.sqrt((R + GAP) ** 2 - height**2) * u + height * a
    n = unit(offset)
    x0 = c + offset
    v0 = -V_N * n
    sim, m = _collide([_annulus(point, normal)], x0, v0)
    np.testing.assert_allclose(sim.particles.v[0], 0.5 * V_N * n, rtol=0,
                               atol=_rebound_tolerance(0.5) * V_N)
    _assert_impulses_balance(sim, m, v0)


@pytest.mark.parametrize("point,normal", ANNULI)
def test_annulus_lets_a_particle_through_its_hole(point, normal):
    """Through the hole along the axis (hole radius 3 R): no contact, no impulse."""
    a = unit(normal)
    x0 = np.asarray(point) + (R + GAP) * a
    v0 = -V_N * a
    sim, m = _collide([_annulus(point, normal)], x0, v0)
    steps = int(3.0 * R / V_N / DT_WALL)  # on until it is a radius below the ring
    sim.run(steps, chunk=steps)
    assert np.dot(sim.particles.x[0] - np.asarray(point), a) < -R
    np.testing.assert_array_equal(sim.particles.v[0], v0)
    np.testing.assert_array_equal(sim.impulse(wall=0), np.zeros(3))


# a hopper: a truncated cone from an orifice of radius 3 mm at height 0 to 13 mm at 20 mm
CONE = dict(kind="frustum", point=(0.002, -0.001, 0.004), axis=(2.0, -1.0, 2.0),
            start=(0.0, 0.003), end=(0.02, 0.013), material="m")


def _cone_start(azimuth_deg, height, inside=True):
    """A point on the cone's sheet at the given height and azimuth, the sheet's unit normal there
    towards the inside (or outside), the meridian tangent and the axis, all from the geometry."""
    a = unit(CONE["axis"])
    e1, e2 = perpendicular_basis(a)
    phi = math.radians(azimuth_deg)
    u = math.cos(phi) * e1 + math.sin(phi) * e2
    (z0, r0), (z1, r1) = CONE["start"], CONE["end"]
    rho = r0 + (r1 - r0) * (height - z0) / (z1 - z0)
    c = np.asarray(CONE["point"]) + height * a + rho * u
    dz, dr = (z1 - z0), (r1 - r0)
    length = math.hypot(dz, dr)
    tangent = (dz * a + dr * u) / length
    n = (dr * a - dz * u) / length * (1.0 if inside else -1.0)
    return c, n, tangent, a


@pytest.mark.parametrize("azimuth,height,inside", [(0.0, 0.01, True), (130.0, 0.004, True),
                                                   (250.0, 0.015, False)])
def test_cone_rebound_reflects_about_its_normal(azimuth, height, inside):
    """A hopper wall hit from inside (or outside) with a velocity along its meridian: the normal
    is the cone's (computed here from its half-angle), the meridian velocity kept (the sheet is
    straight along it), the normal one reversed and scaled by e."""
    c, n, tangent, _ = _cone_start(azimuth, height, inside)
    x0 = c + (R + GAP) * n
    v0 = -V_N * n + 0.1 * tangent
    sim, m = _collide([CONE], x0, v0)
    np.testing.assert_allclose(sim.particles.v[0], 0.1 * tangent + 0.5 * V_N * n, rtol=0,
                               atol=_rebound_tolerance(0.5) * V_N)
    _assert_impulses_balance(sim, m, v0)


@pytest.mark.parametrize("inside", [True, False])
def test_bounded_shell_reflects_radially_on_either_side_and_ends_at_its_rim(inside):
    """A cylinder shell 10 mm long (a frustum with equal radii): hit radially inside or outside
    within its length, the rebound is radial with e; beside it, 2 mm beyond its end, a particle
    crosses its radius untouched."""
    a = unit((1.0, 0.0, 2.0))
    e1, _ = perpendicular_basis(a)
    shell = dict(kind="frustum", point=(0.0, 0.0, 0.0), axis=tuple(a), start=(0.0, R_DRUM),
                 end=(0.01, R_DRUM), material="m")
    n = -e1 if inside else e1
    x0 = 0.005 * a + R_DRUM * e1 + (R + GAP) * n
    sim, m = _collide([shell], x0, -V_N * n)
    np.testing.assert_allclose(sim.particles.v[0], 0.5 * V_N * n, rtol=0,
                               atol=_rebound_tolerance(0.5) * V_N)
    x0 = 0.01 * a + (R + 0.002) * a + R_DRUM * e1 + (R + GAP) * n
    sim, m = _collide([shell], x0, -V_N * n)
    np.testing.assert_array_equal(sim.particles.v[0], -V_N * n)


@pytest.mark.parametrize("omega", [80.0, -120.0])
@pytest.mark.parametrize("shape", ["annulus", "cone"])
def test_turning_sheet_drags_along_omega_a_x_r_and_work_is_torque_times_omega(omega, shape):
    """A particle hitting the face of a turning disk or hopper slides on it (surface speed >> its
    slip): tangential impulse along omega a x (c - p) with |J_t| = mu J_n, and the work put in
    equals omega times the angular momentum the particle gained about the axis (as for the
    cylinders; on the cone the contact point is off the particle's radius, so the surface speed
    must be taken there)."""
    mu = 0.3
    if shape == "annulus":
        point, normal = ANNULI[1]
        a = unit(normal)
        t, _ = perpendicular_basis(a)
        wall, n, c = _annulus(point, normal, omega), a, np.asarray(point) + 0.006 * t
    else:
        c, n, _, a = _cone_start(40.0, 0.01)
        wall, point = dict(CONE, omega=omega), CONE["point"]
    x0 = c + (R + GAP) * n
    v0 = -V_N * n
    sim, m = _collide([wall], x0, v0, friction=mu)
    s_dir = unit(omega * np.cross(a, c - np.asarray(point)))
    _assert_sliding_drag(sim, m, x0, v0, n, s_dir, mu, point, a, omega)


@pytest.mark.parametrize("wall,message", [
    (dict(kind="annulus", point=(0, 0, 0), normal=(0, 0, 1), radius=0.01, inner_radius=0.01,
          material="m"), r"walls\[0\].inner_radius: must be in \[0, radius = 0.01\)"),
    (dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), inner_radius=0.001, material="m"),
     r"walls\[0\]: unknown keys \[.inner_radius.\] for a plane wall"),
    (dict(kind="frustum", point=(0, 0, 0), axis=(0, 0, 1), start=(0.0, 0.01), material="m"),
     r"walls\[0\]: a frustum needs start and end"),
    (dict(kind="frustum", point=(0, 0, 0), axis=(0, 0, 1), start=(0.0, 0.01), end=(0.02, -0.01),
          material="m"), r"walls\[0\]: start .* radii >= 0"),
])
def test_bad_bounded_wall_refused_naming_the_key(wall, message):
    with pytest.raises(ValueError, match=message):
        make_sim(WALL_BOUNDED, [[0.0, 0.0, 0.005]], walls=[wall])


def test_bounded_wall_without_the_spec_refused():
    with pytest.raises(ValueError, match=r"walls\[0\].kind: annulus walls need "
                                         r"PhysicsSpec\(bounded_walls=True\)"):
        make_sim(WALL_VERLET, [[0.0, 0.0, 0.005]], walls=[_annulus((0, 0, 0), (0, 0, 1))])


def test_clipped_closed_form_against_the_ode():
    """The test's closed form is not a tautology: at the overlap-end damping ratio of e = 0.5 the
    clipped law rebounds noticeably faster than 0.5 (checked against a direct ODE solution of the
    clipped law here), which is why the engine solves for its damping from the clipped relation."""
    from scipy.integrate import solve_ivp

    zeta = -math.log(0.5) / math.sqrt(math.pi**2 + math.log(0.5) ** 2)  # overlap-end damping

    def rhs(t, s):
        f = max(K_N * s[0] + 2 * zeta * math.sqrt(MASS * K_N) * s[1], 0.0)
        return [s[1], -f / MASS]

    def leave(t, s):
        return s[0]  # overlap back to zero

    leave.terminal, leave.direction = True, -1
    sol = solve_ivp(rhs, (0, 10 * math.pi / W0), [0.0, 1.0], events=leave, rtol=1e-11,
                    atol=1e-16, max_step=math.pi / W0 / 200)
    e_ode = -sol.y_events[0][0][1]
    assert clipped_linear_restitution(zeta) == pytest.approx(e_ode, rel=1e-6)
    assert clipped_linear_restitution(zeta) > 0.5 + 0.05


# ---- 1b. rotating cylinders --------------------------------------------------------------------

def _assert_sliding_drag(sim, m, x0, v0, n, s, mu, point, a, omega):
    """A particle that slid on a moving wall the whole contact: normal impulse (1 + e) m V_N,
    tangential impulse along the surface velocity s with |J_t| = mu J_n (Coulomb), and the work
    the wall put in equal to omega times the angular momentum the particle gained about the axis
    (orbital + spin; power = torque x omega). Returns that gain."""
    p = sim.particles
    j = -sim.impulse(wall=0)  # impulse on the particle
    j_n = np.dot(j, n)
    j_t = j - j_n * n
    # The particle moves along the wall by ~ mu (1+e) V_N t_c / 2 ~ 1e-5 m during the contact,
    # turning the normal by <= 1e-5 / R_shaft = 3e-3 rad (plus the onset error of
    # _rebound_tolerance, 1.8e-3 / (1 + e)): tolerances of a few 1e-3.
    assert j_n == pytest.approx(m * V_N * (1 + 0.5), rel=3e-3)
    assert np.dot(j_t, s) > 0.0
    np.testing.assert_allclose(j_t / np.linalg.norm(j_t), s, atol=5e-3)
    assert np.linalg.norm(j_t) == pytest.approx(mu * j_n, rel=5e-3)
    # Angular momentum about the axis: (x - p) x m v + I w, projected on a.
    inertia = 0.4 * m * R**2

    def l_axis(x, v, w):
        return np.dot(np.cross(x - np.asarray(point), m * v) + inertia * w, a)

    dl = l_axis(p.x[0], p.v[0], p.w[0]) - l_axis(x0, v0, np.zeros(3))
    assert omega * dl > 0  # dragged in the sense of rotation
    # Velocity Verlet changes x x m v + I w by the trapezoidal sum of the torques (x_k x F_k plus
    # the contact torque (r_c - x_k) x F_k), which is the plain sum when the force vanishes at
    # both ends: equal to minus the wall's summed torque up to round-off. The wall's power is
    # F . omega a x r_c = omega a . (r_c x F): its work is omega dl up to round-off too.
    assert sim.work(wall=0) == pytest.approx(omega * dl, rel=1e-9)
    return dl


@pytest.mark.parametrize("kind", ["cylinder_inner", "cylinder_outer"])
@pytest.mark.parametrize("omega", [80.0, -120.0])
@pytest.mark.parametrize("point,axis,azimuth", [CYLINDERS[1], CYLINDERS[3]])
def test_rotating_cylinder_drags_particle_and_work_is_torque_times_omega(kind, omega, point, axis,
                                                                         azimuth):
    """A particle hitting a spinning drum/shaft radially slides on it the whole contact (surface
    speed omega R >> the slip it loses, 3.5 mu (1 + e) V_N): its tangential impulse points along
    the surface velocity omega a x r (computed here) with |J_t| = mu J_n (Coulomb), and the work
    the wall puts in equals omega times the angular momentum the particle gained about the axis
    (orbital + spin; power = torque x omega)."""
    mu = 0.3
    wall, x0, v0, n, a = _cylinder_start(kind, point, axis, azimuth, v_axial=0.0)
    wall["omega"] = omega
    sim, m = _collide([wall], x0, v0, friction=mu)
    p = sim.particles
    _assert_impulses_balance(sim, m, v0)
    # surface velocity direction at the contact point r_c = R_wall u (u radial): omega a x u
    u = -n if kind == "cylinder_inner" else n
    s_dir = unit(omega * np.cross(a, u))
    dl = _assert_sliding_drag(sim, m, x0, v0, n, s_dir, mu, point, a, omega)
    assert -np.dot(sim.angular_impulse(wall=0), a) == pytest.approx(dl, rel=1e-9)
    inertia = 0.4 * m * R**2
    ke_gain = 0.5 * m * (p.v[0] @ p.v[0] - v0 @ v0) + 0.5 * inertia * p.w[0] @ p.w[0]
    # friction and damping dissipate part of the work (the sign of ke_gain itself depends on e:
    # the normal loss (1 - e^2) m V_N^2 / 2 against the drag's gain)
    assert ke_gain < sim.work(wall=0)


# ---- 1c. a plane turning about its normal (turntable, drum end wall) ----------------------------

@pytest.mark.parametrize("omega,point,normal", [(10.0, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
                                                (-15.0, (0.004, -0.002, 0.001), (1.0, 2.0, 2.0))])
def test_ball_on_a_turntable_circles_at_two_sevenths_of_its_rate(omega, point, normal):
    """A sphere set down at rest on a plane turning at Omega about its normal slips until it
    rolls; from then on its centre circles at 2 Omega / 7 in the lab frame, in the table's sense,
    whatever the start (rolling without slip on the moving surface with I = 2/5 m R^2 gives
    dv/dt = (2/7) Omega a x v; Weltner 1979, Am. J. Phys. 47:984). A wrong sign or lever arm of the
    surface velocity gives another rate or sense; a static plane gives none."""
    a = unit(normal)
    p0 = np.asarray(point)
    e1, _ = perpendicular_basis(a)
    x0 = p0 + 0.02 * e1 + R * a  # resting on the table 20 mm off its axis
    sim = make_sim(WALL_VERLET, [x0], friction=0.5, walls=[dict(
        kind="plane", point=point, normal=normal, omega=omega, material="m")], gravity=-9.81 * a)
    dt = math.pi / W0 / 25.0
    sim.set_time_step(dt)
    # slip ends within (2/7) |Omega| 0.02 / (mu g) ~ 0.02 s; 0.1 s discarded
    sim.run(int(0.1 / dt), chunk=20000)
    every = 2000
    t, angle = [], []
    for k in range(int(0.5 * math.pi / abs(omega / 3.5) / (every * dt))):  # a quarter circle
        sim.run(every, chunk=every)
        v = sim.particles.v[0]
        t.append(k * every * dt)
        angle.append(math.atan2(np.dot(np.cross(e1, v), a), np.dot(e1, v)))
    v = sim.particles.v[0]
    assert abs(np.dot(v, a)) < 1e-6 * np.linalg.norm(v)  # stays on the table
    rate = np.polyfit(t, np.unwrap(angle), 1)[0]
    # elastic creep of the tangential spring and the step (t_c / 25) leave ~1e-4 (seen: 4e-5)
    assert rate == pytest.approx(2.0 * omega / 7.0, rel=1e-3)


@pytest.mark.parametrize("restitution", [0.3, 0.8])
def test_moving_plane_strikes_a_resting_particle_as_a_static_plane_is_struck(restitution):
    """Galilean invariance: a plane translating at V along its (oblique) normal that hits a
    particle at rest gives, relative to the plane, the same motion as a static plane hit by the
    particle at -V: final velocity V + the static rebound (about (1 + e) V) and the same position
    relative to the plane, to rounding (a relative velocity without the wall's, or the wall placed
    a step early or late, breaks it). The wall's work is V . (its force impulse on the particle)
    and equals the momentum it gave times V."""
    speed = 0.2
    a = unit([0.3, -0.2, 1.0])
    gap = 0.2 * R
    point = -(R + gap) * a
    dt = math.pi / W0 / 50.0
    steps = int((gap / speed + 2.0 * math.pi / W0) / dt)  # reach, then two contact times
    moving = make_sim(WALL_TRANSLATING, [[0.0, 0.0, 0.0]], restitution=restitution, walls=[dict(
        kind="plane", point=point, normal=a, velocity=speed * a, material="m")],
        impact_speed=2.0 * speed)
    static = make_sim(WALL_VERLET, [[0.0, 0.0, 0.0]], v=[-speed * a], restitution=restitution,
                      walls=[dict(kind="plane", point=point, normal=a, material="m")],
                      impact_speed=2.0 * speed)
    for sim in (moving, static):
        sim.set_time_step(dt)
        sim.run(steps)
    v = moving.particles.v[0]
    assert v - speed * a == pytest.approx(static.particles.v[0], abs=1e-12 * speed)
    assert moving.particles.x[0] - moving.walls[0, 1:4] == pytest.approx(
        static.particles.x[0] - static.walls[0, 1:4], abs=1e-9 * R)
    # the rebound itself: e at this step (t_c / 50) within 1 % of the asked one
    assert np.dot(v, a) == pytest.approx((1.0 + restitution) * speed, rel=1e-2)
    received = -moving.impulse(wall=0)  # impulse the wall gave the particle
    assert moving.work(wall=0) == pytest.approx(float(np.dot(received, speed * a)), rel=1e-12)
    assert moving.work(wall=0) == pytest.approx(MASS * np.dot(v, a) * speed, rel=1e-9)


def test_particle_rides_a_rising_plate_and_the_plate_gives_m_g_v():
    """A particle resting on a plate that rises at V under gravity: once the contact has settled
    the particle rises at V with the steady overlap m g / k, and the plate's power is m g V."""
    speed = 0.05
    g = 9.81
    wall = dict(kind="plane", point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0),
                velocity=(0.0, 0.0, speed), material="m")
    sim = make_sim(WALL_TRANSLATING, [[0.0, 0.0, R]], walls=[wall], gravity=(0.0, 0.0, -g),
                   impact_speed=2.0 * speed)
    dt = math.pi / W0 / 50.0
    sim.set_time_step(dt)
    sim.run(int(60.0 * 2.0 * math.pi / W0 / dt))  # the damped transient (zeta ~ 0.2) dies out
    w0, t0 = sim.work(wall=0), sim.time
    steps = int(5.0 * 2.0 * math.pi / W0 / dt)
    sim.run(steps)
    assert sim.particles.v[0, 2] == pytest.approx(speed, rel=1e-9)
    plate = speed * sim.time
    assert sim.particles.x[0, 2] - plate == pytest.approx(R - MASS * g / K_N, rel=1e-9)
    assert (sim.work(wall=0) - w0) / (sim.time - t0) == pytest.approx(MASS * g * speed, rel=1e-9)


def test_translating_wall_goes_on_from_where_it_is_when_its_velocity_changes():
    """set_wall(velocity=...) between chunks: the wall does not jump, it goes on from its point."""
    wall = dict(kind="plane", point=(0.0, 0.0, -0.01), normal=(0.0, 0.0, 1.0),
                velocity=(0.0, 0.0, 0.01), material="m")
    sim = make_sim(WALL_TRANSLATING, [[0.0, 0.0, 0.0]], walls=[wall], impact_speed=0.1)
    sim.run(100)
    at = sim.walls[0, 1:4].copy()
    assert at[2] == pytest.approx(-0.01 + 0.01 * sim.time, rel=1e-12)
    sim.set_wall(0, velocity=(0.002, 0.0, 0.0))
    t0 = sim.time
    sim.run(100)
    assert sim.walls[0, 1:4] == pytest.approx(at + np.array([0.002, 0.0, 0.0]) * (sim.time - t0),
                                              rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("spec,wall,message", [
    (PhysicsSpec(dim=3, walls=True), dict(velocity=(0.0, 0.0, 1.0)),
     r"walls\[0\]\.velocity: translating walls need PhysicsSpec\(translating_walls=True\)"),
    (PhysicsSpec(dim=3, walls=True, translating_walls=True), dict(velocity=(0.0, 1.0)),
     r"walls\[0\]\.velocity: must be 3 finite numbers"),
    (PhysicsSpec(dim=3, walls=True, translating_walls=True), dict(velocity=(0.0, math.nan, 0.0)),
     r"walls\[0\]\.velocity: must be 3 finite numbers"),
    (PhysicsSpec(dim=2, walls=True, translating_walls=True), dict(velocity=(0.0, 0.0, 1.0)),
     r"walls\[0\]\.velocity: a 2D run's walls move in the xy plane"),
])
def test_translating_walls_refused_where_they_cannot_work(spec, wall, message):
    mat = Material("m", RHO)
    table = MaterialTable([mat], {"*": Interaction(restitution=0.5, normal_stiffness=K_N)},
                          "linear_history")
    with pytest.raises(ValueError, match=message):
        Simulation(spec, table, x=[[0.0, 0.0, 0.002]], radius=[R], material="m",
                   walls=[dict(kind="plane", normal=(0.0, 0.0, 1.0), material="m", **wall)],
                   gravity=ZERO_G)


def test_translating_walls_need_walls():
    with pytest.raises(ValueError, match="translating_walls: needs walls=True"):
        PhysicsSpec(translating_walls=True)
