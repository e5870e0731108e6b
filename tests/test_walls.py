"""The wall registry (engine.walls) and its torus kind.

- Every entry of the registry is reached by its dispatcher: wall_contact_bounded (and, for the
  kinds the near-walls pass may skip, wall_contact) gives what the entry's own contact function
  gives, for a declaration of each kind written here (a new kind without one fails here).
- The torus (the knuckle of a dished head): gap, normal and surface velocity against the
  nearest point of a sampled and refined surface, for random tori and points (hypothesis); a
  particle dropped into the tube settles at the analytic height (its bottom, minus m g / k); a
  particle striking it from inside or outside rebounds with the law's restitution.
- Declarations refused in one line naming the key: an unknown kind, a missing or bad key, a
  key of another kind, a kind without the spec switch it needs.
"""

import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize

from millsim.engine import PhysicsSpec, Simulation, StepPolicy
from millsim.engine.walls import (
    KINDS,
    SKIP_WHEN_FAR,
    torus_contact,
    wall_contact,
    wall_contact_bounded,
    wall_table,
)
from millsim.models import Interaction, Material, MaterialTable

from helpers import clipped_damping_ratio

# the spec and law tests/test_wall_kinds.py compiles for bounded walls: no new kernel
SPEC = PhysicsSpec(dim=3, walls=True, bounded_walls=True)
R = 1e-3  # particle radius [m]
RHO = 2500.0
K_N = 2e3  # linear normal stiffness [N/m]
MASS = RHO * 4.0 / 3.0 * math.pi * R**3
W0 = math.sqrt(K_N / MASS)

# one declaration per kind name of the registry (meshes have their own contact code)
EXAMPLES = {
    "plane": dict(point=(0.0, 0.0, -0.01), normal=(0.0, 0.3, 1.0), omega=2.0),
    "cylinder_inner": dict(point=(0.0, 0.001, 0.0), axis=(0.0, 0.0, 1.0), radius=0.03, omega=3.0),
    "cylinder_outer": dict(point=(0.0, 0.0, 0.0), axis=(1.0, 0.0, 1.0), radius=0.004, omega=-1.0),
    "annulus": dict(point=(0.0, 0.0, 0.002), axis=(0.0, 0.0, 1.0), radius=0.02, inner_radius=0.005,
                    omega=1.5),
    "frustum": dict(point=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0), start=(0.0, 0.01),
                    end=(0.02, 0.003), omega=0.5),
    "torus_inner": dict(point=(0.001, 0.0, 0.0), axis=(0.0, 0.0, 1.0), ring_radius=0.02,
                        tube_radius=0.008, omega=2.0),
    "torus_outer": dict(point=(0.0, 0.0, 0.003), axis=(1.0, 1.0, 0.0), ring_radius=0.01,
                        tube_radius=0.004, omega=-2.0),
}


def table_of(*declarations):
    """The wall table of declarations (material "m"), without a Simulation."""
    sim = SimpleNamespace(spec=SPEC, material_index=lambda name: 0, _mesh_geometry=[])
    return wall_table(sim, [dict(d, material="m") for d in declarations])


def test_every_kind_is_reached_by_its_dispatcher():
    rng = np.random.default_rng(3)
    analytic = [kind for kind in KINDS if kind.contact is not None]
    assert {kind.name for kind in analytic} == set(EXAMPLES)
    for kind in analytic:
        assert SKIP_WHEN_FAR[kind.code] == kind.far_skip
        assert not (kind.far_skip and kind.bounded)  # the near-walls pass calls wall_contact
        row = table_of(dict(EXAMPLES[kind.name], kind=kind.name))[0]
        for x in rng.uniform(-0.03, 0.03, (20, 3)):
            own = kind.contact(row, *x, R)
            assert wall_contact_bounded(row, *x, R) == own, kind.name
            if not kind.bounded:
                assert wall_contact(row, *x, R) == own, kind.name


# ---- the torus against a sampled surface -------------------------------------------------------

def _frame(a):
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(a, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


def _nearest_on_torus(p, a, ring, tube, x):
    """Nearest surface point of the torus to x: the best of a sampled grid of its surface,
    refined by a local minimisation of the distance over the two angles."""
    e1, e2 = _frame(a)

    def surface(phi, theta):
        radial = np.cos(phi)[..., None] * e1 + np.sin(phi)[..., None] * e2
        return p + (ring + tube * np.cos(theta))[..., None] * radial \
            + (tube * np.sin(theta))[..., None] * a

    phi, theta = np.meshgrid(np.linspace(0, 2 * np.pi, 181), np.linspace(0, 2 * np.pi, 91))
    d2 = ((surface(phi, theta) - x) ** 2).sum(-1)
    k = np.unravel_index(np.argmin(d2), d2.shape)
    best = minimize(lambda u: ((surface(np.array(u[0]), np.array(u[1])) - x) ** 2).sum(),
                    [phi[k], theta[k]], method="Nelder-Mead",
                    options={"xatol": 1e-12, "fatol": 1e-30, "maxiter": 4000})
    return surface(np.array(best.x[0]), np.array(best.x[1]))


@settings(max_examples=25, deadline=None)
@given(axis=st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: np.linalg.norm(v) > 0.1),
       ring=st.floats(0.01, 0.05), fraction=st.floats(0.2, 0.8), inner=st.booleans(),
       where=st.tuples(st.floats(0, 2 * np.pi), st.floats(0, 2 * np.pi), st.floats(0.05, 0.95)),
       omega=st.floats(-5, 5))
def test_torus_gap_normal_and_surface_speed_match_the_sampled_surface(axis, ring, fraction, inner,
                                                                      where, omega):
    tube = fraction * ring
    p = np.array([0.003, -0.002, 0.001])
    name = "torus_inner" if inner else "torus_outer"
    row = table_of(dict(kind=name, point=p, axis=axis, ring_radius=ring, tube_radius=tube,
                        omega=omega))[0]
    a = row[4:7]
    # a point on its side of the surface: inside the tube, or outside within a tube radius
    phi, theta, s = where
    e1, e2 = _frame(a)
    radial = math.cos(phi) * e1 + math.sin(phi) * e2
    off = s * tube if inner else tube * (1.0 + s)
    x = p + (ring + off * math.cos(theta)) * radial + off * math.sin(theta) * a
    y = _nearest_on_torus(p, a, ring, tube, x)
    gap = np.linalg.norm(x - y)
    overlap, *rest = torus_contact(row, *x, R)
    n, u = np.array(rest[:3]), np.array(rest[3:])
    assert overlap == pytest.approx(R - gap, abs=1e-9 * ring)
    np.testing.assert_allclose(n, (x - y) / gap, atol=1e-6)
    contact = x - (R - 0.5 * overlap) * n  # mid-overlap, where the loop's lever ends
    np.testing.assert_allclose(u, omega * np.cross(a, contact - p), atol=1e-12 + 1e-9 * abs(omega))


# ---- the torus in a run ------------------------------------------------------------------------

def make_sim(x, v, walls, restitution, gravity=(0.0, 0.0, 0.0)):
    table = MaterialTable([Material("m", RHO)], {"*": Interaction(
        restitution=restitution, friction=0.0, normal_stiffness=K_N)}, "linear_history")
    sim = Simulation(SPEC, table, x=np.asarray([x], float), radius=[R], material="m",
                     v=np.asarray([v], float), walls=[dict(w, material="m") for w in walls],
                     gravity=gravity, step=StepPolicy(impact_speed=1.0))
    sim.set_time_step(math.pi / W0 / 400.0)
    return sim


def test_particle_dropped_into_the_tube_settles_at_its_bottom():
    """Dropped onto the bottom of the tube of a knuckle (axis up), below the centre circle:
    it comes to rest there, sunk by m g / k."""
    ring, tube, g = 0.02, 0.008, 9.81
    p = np.array([0.001, -0.002, 0.05])
    rest = p[2] - (tube - R) - MASS * g / K_N
    sim = make_sim((p[0] + ring, p[1], rest + 2e-4), (0.0, 0.0, 0.0),
                   [dict(kind="torus_inner", point=p, axis=(0, 0, 1), ring_radius=ring,
                         tube_radius=tube)], restitution=0.3, gravity=(0.0, 0.0, -g))
    sim.run(int(0.06 / sim.dt), chunk=100000)
    x = sim.particles.x[0]
    assert x[2] == pytest.approx(rest, abs=1e-3 * MASS * g / K_N)
    assert np.hypot(x[0] - p[0], x[1] - p[1]) == pytest.approx(ring, abs=1e-12)
    assert np.linalg.norm(sim.particles.v[0]) < 1e-6


@pytest.mark.parametrize("kind", ["torus_inner", "torus_outer"])
@pytest.mark.parametrize("restitution", [0.5, 0.9])
def test_torus_rebound_with_the_laws_restitution(kind, restitution):
    """Head-on at the tube's outer equator, oblique axis: the normal velocity is reversed and
    scaled by e (the clipped linear law's closed form, as tests/test_wall_kinds.py)."""
    a = np.array([1.0, -2.0, 2.0]) / 3.0
    p = np.array([0.002, 0.0, -0.001])
    ring, tube, v_n, gap = 0.02, 0.006, 0.2, 0.02 * R
    radial, _ = _frame(a)
    side = -1.0 if kind == "torus_inner" else 1.0  # the normal at the outer equator
    n = side * radial
    x0 = p + (ring + tube) * radial + (R + gap) * n
    sim = make_sim(x0, -v_n * n, [dict(kind=kind, point=p, axis=a, ring_radius=ring,
                                       tube_radius=tube)], restitution)
    steps = int((gap / v_n + 1.3 * math.pi / W0) / sim.dt)
    sim.run(steps, chunk=steps)
    tolerance = (clipped_damping_ratio(restitution) * W0 * sim.dt + 1e-4) * v_n
    np.testing.assert_allclose(sim.particles.v[0], restitution * v_n * n, rtol=0, atol=tolerance)
    m = 1.0 / sim.particles.inv_mass[0]
    np.testing.assert_allclose(-sim.impulse(wall=0), m * (sim.particles.v[0] + v_n * n), rtol=0,
                               atol=1e-10 * m * v_n)


# ---- refusals ----------------------------------------------------------------------------------

TORUS = dict(kind="torus_inner", point=(0, 0, 0), axis=(0, 0, 1), ring_radius=0.02,
             tube_radius=0.008)


@pytest.mark.parametrize("wall,message", [
    (dict(TORUS, kind="torus"), r"walls\[0\].kind: must be one of \[.*'torus_inner'"),
    ({k: v for k, v in TORUS.items() if k != "tube_radius"},
     r"walls\[0\].tube_radius: required for a torus_inner wall"),
    (dict(TORUS, tube_radius=0.03), r"walls\[0\].tube_radius: must be below ring_radius"),
    (dict(TORUS, ring_radius=-1.0), r"walls\[0\].ring_radius: -1 is outside"),
    (dict(TORUS, radius=0.01), r"walls\[0\]: unknown keys \['radius'\] for a torus_inner wall"),
    ({k: v for k, v in TORUS.items() if k != "axis"}, r"walls\[0\].axis: required"),
    (dict(kind="cylinder_inner", point=(0, 0, 0), axis=(0, 0, 1)),
     r"walls\[0\].radius: required for a cylinder_inner wall"),
])
def test_bad_declaration_refused_in_one_line_naming_the_key(wall, message):
    with pytest.raises(ValueError, match=message) as caught:
        table_of(wall)
    assert "\n" not in str(caught.value)


def test_torus_without_bounded_walls_refused():
    sim = SimpleNamespace(spec=PhysicsSpec(dim=3, walls=True), material_index=lambda name: 0,
                          _mesh_geometry=[])
    with pytest.raises(ValueError, match=r"walls\[0\].kind: torus_inner walls need "
                                         r"PhysicsSpec\(bounded_walls=True\)"):
        wall_table(sim, [dict(TORUS, material="m")])
