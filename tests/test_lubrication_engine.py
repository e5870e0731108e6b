"""Lubrication (the LabStar LS1 paper) inside the compiled engine: forces, cutoffs, dynamics,
energy, stability.

Every number here comes out of real ``Simulation`` runs (the compiled loop, its Verlet or Gear
integrator, its neighbour list and its cutoffs), never from calling the lubrication kernels. The
expected values are coded in this file from the reference formulas:

- Jeffrey & Onishi (1984), J. Fluid Mech. 139, 261, leading singular terms for unequal spheres
  (also Kim & Karrila 1991 ch. 11; written out in /work/shared/reference/lubrication.md 2.1), force
  and torque assembly with n from j to i (lubrication.md 2.2);
- the sphere-plane limit (lubrication.md 2.5: Brenner 1961 / Cox & Brenner 1967 for the normal
  term);
- cutoffs (lubrication.md 3): gaps are fractions of the SMALLER diameter of a pair (2 a for a
  sphere at a wall), h_eff = max(h, h_min), nothing beyond h_max.

Pairs have radius ratio 0.5 and are run in both index orders, so a cutoff or scalar taken from the
wrong bead of the pair fails in one of them.

A force is read back from one step: the engine evaluates the start state's forces, the first step
starts with the drift x += dt v + dt^2/2 a0 and predicts the velocities to v + dt a0 (w + dt
alpha0), and evaluates the forces at that position with those velocities; after the step ``acc``
= F/m and ``alpha`` = T/I with those forces. The test follows the same chain with the formulas
(the start state's loads give a0 and alpha0; F and T at the position after the step, where the
force was evaluated, with the predicted velocities), with its own masses m = 4/3 pi a^3 rho and
I = 2/5 m a^2 (``one_step``).
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from millsim.engine import PhysicsSpec, Simulation
from millsim.models import Interaction, Lubrication, Material, MaterialTable
from millsim.models.lubrication import lubrication_dt_limit

from helpers import clipped_damping_ratio

PI = math.pi
RHO = 2500.0  # bead density [kg/m3]
ETA = 0.02  # viscosity [Pa s]
H_MIN, H_MAX = 0.001, 0.05  # gap cutoffs as fractions of the smaller diameter of a pair
A_S, A_L = 0.5e-3, 1.0e-3  # radii [m], ratio 0.5
K_OFF = 1e-6  # [N/m]: contact spring off in practice (an overlap of 1 um gives 1e-12 N)

# The stirred-mill scene's periodic variant (scenes.stirred_mill.physics_spec(True)) field for
# field; with its table's linear_history law and a Lubrication fluid it shares that compiled loop
# (numba's disk cache) with tests/test_stirred_mill.py.
WET = PhysicsSpec(dim=3, gravity=True, walls=True, bodies=True, periodic=True, energy_audit=True)
# The Gear corrector with lubrication (only the stability test needs it): the smallest variant.
WET_GEAR = PhysicsSpec(dim=3, integrator="gear", gravity=False, walls=True)
ORDERS = ("i_small", "j_small")  # particle 0 is i (the pair's first index), particle 1 is j


def make_sim(spec, x, radius, v=None, w=None, body=None, bodies=(), walls=(), gravity=(0, 0, 0),
             k_n=K_OFF, restitution=1.0, eta=ETA):
    """The one place a Simulation is built (one material "bead"; restitution 1: no dashpot)."""
    table = MaterialTable([Material("bead", RHO)],
                          {"*": Interaction(normal_stiffness=k_n, restitution=restitution,
                                            friction=0.3)}, "linear_history")
    box = ((-0.02, 0, 0), (0.04, 0, 0)) if spec.periodic else None
    return Simulation(spec, table, x=x, radius=radius, material="bead", v=v, w=w, body=body,
                      bodies=bodies, walls=walls, gravity=gravity, box=box,
                      fluid=Lubrication(eta=eta, h_min=H_MIN, h_max=H_MAX))


def plane(point=(0, 0, 0), normal=(0, 0, 1)):
    return dict(kind="plane", point=point, normal=normal, material="bead")


def mass(a):
    return RHO * 4.0 / 3.0 * PI * a**3


def inertia(a):
    return 0.4 * mass(a) * a**2


def unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


# ------------------------------------------------------------------------------------------------
# the reference formulas, coded here (lubrication.md 2.1, 2.2, 2.5)
# ------------------------------------------------------------------------------------------------

def jo84(ai, aj, h_eff, eta=ETA):
    """JO84 leading terms for spheres a_i, a_j at the gap h_eff: (X11A, Y11A, Y11B, Y21B, Y11C,
    Y12C, Y22C), beta = a_j/a_i, xi = 2 h/(a_i + a_j), L = ln(1/xi)."""
    b = aj / ai
    xi = 2.0 * h_eff / (ai + aj)
    L = math.log(1.0 / xi)
    return (6 * PI * eta * ai * (2 * b**2 / ((1 + b)**3 * xi) + b * (1 + 7 * b + b**2) / (5 * (1 + b)**3) * L),
            6 * PI * eta * ai * 4 * b * (2 + b + 2 * b**2) / (15 * (1 + b)**3) * L,
            -4 * PI * eta * ai**2 * b * (4 + b) / (5 * (1 + b)**2) * L,
            -4 * PI * eta * aj**2 * (1 + 4 * b) / (5 * (1 + b)**2) * L,
            8 * PI * eta * ai**3 * 2 * b / (5 * (1 + b)) * L,
            8 * PI * eta * ai**3 * b**2 / (10 * (1 + b)) * L,
            8 * PI * eta * aj**3 * 2 / (5 * (1 + b)) * L)


def wall_scalars(a, h_eff, eta=ETA):
    """Sphere-plane limit: (X_w, YA_w, YB_w, YC_w) with L = ln(a/h)."""
    L = math.log(a / h_eff)
    return (6 * PI * eta * a * (a / h_eff + L / 5), 6 * PI * eta * a * 8 / 15 * L,
            -4 * PI * eta * a**2 / 5 * L, 8 * PI * eta * a**3 * 2 / 5 * L)


def pair_expected(ai, aj, n, h, vij, wi, wj):
    """(F_i, T_i, T_j) of lubrication.md 2.2 with the cutoffs of the smaller bead (zero beyond
    h_max, clamped at h_min)."""
    d = 2.0 * min(ai, aj)
    if h >= H_MAX * d:
        return np.zeros(3), np.zeros(3), np.zeros(3)
    x, ya, yb11, yb21, yc11, yc12, yc22 = jo84(ai, aj, max(h, H_MIN * d))
    P = np.eye(3) - np.outer(n, n)
    Fi = -x * (n @ vij) * n - ya * (P @ vij) - yb11 * np.cross(wi, n) - yb21 * np.cross(wj, n)
    Ti = yb11 * np.cross(vij, n) - P @ (yc11 * wi + yc12 * wj)
    Tj = yb21 * np.cross(vij, n) - P @ (yc12 * wi + yc22 * wj)
    return Fi, Ti, Tj


def wall_expected(a, n, h, v, w):
    """(F, T) on a sphere at a fixed wall (lubrication.md 2.5 with the assembly of 2.2)."""
    if h >= H_MAX * 2 * a:
        return np.zeros(3), np.zeros(3)
    x, ya, yb, yc = wall_scalars(a, max(h, H_MIN * 2 * a))
    P = np.eye(3) - np.outer(n, n)
    return (-x * (n @ v) * n - ya * (P @ v) - yb * np.cross(w, n),
            yb * np.cross(v, n) - yc * (P @ w))


def pair_loads(ai, aj):
    """``loads(x, v, w)`` -> (F, T) per particle of the pair (0 = i, 1 = j) from
    :func:`pair_expected`, with the (negligible) contact spring K_OFF * overlap when they overlap."""
    def loads(x, v, w):
        r = x[0] - x[1]
        n = r / np.linalg.norm(r)
        h = np.linalg.norm(r) - ai - aj
        Fi, Ti, Tj = pair_expected(ai, aj, n, h, v[0] - v[1], w[0], w[1])
        if h < 0:
            Fi = Fi + K_OFF * (-h) * n
        return np.array([Fi, -Fi]), np.array([Ti, Tj])
    return loads


def wall_loads(a):
    """``loads(x, v, w)`` -> (F, T) of one sphere above the plane z = 0 from :func:`wall_expected`,
    with the contact spring K_OFF * overlap when it overlaps."""
    n = np.array([0.0, 0.0, 1.0])

    def loads(x, v, w):
        h = x[0, 2] - a
        F, T = wall_expected(a, n, h, v[0], w[0])
        if h < 0:
            F = F + K_OFF * (-h) * n
        return F[None], T[None]
    return loads


def one_step(sim, loads=None):
    """Run the first step of ``sim``; return (F, T, x, F_ref, T_ref): the forces and torques of
    that step (m acc, I alpha), the positions they were evaluated at, and the reference loads
    there (None without ``loads``).

    The engine evaluates the start state's forces before the first drift (issue 11 item 8a); the
    drift (integrators.verlet_drift) moves to x0 + dt v0 + dt^2/2 a0 and predicts the velocities
    to v0 + dt a0, w0 + dt alpha0, which the step's forces see. The reference follows that chain
    with the formulas coded here, ``loads(x, v, w)`` -> (F, T) per particle: a0 = F(x0, v0, w0)/m,
    alpha0 = T(x0, v0, w0)/I, then F and T at the engine's position after the step (checked
    against x0 + dt v0 + dt^2/2 a0 to 1e-9 of the step's motion, plus rounding) with the predicted
    velocities."""
    p = sim.particles
    x0, v0, w0, dt = p.x.copy(), p.v.copy(), p.w.copy(), sim.dt
    m = np.array([mass(a) for a in p.radius])
    inert = np.array([inertia(a) for a in p.radius])
    sim.run(1, threads=1)
    p = sim.particles
    x = p.x.copy()
    F_ref = T_ref = None
    if loads is not None:
        F0, T0 = loads(x0, v0, w0)
        a0, b0 = F0 / m[:, None], T0 / inert[:, None]
        np.testing.assert_allclose(x, x0 + dt * v0 + 0.5 * dt * dt * a0, rtol=0,
                                   atol=1e-9 * dt * np.abs(v0).max()
                                   + 4 * np.finfo(float).eps * np.abs(x0).max())
        F_ref, T_ref = loads(x, v0 + dt * a0, w0 + dt * b0)
    return m[:, None] * p.acc, inert[:, None] * p.alpha, x, F_ref, T_ref


def pair_radii(order):
    return (A_S, A_L) if order == "i_small" else (A_L, A_S)


def pair_sim(order, gap, n, vi, vj, wi=(0, 0, 0), wj=(0, 0, 0), k_n=K_OFF):
    """Particles 0 (i) and 1 (j) with the surface gap ``gap`` along n (from j to i)."""
    ai, aj = pair_radii(order)
    xj = np.array([0.0, 0.0, 3e-3])
    xi = xj + (ai + aj + gap) * n
    return make_sim(WET, [xi, xj], [ai, aj], v=[vi, vj], w=[wi, wj], k_n=k_n)


N_OBLIQUE = unit([0.3, -0.4, 0.866])  # an oblique line of centres


# ------------------------------------------------------------------------------------------------
# 1. the squeeze force at the cutoffs, unequal pair and sphere-wall
# ------------------------------------------------------------------------------------------------

GAPS = {"out_1.02hmax": 1.02 * H_MAX, "in_0.98hmax": 0.98 * H_MAX, "mid_0.01": 0.01,
        "at_hmin": H_MIN, "clamped_0.5hmin": 0.5 * H_MIN, "overlap_0.5hmin": -0.5 * H_MIN}


@pytest.mark.parametrize("order", ORDERS)
@pytest.mark.parametrize("gap", GAPS.values(), ids=GAPS.keys())
def test_pair_squeeze_force_at_the_cutoffs(order, gap):
    """Two free spheres (radius ratio 0.5) approaching along an oblique n at gap/d_small: no force
    just outside h_max = 0.05 d_small, the JO84 X11A squeeze force -X11A(h_eff) (n.v_ij) n just
    inside it and in between, X11A(h_min) at and below h_min = 0.001 d_small (also overlapping,
    where the contact spring K_OFF * overlap is added). F_j = -F_i.

    With the cutoffs of the larger bead, h_max and h_min double: the 1.02 h_max case gets a
    force and the clamped values change by about 2x; with X11A's beta inverted the values change
    by 2x (beta = 0.5 or 2)."""
    ai, aj = pair_radii(order)
    d_small = 2 * A_S
    n = N_OBLIQUE
    u = 1e-3  # approach speed [m/s]: both move, v_ij . n = -u
    F, _, x, F_ref, _ = one_step(pair_sim(order, gap * d_small, n, -0.6 * u * n, 0.4 * u * n),
                                 pair_loads(ai, aj))
    r = x[0] - x[1]
    n_now = r / np.linalg.norm(r)
    Fi = F_ref[0]  # at the gap the force was evaluated at (moved by the first drift)
    # scale of the force just inside h_max, for the "zero" case
    scale = np.linalg.norm(pair_expected(ai, aj, n, 0.98 * H_MAX * d_small, -u * n,
                                         np.zeros(3), np.zeros(3))[0])
    # Only rounding separates the engine from the formula (the gap loses ~log10(r/h) < 4 digits
    # to cancellation): 1e-9 relative.
    np.testing.assert_allclose(F[0], Fi, rtol=1e-9, atol=1e-9 * max(np.linalg.norm(Fi), scale))
    np.testing.assert_allclose(F[1], -F[0], rtol=1e-12, atol=1e-12 * scale)
    if gap > H_MAX:
        assert np.linalg.norm(F[0]) <= 1e-12 * scale
    else:
        assert F[0] @ n_now > 0.5 * scale  # a real squeeze force, pushing i away from j


@pytest.mark.parametrize("a", [A_S, A_L])
@pytest.mark.parametrize("gap", [g for k, g in GAPS.items() if k != "at_hmin"],
                         ids=[k for k in GAPS if k != "at_hmin"])
def test_wall_squeeze_force_at_the_cutoffs(a, gap):
    """A sphere approaching a plane at gap/(2a): no force beyond h_max = 0.05 (2a), the
    sphere-plane squeeze -X_w(h_eff) (n.v) n with X_w = 6 pi eta a (a/h + ln(a/h)/5) inside,
    X_w(h_min) at h_min = 0.001 (2a) and below (also overlapping, plus the spring)."""
    n = unit([0.0, 0.0, 1.0])
    u = 1e-3
    sim = make_sim(WET, [[0.0, 0.0, a + gap * 2 * a]], [a], v=[[0.0, 0.0, -u]], walls=[plane()])
    F, _, _, F_ref, _ = one_step(sim, wall_loads(a))
    Fe = F_ref[0]
    scale = np.linalg.norm(wall_expected(a, n, 0.98 * H_MAX * 2 * a, np.array([0, 0, -u]),
                                         np.zeros(3))[0])
    np.testing.assert_allclose(F[0], Fe, rtol=1e-9, atol=1e-9 * max(np.linalg.norm(Fe), scale))
    if gap > H_MAX:
        assert np.linalg.norm(F[0]) <= 1e-12 * scale
    else:
        assert F[0, 2] > 0.5 * scale


# ------------------------------------------------------------------------------------------------
# 1b. shear and rotation terms at one gap
# ------------------------------------------------------------------------------------------------

def _oblique_pair_motion(n):
    """Sliding and spinning fast, approaching slowly (the squeeze term is ~1/xi, the others ~ln):
    every term of lubrication.md 2.2 then matters."""
    t1 = unit(np.cross(n, [0.0, 0.0, 1.0]))
    t2 = np.cross(n, t1)
    vi = 2e-3 * t1 - 1e-3 * t2 - 0.02e-3 * n
    vj = -1e-3 * t1 + 0.5e-3 * t2 + 0.02e-3 * n
    wi = np.array([3.0, -2.0, 5.0])
    wj = np.array([-1.0, 4.0, 2.0])
    return vi, vj, wi, wj


@pytest.mark.parametrize("order", ORDERS)
def test_pair_shear_and_rotation_terms(order):
    """Unequal pair at h = 0.005 d_small with sliding, spin and approach: F_i, F_j = -F_i, T_i and
    T_j (not -T_i) from the JO84 scalars X11A, Y11A, Y11B, Y21B, Y11C, Y12C, Y22C
    (lubrication.md 2.1-2.2):
        F_i = -X11A (n.v) n - Y11A P.v - Y11B (w_i x n) - Y21B (w_j x n)
        T_i =  Y11B (v x n) - P.(Y11C w_i + Y12C w_j),  T_j = Y21B (v x n) - P.(Y12C w_i + Y22C w_j)
    """
    ai, aj = pair_radii(order)
    vi, vj, wi, wj = _oblique_pair_motion(N_OBLIQUE)
    F, T, x, F_ref, T_ref = one_step(pair_sim(order, 0.005 * 2 * A_S, N_OBLIQUE, vi, vj, wi, wj),
                                     pair_loads(ai, aj))
    r = x[0] - x[1]
    n = r / np.linalg.norm(r)
    Fi, Ti, Tj = F_ref[0], T_ref[0], T_ref[1]
    f, t = np.linalg.norm(Fi), max(np.linalg.norm(Ti), np.linalg.norm(Tj))
    np.testing.assert_allclose(F[0], Fi, rtol=1e-9, atol=1e-9 * f)
    np.testing.assert_allclose(F[1], -Fi, rtol=1e-9, atol=1e-9 * f)
    np.testing.assert_allclose(T[0], Ti, rtol=1e-9, atol=1e-9 * t)
    np.testing.assert_allclose(T[1], Tj, rtol=1e-9, atol=1e-9 * t)
    # the tangential part is not a by-product of the squeeze: it is a sizeable share
    P = np.eye(3) - np.outer(n, n)
    assert np.linalg.norm(P @ Fi) > 0.2 * f


@pytest.mark.parametrize("a", [A_S, A_L])
def test_wall_shear_and_rotation_terms(a):
    """A sphere sliding, spinning and approaching a fixed plane at h = 0.005 (2a):
    F = -X_w (n.v) n - YA_w P.v - YB_w (w x n), T = YB_w (v x n) - YC_w P.w (lubrication.md 2.5).
    A sphere sliding along +x without spin gets a drag along -x and a torque about +y (it is
    rolled forward, YB_w < 0).
    The wall receives the opposite: its impulse -F dt and, about its point p (off the sphere's
    foot, so the lever has every component), the angular impulse -((x - p) x F + T) dt, the film's
    force acting through the sphere's centre (lubrication.md 2.5)."""
    h0 = 0.005 * 2 * a
    p = np.array([0.003, -0.002, 0.0])  # on the plane z = 0 that wall_loads assumes
    for v, w in (([2e-3, -1e-3, -0.5e-3], [3.0, -2.0, 5.0]), ([2e-3, 0.0, 0.0], [0.0, 0.0, 0.0])):
        v, w = np.array(v), np.array(w)
        sim = make_sim(WET, [[0.0, 0.0, a + h0]], [a], v=[v], w=[w], walls=[plane(point=p)])
        F, T, x, F_ref, T_ref = one_step(sim, wall_loads(a))
        Fe, Te = F_ref[0], T_ref[0]
        np.testing.assert_allclose(F[0], Fe, rtol=1e-9, atol=1e-9 * np.linalg.norm(Fe))
        np.testing.assert_allclose(T[0], Te, rtol=1e-9, atol=1e-9 * np.linalg.norm(Te))
        J, L = -Fe * sim.dt, -(np.cross(x[0] - p, Fe) + Te) * sim.dt
        np.testing.assert_allclose(sim.impulse(wall=0), J, rtol=1e-9,
                                   atol=1e-9 * np.linalg.norm(J))
        np.testing.assert_allclose(sim.angular_impulse(wall=0), L, rtol=1e-9,
                                   atol=1e-9 * np.linalg.norm(L))
    assert F[0, 0] < 0 and T[0, 1] > 0


# ------------------------------------------------------------------------------------------------
# 3. momentum, angular momentum, energy
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("order", ORDERS)
def test_pair_momentum_and_angular_momentum_balance(order):
    """For several directions and motions of an unequal pair: F_j = -F_i, and the torques balance
    the moment of the pair force with the lever a_i + a_j of the leading terms (lubrication.md 2.2,
    2.6): T_i + T_j + (a_i + a_j) n x F_i = 0, while T_j differs from -T_i (by that moment)."""
    ai, aj = pair_radii(order)
    rng = np.random.default_rng(11)
    for _ in range(3):
        n = unit(rng.normal(size=3))
        vi, vj = rng.normal(size=3) * 1e-3, rng.normal(size=3) * 1e-3
        wi, wj = rng.normal(size=3) * 3.0, rng.normal(size=3) * 3.0
        F, T, x, _, _ = one_step(pair_sim(order, 0.01 * 2 * A_S, n, vi, vj, wi, wj))
        r = x[0] - x[1]
        n_now = r / np.linalg.norm(r)
        f = np.linalg.norm(F[0])
        t = np.linalg.norm(T[0]) + np.linalg.norm(T[1]) + (ai + aj) * f
        np.testing.assert_allclose(F[0] + F[1], 0.0, atol=1e-12 * f)
        np.testing.assert_allclose(T[0] + T[1] + (ai + aj) * np.cross(n_now, F[0]), 0.0,
                                   atol=1e-10 * t)
        assert np.linalg.norm(T[0] + T[1]) > 0.05 * max(np.linalg.norm(T[0]), np.linalg.norm(T[1]))


def _pair_and_sphere_near_a_plane():
    """An unequal pair (oblique approach, sliding, spins) within each other's film and a sphere
    sliding and spinning within the film of the plane z = 0: positions, velocities, spins, radii."""
    n = N_OBLIQUE
    ai, aj, aw = A_S, A_L, 0.7e-3
    xj = np.array([0.0, 0.0, 0.004])
    xi = xj + (ai + aj + 0.02 * 2 * A_S) * n
    xw = np.array([0.0, 0.005, aw + 0.01 * 2 * aw])
    u = 2e-3
    v = [-0.6 * u * n + [u, 0.5 * u, 0], 0.4 * u * n + [0, -u, 0.3 * u], [u, -0.5 * u, -0.3 * u]]
    w = [[3.0, -2.0, 5.0], [-1.0, 4.0, 2.0], [2.0, 3.0, -4.0]]
    return [xi, xj, xw], v, w, [ai, aj, aw]


def test_lubrication_only_dissipates_and_the_audit_closes():
    """An unequal pair (oblique approach, sliding, spins) and a sphere sliding and spinning near a
    fixed plane, no gravity, no contact: the kinetic energy never rises, both lubrication audit
    terms are >= 0 and never fall, and KE(0) - KE(t) equals the audited dissipation.

    Tolerance: the audit integrates the power trapezoidally at the predicted velocities, an O(dt^2)
    error; measured 6.0e-7 of the dissipated energy at this step (1.5e-7 at dt/2; the trapezoid
    starts from the power of the start state, evaluated before the first step); 1e-5 leaves a
    factor 17. A wrong sign or a lost term is an error of order 1 (each term is > 20 % of it)."""
    x, v, w, radius = _pair_and_sphere_near_a_plane()
    ai, aj, aw = radius
    sim = make_sim(WET, x, radius, v=v, w=w, walls=[plane()])
    m = np.array([mass(a) for a in radius])
    inert = np.array([inertia(a) for a in radius])

    def kinetic(p):
        return 0.5 * (m * (p.v**2).sum(1)).sum() + 0.5 * (inert * (p.w**2).sum(1)).sum()

    ke0 = kinetic(sim.particles)
    rows = []

    def observe(s):
        audit = s.energy_audit()
        p = s.particles
        rows.append((kinetic(p), audit["lubrication_normal"], audit["lubrication_tangential"],
                     min(np.linalg.norm(p.x[0] - p.x[1]) - ai - aj, p.x[2, 2] - aw)))

    sim.run(2000, chunk=10, observer=observe, threads=1)
    ke, d_n, d_t, gap = np.array(rows).T
    lost = ke0 - ke[-1]
    assert lost > 0.1 * ke0  # a real test: a tenth of the energy goes
    assert np.all(np.diff(np.r_[ke0, ke]) <= 1e-12 * ke0)  # never injected
    assert np.all(np.diff(np.r_[0.0, d_n]) >= 0) and np.all(np.diff(np.r_[0.0, d_t]) >= 0)
    assert d_n[-1] > 0.2 * lost and d_t[-1] > 0.2 * lost
    assert gap.min() > 0.005 * 2 * A_S  # no contact happened (the test's premise)
    np.testing.assert_allclose(ke0 - ke, d_n + d_t, rtol=0, atol=1e-5 * lost)


def test_a_fluid_of_zero_viscosity_does_nothing_and_audits_zero():
    """eta = 0 is allowed (a dry reference in a viscosity sweep): then the film has no force, no
    torque and no dissipation, so the same unequal pair and sphere near a plane as above move
    uniformly, spins unchanged, and both audit terms stay exactly 0, not NaN (issue 47, seed 55
    `lubrication:218`: the wall's dissipation taking YB/YA where YA = 0 wrote NaN into the audit)."""
    x, v, w, radius = _pair_and_sphere_near_a_plane()
    ai, aj, aw = radius
    sim = make_sim(WET, x, radius, v=v, w=w, walls=[plane()], eta=0.0)
    sim.set_time_step(1e-5)  # without a film the soft spring's bound is long: 2 ms in all
    sim.run(200, chunk=50, threads=1)
    p = sim.particles
    assert np.array_equal(p.v, np.array(v)) and np.array_equal(p.w, np.array(w))
    np.testing.assert_allclose(p.x, np.array(x) + np.array(v) * sim.time, rtol=0, atol=1e-15)
    audit = sim.energy_audit()
    assert audit["lubrication_normal"] == 0.0 and audit["lubrication_tangential"] == 0.0
    # the films were within reach all along (the test's premise)
    assert np.linalg.norm(p.x[0] - p.x[1]) - ai - aj < H_MAX * 2 * A_S
    assert p.x[2, 2] - aw < H_MAX * 2 * aw


# ------------------------------------------------------------------------------------------------
# 2. squeeze under a constant force, unequal spheres
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("free_small", [True, False])
def test_squeeze_under_constant_force_unequal_spheres(free_small):
    """A free bead settles under gravity, from rest at h0 = 0.9 h_max, onto a fixed sphere of the
    other size (a kinematic body particle: infinite mass, so m_eff = m_free), through the liquid,
    past h_min into the clamped range (h = 0.5 h_min; cutoffs of the smaller bead).

    Reference: m h'' = -m g - X11A(max(h, h_min)) h' with the unequal-sphere JO84 X11A coded
    here, solved by Radau (rtol 1e-10). Starting from rest, the loop's first acceleration
    (gravity) is the true one, so its Verlet is second order: measured gap errors 2.4e-6 h_min
    (small bead) and 4.1e-5 h_min (large bead, 725 steps) at the default step (0.25 of the
    lubrication stability limit), 4.0x and 4.7x less at dt/2 (4.0x and 4.7x again at dt/4).
    Tolerance 3e-4 h_min (7x the larger); at dt/2 the error must drop >= 2.5x (a first-order
    error, e.g. a start-up inconsistency, drops 2x).
    Cutoffs of the larger bead double h_min and X11A with beta inverted changes by 2x: both move
    the gap by far more than h_min/1000."""
    a_free, a_fixed = (A_S, A_L) if free_small else (A_L, A_S)
    d_small = 2 * A_S
    h_min, h_max = H_MIN * d_small, H_MAX * d_small
    g = 9.81
    m = mass(a_free)

    def X(h):
        return 0.0 if h >= h_max else jo84(a_free, a_fixed, max(h, h_min))[0]

    h0, h_end = 0.9 * h_max, 0.5 * h_min

    def reach_end(t, y):
        return y[0] - h_end

    reach_end.terminal = True
    sol = solve_ivp(lambda t, y: [y[1], (-X(y[0]) * y[1] - m * g) / m], (0.0, 10.0), [h0, 0.0],
                    method="Radau", rtol=1e-10, atol=[1e-16, 1e-14], dense_output=True,
                    events=reach_end)
    t_end = sol.t_events[0][0]
    errors = []
    for refine in (1, 2):
        sim = make_sim(WET, [[0, 0, a_free + a_fixed + h0], [0, 0, 0]], [a_free, a_fixed],
                       body=[-1, 0], bodies=[dict(kind="rotate", center=(0, 0, 0),
                                                  axis=(1, 0, 0), rate=0.0)],
                       gravity=(0, 0, -g))
        sim.set_time_step(sim.dt / refine)
        steps = int(t_end / sim.dt)
        ts, hs = [], []
        sim.run(steps, chunk=max(1, steps // 40), threads=1,
                observer=lambda s: (ts.append(s.time),  # noqa: B023 (this run's lists)
                                    hs.append(s.particles.x[0, 2] - a_free - a_fixed)))  # noqa: B023
        assert hs[-1] < h_min  # it got into the clamped range
        errors.append(np.abs(np.array(hs) - sol.sol(np.array(ts))[0]).max())
    assert errors[0] <= 3e-4 * h_min
    assert errors[1] <= errors[0] / 2.5


# ------------------------------------------------------------------------------------------------
# 4. the stability limit against the compiled integrators
# ------------------------------------------------------------------------------------------------

STEPS_TO_SEE = {"verlet": 600, "gear": 1600}


def _squeeze_amplification(sim, v0, steps, stop_at):
    """Run ``steps`` steps in blocks of 10 (stopping once |v| > stop_at v0); return (largest |v_z|
    of the last 10 blocks / v0, largest |z - z0|)."""
    z0 = sim.particles.x[0, 2]
    vz, dz = [], []
    for _ in range(steps // 10):
        sim.run(10, threads=1)
        vz.append(abs(sim.particles.v[0, 2]) / v0)
        dz.append(abs(sim.particles.x[0, 2] - z0))
        if vz[-1] > stop_at:
            break
    return max(vz[-10:]), max(dz)


@pytest.mark.parametrize("law", ["linear_history", "hertz_mindlin"])
def test_the_films_step_bound_adds_the_spring_of_a_linear_contact_only(law):
    """The film's step bound (lubrication.md 4) adds the contact spring and dashpot of a pair of
    the lightest beads, m_eff = m / 2: for a linear law k_n and its damping rate
    2 zeta sqrt(k_n / m_eff) (zeta the clipped convention's, closed form, tests/helpers.py); a
    Hertz contact, whose stiffness grows with the overlap and which has its own step bounds, adds
    none (issue 47, seed 57 `base:154`: every law without a linear spring given k_n = 1 N/m)."""
    k_n, e = 2e4, 0.6
    values = dict(restitution=e, friction=0.3)
    if law == "linear_history":
        values["normal_stiffness"] = k_n
    table = MaterialTable([Material("bead", RHO, 2e8, 0.3)], {"*": Interaction(**values)}, law)
    sim = Simulation(WET_GEAR, table, x=[[0.0, 0.0, 0.01]], radius=[A_S], material="bead",
                     fluid=Lubrication(eta=ETA, h_min=H_MIN, h_max=H_MAX))
    m = mass(A_S)
    if law == "linear_history":
        spring, dashpot = k_n, 2.0 * clipped_damping_ratio(e) * math.sqrt(k_n / (0.5 * m))
    else:
        spring, dashpot = 0.0, 0.0
    expected = lubrication_dt_limit(ETA, H_MIN * 2 * A_S, A_S, m, spring, dashpot, "gear")
    (film,) = [b for b in sim.dt_report.bounds if b.kind == "lubrication"]
    assert film.limit == pytest.approx(expected.step_bound().limit, rel=1e-12, abs=0.0)


# contact spring k_n [N/m] and restitution e of the three stability cases: the squeeze alone;
# spring, dashpot and squeeze of similar rates (sqrt(lambda_k) ~ lambda_c); a stiff spring with
# the squeeze as the only damping (sqrt(lambda_k) ~ 10 lambda_c), where the Gear boundary depends on
# the position corrector coefficient too (3/20 instead of 3/16 moves it by 4 %).
STABILITY_CASES = {"squeeze": (K_OFF, 1.0), "spring_dashpot": (1e5, 0.5), "stiff_spring": (1.5e6, 1.0)}


@pytest.mark.parametrize("integrator", ["verlet", "gear"])
@pytest.mark.parametrize("case", STABILITY_CASES)
def test_lubrication_dt_limit_is_the_compiled_integrators_boundary(integrator, case):
    """A bead (a = 0.5 mm) between two parallel planes, inside the clamped range on both sides, so
    its normal motion is exactly linear: x'' = -lambda_k x - lambda_c x' with
    lambda_c = 2 X_w(h_min)/m (+ the two dashpots 2 * 2 zeta sqrt(k/m)) and lambda_k = 2 k/m
    when it is pressed into both planes by 0.2 um (spring cases), X_w coded here
    (lubrication.md 2.5), zeta the clipped convention's (tests/helpers.py, closed form).

    lubrication_dt_limit gives dt_stable for lambda_c = (8 X11A(h_min) + X_w(h_min))/m + gamma_n
    and lambda_k = 2 k_n/m (lubrication.md 4.3-4.5). With eta scaled by 2 X_w/(8 X11A + X_w) and
    gamma_n = 4 zeta sqrt(k/m) its lambdas are this bead's (checked), so its dt_stable must be
    where the compiled loop turns unstable: at 0.98 dt_stable the squeeze decays (below 1e-2 of
    its start after 600 Verlet / 1600 Gear steps; measured <= 4e-5), at 1.02 it grows by 1e3
    within them (growth ~2.7 %/step Verlet, ~1 %/step Gear; reached after ~330 and ~900 steps).

    sim.dt is set directly: the constructor and set_time_step refuse any dt above the
    Simulation's own limit (the worst-case packing bound, ~3x below this bead's boundary, and
    the contact bounds), and this test has to step just past the boundary to see it."""
    a = A_S
    m = mass(a)
    h_min = H_MIN * 2 * a
    k_n, e = STABILITY_CASES[case]
    spring = case != "squeeze"
    zeta = clipped_damping_ratio(e)
    gap = -2e-7 if spring else 0.5 * h_min  # each side
    x_w = wall_scalars(a, h_min)[0]
    x11a = jo84(a, a, h_min)[0]
    lambda_c = 2 * x_w / m + (4 * zeta * math.sqrt(k_n / m) if spring else 0.0)
    lambda_k = 2 * k_n / m if spring else 0.0
    eta_b = ETA * 2 * x_w / (8 * x11a + x_w)
    lim = lubrication_dt_limit(eta_b, h_min, a, m, k_n if spring else 0.0,
                               4 * zeta * math.sqrt(k_n / m) if spring else 0.0, integrator)
    np.testing.assert_allclose([lim.lambda_c, lim.lambda_k], [lambda_c, lambda_k], rtol=1e-12)
    spec = WET if integrator == "verlet" else WET_GEAR
    v0 = 1e-8  # with the stop at 1e3 v0 it stays in the clamped, linear range (checked below)
    peak = {}
    for factor in (0.98, 1.02):
        sim = make_sim(spec, [[0, 0, a + gap]], [a], v=[[0, 0, v0]],
                       walls=[plane(), plane((0, 0, 2 * a + 2 * gap), (0, 0, -1))],
                       k_n=k_n, restitution=e)
        sim.dt = factor * lim.dt_stable  # past the Simulation's refusal, see the docstring
        peak[factor], moved = _squeeze_amplification(sim, v0, STEPS_TO_SEE[integrator], 1e3)
        # stayed in the linear range: clamped, and still pressed in (spring case)
        assert moved < 0.1 * min(h_min, abs(gap))
    assert peak[0.98] < 1e-2, peak  # decays
    assert peak[1.02] > 1e3, peak  # grows
