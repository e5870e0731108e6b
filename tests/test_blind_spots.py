"""Tests for the blind spots of issue 47: situations where sampled bugs survived every test.

Each expected number comes from outside the code under test: a closed form, a conservation law or
an independent computation written here.

- The pour against an existing particle larger than those it pours: no poured sphere overlaps
  it (brute-force pairwise check).
- The impact-resolution guard of turning bounded walls: a turning annulus or cone whose rim moves
  faster than the step resolves (Hertz contact time, Johnson 1985) stops the run; one just slower
  does not.
- The linear-history law's tangential dashpot: an oblique impact with stick and slip against the
  solve_ivp solution of the model.
- The Haff-Werner tangential dashpot's step bound in 2D and 3D: the critical step of the
  engine's Verlet on a pure decay (eigenvalues of its recurrence, written here) over the slip
  relaxation rate (1 + m a^2 / I) gamma_T of a disk or sphere held by three contacts.
- Analyses on small synthetic data against hand computations: the relative comminution rate
  (normalised per row along n/n_c), the viscosity interval (linear in log eta across decades),
  MSER-5 (White 1997).
- Tavares fines through a secondary breakage: parent mass = resolved spheres + fines.
- The silo's Beverloo prediction: W = C rho_b sqrt(g) (D - k d)^(5/2), C = 0.58, k = 1.5.
"""

import math

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from millsim.engine import PhysicsSpec, Simulation, SimulationError, StepPolicy
from millsim.engine.guards import check_contact_resolution
from millsim.engine.insertion import Pour
from millsim.models import Interaction, Material, MaterialTable

from helpers import PourCharge, clipped_damping_ratio

R = 1e-3
RHO = 2500.0
K_N = 2e3
MASS = RHO * 4.0 / 3.0 * math.pi * R**3
W0 = math.sqrt(K_N / MASS)
# variants other files compile already: no new kernel (tests/test_wall_kinds.py)
WALL_VERLET = PhysicsSpec(dim=3, walls=True)
BOUNDED_HERTZ = PhysicsSpec(dim=3, walls=True, bounded_walls=True)  # the silo's


# ---- the pour next to a larger particle -------------------------------------------------------

def test_a_pour_keeps_clear_of_a_larger_particle_beside_its_region():
    """A 5 mm sphere whose centre lies 4 mm outside the pouring box reaches 1 mm into it; the
    0.5 mm spheres poured must keep clear of it (and of each other) with the asked gap."""
    big, small, gap = 5e-3, 5e-4, 1e-5
    charge = PourCharge([[-4e-3, 5e-3, 5e-3]], [big], time=1.0)
    pour = Pour(lo=(0, 0, 0), hi=(0.01, 0.01, 0.01), count=300, rate=300.0, material="m",
                radii=(small,), gap=gap, seed=5, start=0.0)
    pour.fill(charge)
    x, r = charge.particles.x, charge.particles.radius
    assert pour.inserted > 250  # most of the region is free: the check ran against many places
    d = np.linalg.norm(x[:, None] - x[None], axis=2) - r[:, None] - r[None]
    np.fill_diagonal(d, np.inf)
    assert d.min() >= gap * (1 - 1e-9)
    # the region the big sphere covers was offered to the pour: some spheres sit right by it
    assert (d[0, 1:] < 2 * small).any()


# ---- the impact-resolution guard of turning bounded walls -------------------------------------

@pytest.mark.parametrize("wall", [
    dict(kind="annulus", point=(0, 0, 0), normal=(0, 0, 1), radius=0.01, inner_radius=0.003),
    # a hopper cone, its wide end first and then last: the rim speed is at the larger radius
    dict(kind="frustum", point=(0, 0, 0), axis=(0, 0, 1), start=(0.0, 0.01), end=(0.02, 0.003)),
    dict(kind="frustum", point=(0, 0, 0), axis=(0, 0, 1), start=(0.0, 0.003), end=(0.02, 0.01)),
])
def test_a_turning_bounded_wall_faster_than_the_step_resolves_stops_the_run(wall):
    """Hertz contacts shorten with speed, t_c(v) = 2.87 (m*^2 / (R* E*^2 v))^(1/5) (Johnson
    1985): the run must stop once the fastest surface, omega x the outer radius 0.01 m, would
    be resolved by fewer than 10 steps, and go on just below."""
    E, nu, v0 = 5e6, 0.3, 1.0
    table = MaterialTable([Material("m", RHO, E, nu)], {"*": Interaction(restitution=0.5)},
                          "hertz_mindlin")
    e_star = E / (2.0 * (1.0 - nu * nu))
    # the shortest contact: two of the particles (m* = m/2, R* = R/2)
    t_c = 2.87 * ((MASS / 2) ** 2 / (R / 2 * e_star**2 * v0)) ** 0.2
    dt = t_c / 11.0
    v_star = v0 * (t_c / (10.0 * dt)) ** 5  # t_c(v*) = 10 dt
    for factor, stops in ((1.05, True), (0.95, False)):
        omega = factor * v_star / 0.01  # the inner radius turns at 0.3 of that, well below
        sim = Simulation(BOUNDED_HERTZ, table, x=[[0.0, 0.0, 0.05]], radius=[R], material="m",
                         walls=[dict(wall, omega=omega, material="m")], gravity=(0, 0, 0),
                         step=StepPolicy(dt=dt, impact_speed=v0))
        # the check run() makes before its first step and after every chunk (called alone here:
        # building the step loop would cost its compilation for nothing)
        if stops:
            with pytest.raises(SimulationError, match="impacts at"):
                check_contact_resolution(sim)
        else:
            check_contact_resolution(sim)


# ---- the linear-history law's tangential dashpot ----------------------------------------------

def linear_history_impact(*, v_n, v_t, w, mu, zeta, kt_ratio):
    """A sphere (radius R, mass m, I = 2/5 m R^2) striking a wall of the linear-history model,
    solved with solve_ivp (rtol 1e-10). Model (models/contact/ docstrings):
      F_n = k_n xi + 2 zeta sqrt(m k_n) xi', never below 0;
      F_t = -k_t s - 2 zeta sqrt(m k_t) v_s, |F_t| <= mu F_n, s' = v_s while it sticks; at the
      Coulomb limit F_t = mu F_n against the slip and the spring carries it alone.
    Lever arm R - xi/2. Wall at x = 0, normal +x; velocity (-v_n, v_t), spin w about z; slip
    velocity v_s = v_y - (R - xi/2) w. Returns (v_x, v_y, w) when the normal force ends."""
    kt = kt_ratio * K_N
    cn = 2.0 * zeta * math.sqrt(MASS * K_N)
    ct = 2.0 * zeta * math.sqrt(MASS * kt)
    inertia = 0.4 * MASS * R**2

    def parts(y):
        xi = R - y[0]
        fn = K_N * xi - cn * y[2]
        arm = R - 0.5 * xi
        return fn, arm, y[3] - arm * y[4]

    def rhs(mode):
        def f(_, y):
            fn, arm, vs = parts(y)
            fn = max(fn, 0.0)
            ft = -kt * y[5] - ct * vs if mode == 0 else -mode * mu * fn
            return [y[2], y[3], fn / MASS, ft / MASS, -arm * ft / inertia, vs if mode == 0 else 0.0]
        return f

    def end(_, y):
        return parts(y)[0]
    end.terminal, end.direction = True, -1

    def cap(sign):
        def g(_, y):
            fn, _, vs = parts(y)
            return sign * (kt * y[5] + ct * vs) - mu * max(fn, 0.0)
        g.terminal, g.direction = True, 1
        return g

    eps = 1e-9 * math.hypot(v_n, v_t)

    def slip_end(sign):
        def g(_, y):
            return sign * parts(y)[2] + eps
        g.terminal, g.direction = True, -1
        return g

    t_scale = math.pi / W0
    vs0 = v_t - R * w
    mode = 0 if math.sqrt(kt / K_N) * abs(vs0) < mu * v_n else int(np.sign(vs0))
    t = 1e-9 * t_scale
    y = np.array([R - v_n * t, v_t * t, -v_n, v_t, w, vs0 * t if mode == 0 else 0.0])
    for _ in range(1000):
        events = [end] + ([cap(1), cap(-1)] if mode == 0 else [slip_end(mode)])
        sol = solve_ivp(rhs(mode), (t, t + 10 * t_scale), y, method="DOP853", events=events,
                        rtol=1e-10, atol=1e-16, max_step=t_scale / 50)
        k = next(i for i, te in enumerate(sol.t_events) if len(te))
        t, y = sol.t_events[k][0], sol.y_events[k][0].copy()
        if k == 0:
            return y[2], y[3], y[4]
        fn, _, vs = parts(y)
        if mode == 0:
            sign = 1 if k == 1 else -1
            if not sign * vs < 0.0:  # a limit reached while the spring relaxes: reset, stick on
                mode = sign
            y[5] = sign * mu * fn / kt
        else:
            y[5] = mode * mu * max(fn, 0.0) / kt
            mode = 0
    raise RuntimeError("too many stick/slip switches")


@pytest.mark.parametrize("v_t,w,mu", [(0.06, 0.0, 0.5), (-0.03, 150.0, 0.3)])
def test_linear_history_oblique_impact_against_the_model_ode(v_t, w, mu):
    """Tangential spring and dashpot (k_t = 2/7 k_n, the damping ratio of the normal one, zeta
    from the restitution 0.5 by the clipped closed form) through stick and slip."""
    v_n, e = 0.2, 0.5
    zeta = clipped_damping_ratio(e)
    table = MaterialTable([Material("m", RHO)], {"*": Interaction(
        restitution=e, friction=mu, normal_stiffness=K_N)}, "linear_history")
    gap = 0.02 * R
    dt = math.pi / W0 / 400.0
    sim = Simulation(WALL_VERLET, table, x=[[R + gap, 0.0, 0.0]], radius=[R], material="m",
                     v=[[-v_n, v_t, 0.0]], w=[[0.0, 0.0, w]], gravity=(0.0, 0.0, 0.0),
                     walls=[dict(kind="plane", point=(0, 0, 0), normal=(1, 0, 0), material="m")],
                     step=StepPolicy(impact_speed=1.0))
    sim.set_time_step(dt)
    steps = int((gap / v_n + 1.3 * math.pi / W0) / dt)
    sim.run(steps, chunk=steps)
    vx, vy, wz = linear_history_impact(v_n=v_n, v_t=v_t, w=w, mu=mu, zeta=zeta, kt_ratio=2 / 7)
    # first order in dt: the dashpot force jumps at onset inside a step, zeta w0 dt of the
    # speed (as tests/test_wall_kinds.py), plus O((w0 dt)^2)
    tol = (zeta * W0 * dt + 1e-4) * v_n
    assert sim.particles.v[0, 0] == pytest.approx(vx, abs=tol)
    assert sim.particles.v[0, 1] == pytest.approx(vy, abs=tol)
    assert R * sim.particles.w[0, 2] == pytest.approx(R * wz, abs=tol)
    assert abs(vy - v_t) > 20 * tol  # the tangential force mattered


# ---- the Haff-Werner tangential dashpot's step bound ------------------------------------------

def verlet_decay_critical_step():
    """g dt at which the engine's Verlet goes unstable on v' = -g v: the dashpot sees the
    predicted velocity v + dt a (integrators.verlet_drift), then v += dt/2 (a_old + a_new). On
    (v, dt a): a_new dt = -h (v + dt a), v_new = v + (dt a + a_new dt) / 2, h = g dt."""
    def growth(h):
        m = np.array([[1.0 - 0.5 * h, 0.5 * (1.0 - h)], [-h, -h]])
        return np.abs(np.linalg.eigvals(m)).max() - 1.0

    return brentq(growth, 0.5, 1.9, xtol=1e-14)


@pytest.mark.parametrize("dim", [2, 3])
def test_haff_werner_tangential_dashpot_step_bound(dim):
    """The slip of a contact point with an immovable partner relaxes at (1/m + a^2/I) m gamma_T:
    3 gamma_T for a disk (I = m a^2 / 2), 3.5 gamma_T for a sphere (I = 2/5 m a^2); a particle
    held by three such contacts (the engine's stated design case) at three times that. The
    bound is Verlet's critical step of that decay."""
    gamma_t = 2e4
    table = MaterialTable([Material("m", RHO)], {"*": Interaction(
        friction=0.5, normal_stiffness=1e3, normal_damping_rate=10.0,
        tangential_damping_rate=gamma_t)}, "linear_hw")
    sim = Simulation(PhysicsSpec(dim=dim, walls=True), table, x=[[0.0, 0.0, 0.01]], radius=[R],
                     material="m", walls=[dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1),
                                               material="m")], gravity=(0.0, 0.0, 0.0))
    inertia_over_ma2 = 0.5 if dim == 2 else 0.4
    rate = 3 * (1.0 + 1.0 / inertia_over_ma2) * gamma_t
    bound = sim.dt_report.of_kind("tangential_dashpot")
    assert verlet_decay_critical_step() == pytest.approx(1.0, abs=1e-12)
    assert bound.limit == pytest.approx(verlet_decay_critical_step() / rate, rel=1e-12)
    assert sim.dt_report.binding.kind == "tangential_dashpot"  # the step it set


# ---- analyses on synthetic data ---------------------------------------------------------------

def test_relative_comminution_rate_is_normalised_per_row_along_n_over_nc():
    from millsim.analysis.ballmill import summary

    rate = np.array([[1.0, 2.0, 4.0], [3.0, 6.0, 2.0]])  # rows: two fillings, peaks 4 and 6
    ci = np.array([[0.1, 0.2, 0.4], [0.3, 0.3, 0.6]])
    ds = xr.Dataset({"comminution_rate": (("filling", "n_over_nc"), rate),
                     "comminution_rate_ci": (("filling", "n_over_nc"), ci)},
                    coords={"filling": [0.2, 0.4], "n_over_nc": [0.6, 0.8, 1.0]})
    out = summary(ds)
    rel = out["relative_rate"].transpose("filling", "n_over_nc").to_numpy()
    rel_ci = out["relative_rate_ci"].transpose("filling", "n_over_nc").to_numpy()
    np.testing.assert_allclose(rel, [[0.25, 0.5, 1.0], [0.5, 1.0, 1 / 3]], rtol=1e-15)
    np.testing.assert_allclose(rel_ci, [[0.025, 0.05, 0.1], [0.05, 0.05, 0.1]], rtol=1e-15)


def test_viscosity_interval_is_interpolated_in_log_eta_across_decades():
    """Power 10, 20, 30, 40 W at eta = 1e-3 .. 1 Pa s (linear in log10 eta), reference 25 W,
    half-width hypot(0.3, 0.4) = 0.5 W: the crossing at log10 eta = -1.5 (linear in eta it
    would be 0.055), the interval where |P - 25| <= 0.5: log10 eta = -1.5 -+ 0.05."""
    from millsim.analysis.stirred_mill import viscosity_interval

    eta = [1e-3, 1e-2, 1e-1, 1.0]
    rows = pd.DataFrame({"eta_sim": eta[::-1], "net_power": [40.0, 30.0, 20.0, 10.0],
                         "net_power_ci": 0.3, "reference_ci": 0.4, "reference": 25.0})
    out = viscosity_interval(rows)
    # grid of 4001 points over 3 decades: a step of 3 ln 10 / 4000 = 0.17 % in eta
    step = 3 * math.log(10) / 4000
    assert out["best"] == pytest.approx(10**-1.5, rel=step)
    assert out["lo"] == pytest.approx(10**-1.55, rel=step)
    assert out["hi"] == pytest.approx(10**-1.45, rel=step)
    assert not out["lo_open"] and not out["hi_open"]


def test_mser5_truncates_where_the_standard_error_of_the_kept_batch_means_is_least():
    """White (1997): batch means of 5, truncation d (in batches, at most half) minimising
    sum_{i>=d} (b_i - mean)^2 / (n - d)^2. For the batch means below, d = 0..4 give 0.4824,
    0.4373, 0.5, 0.528, 0.797: d = 1, index 5. The variance alone would pick d = 3, the sum of
    squares d = 4, the standard deviation over n - d d = 0."""
    b = np.array([0.0, 5.0, 5.0, 2.0, 3.0, 0.0, 3.0, 5.0])
    stat = [((b[d:] - b[d:].mean()) ** 2).sum() / (8 - d) ** 2 for d in range(5)]
    np.testing.assert_allclose(stat, [0.482421875, 0.4373177842565598, 0.5, 0.528, 0.796875],
                               rtol=1e-12)
    # within each batch a zero-mean wiggle: MSER-5 works on batch means, not the raw series
    wiggle = np.array([0.9, -0.3, 0.4, -0.6, -0.4])
    series = np.concatenate([m + wiggle * (1 + k) for k, m in enumerate(b)])
    from millsim.util.stats import mser5

    assert mser5(series) == 5
    assert mser5(series[:19]) == 0  # fewer than 4 batches: nothing truncated


# ---- Tavares fines through a secondary breakage -----------------------------------------------

def test_tavares_fines_conserve_mass_through_a_secondary_breakage():
    """A copper-ore particle broken, then its largest fragment broken again, dummy classes as
    unresolved fines: after each event, parent mass = resolved spheres + fines (computed here
    from the radii), and each event's fines are its parent's mass less its progeny's."""
    from millsim.models import TavaresModel
    from millsim.models.breakage.replacement import TavaresReplacement
    from millsim.models.breakage.tavares_materials import load_materials
    from millsim.scenes import bed_impact as bed
    from millsim.scenes.base import get_scene

    d = 5.5e-3
    values = get_scene("bed_impact").resolve({"rings": 1})
    mats = load_materials(values["materials_file"], truncation="bed")
    ore = mats["copper_ore"]
    table = bed.material_table(values, mats)
    sim = Simulation(bed.SPEC, table, x=[[0.0, 0.0, 0.01]], radius=[d / 2],
                     material="copper_ore", breakage=TavaresModel({"copper_ore": (ore.gamma, 0.0)}),
                     step=StepPolicy(impact_speed=1.5, smallest_radius=d / 40))
    replace = TavaresReplacement({"copper_ore": ore}, d_min=d / 20, seed=2, dummy_as="fines")
    replace.assign_fracture_energies(sim, [0])
    rho = ore.density

    def resolved():
        return float(rho * 4.0 / 3.0 * math.pi * (sim.particles.radius**3).sum())

    m0 = resolved()
    fines = []
    for _ in range(2):
        i = int(np.argmax(sim.particles.radius))  # the parent, then the largest fragment
        parent = rho * 4.0 / 3.0 * math.pi * sim.particles.radius[i] ** 3
        before = resolved()
        sim.pop_events = lambda i=i: sim.breakage.records(
            np.array([[i, 20.0 * sim.breakage.e_frac[i], 0, 0.0, 0.0, 1.0]]))
        replace(sim)
        progeny = resolved() - (before - parent)
        fines.append(parent - progeny)
        assert replace.events[-1].fines_mass == pytest.approx(parent - progeny, rel=1e-9)
        assert resolved() + replace.fines_mass == pytest.approx(m0, rel=1e-12)
    assert len(replace.events) == 2 and min(fines) > 0
    assert replace.fines_mass == pytest.approx(sum(fines), rel=1e-9)


# ---- the silo's Beverloo prediction -----------------------------------------------------------

@pytest.mark.parametrize("radius,orifice", [(1e-3, 0.010), (1.5e-3, 0.014)])
def test_silo_beverloo_prediction_and_flow_rate(radius, orifice):
    """Beverloo, Leniger & van de Velde (1961): W = C rho_b sqrt(g) (D - k d)^(5/2), C = 0.58,
    k = 1.5 (Nedderman 1992, ch. 10), d the sphere diameter, rho_b the settled bulk density;
    the flow rate is the slope of a discharge recorded at 2 kg/s here."""
    from millsim.scenes import load_all
    from millsim.scenes.base import get_scene

    load_all()
    scene = get_scene("silo")
    values = scene.resolve(dict(n=300, silo_radius=0.012, orifice_diameter=orifice,
                                pour_height=0.03, radius=radius))
    case = scene.case(values) if hasattr(scene, "case") else None
    if case is None:
        from millsim.scenes.silo import SiloCase

        case = SiloCase(values)
    case.charge = {"solid_fraction": 0.6, "height": 0.02}
    case.open_time = 0.0
    mass = values["density"] * 4.0 / 3.0 * math.pi * radius**3
    total = mass * values["n"]
    for t in np.linspace(0.0, 0.8 * total / 2.0, 40):
        case.record(float(t), discharged_mass=2.0 * float(t))
    data = case.finish()
    rho_b = 0.6 * values["density"]
    expected = 0.58 * rho_b * math.sqrt(9.81) * (orifice - 1.5 * 2 * radius) ** 2.5
    assert data["bulk_density"] == pytest.approx(rho_b, rel=1e-12)
    assert data["beverloo_flow_rate"] == pytest.approx(expected, rel=1e-12)
    assert data["flow_rate"] == pytest.approx(2.0, rel=1e-9)
    assert data["flow_rate_over_beverloo"] == pytest.approx(2.0 / expected, rel=1e-9)
