"""The contact tests' set-up and the reference formulas they share, written here from the
papers (nothing taken from millsim): materials with unequal elastic constants, the one
Simulation builder, E*, G*, R*, the Hertz overlap, EDEM's and the clipped damping, the
elastic Hertz collision by solve_ivp. Used by tests/test_contact_physics.py and
tests/test_contact_rolling_times.py."""

import functools
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from millsim.engine import PhysicsSpec, Simulation, StepPolicy
from millsim.models import Material, MaterialTable

G = 9.81
# Unequal elastic constants (Poisson ratios far apart, so that a (1 - nu^2) or (2 - nu) taken from
# the wrong body shows). Stiff enough that impacts at 1 m/s overlap a few % of the radius.
GLASS = Material("glass", 2500.0, 6e7, 0.22)
POLYMER = Material("polymer", 1100.0, 1.5e7, 0.45)
PLATE = Material("plate", 7800.0, 2e8, 0.29)
# Same solids under other names, so that one simulation can hold a second interaction (damped).
GLASS_D = Material("glass_d", GLASS.density, GLASS.youngs_modulus, GLASS.poisson_ratio)
POLYMER_D = Material("polymer_d", POLYMER.density, POLYMER.youngs_modulus, POLYMER.poisson_ratio)


def make_sim(law, materials, interactions, x, radius, material, *, walls=(), gravity=None,
             box=None, dt=None, impact_speed=1.0, **kw):
    """The one place where this file builds a Simulation (adapt it when the constructor changes).

    walls: (point, normal, material) of planes; gravity: vector (default none); box: periodic
    cube edge (linear_history only); dt: absolute time step (default: the recommended one).
    Each law runs in a variant other tests compile anyway: hertz_mindlin in test_dynamics'
    rolling-friction one (gravity, walls and rolling friction compiled in; a zero gravity vector
    and mu_r = 0 leave them out of a case, exactly), linear_history in test_dynamics' periodic
    gas one, linear_hw (2D) in test_engine's one.
    """
    if law == "hertz_mindlin":
        spec = PhysicsSpec(dim=3, rolling_friction=True, walls=True)
    elif law == "linear_history":
        spec = PhysicsSpec(dim=3, gravity=False, periodic=True)
    else:
        spec = PhysicsSpec(dim=2, gravity=False)
    table = MaterialTable(list(materials), dict(interactions), law)
    if box is not None:
        kw["box"] = (np.zeros(3), np.full(3, box))
    return Simulation(spec, table, x=x, radius=radius, material=material,
                      walls=[dict(kind="plane", point=p, normal=n, material=m) for p, n, m in walls],
                      gravity=(0.0, 0.0, 0.0) if gravity is None else gravity,
                      step=StepPolicy(dt=dt, impact_speed=impact_speed), **kw)


# ---- independent reference formulas -------------------------------------------------------------

def sphere_mass(r, rho):
    return rho * 4.0 / 3.0 * math.pi * r**3


def e_star(a, b):
    """Hertz contact modulus, 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2 (Johnson 1985, ch. 4)."""
    return 1.0 / ((1 - a.poisson_ratio**2) / a.youngs_modulus
                  + (1 - b.poisson_ratio**2) / b.youngs_modulus)


def g_star(a, b):
    """Mindlin shear modulus, 1/G* = (2 - nu1)/G1 + (2 - nu2)/G2, G = E / (2 (1 + nu))
    (Mindlin 1949; the form EDEM and Di Renzo & Di Maio 2004 use)."""
    def shear(m):
        return m.youngs_modulus / (2.0 * (1.0 + m.poisson_ratio))
    return 1.0 / ((2 - a.poisson_ratio) / shear(a) + (2 - b.poisson_ratio) / shear(b))


def hertz_overlap(force, es, r_eff):
    """Overlap carrying ``force``: F = 4/3 E* sqrt(R*) xi^3/2 inverted."""
    return (3.0 * force / (4.0 * es * math.sqrt(r_eff))) ** (2.0 / 3.0)


def edem_damping(restitution):
    """EDEM's 2 sqrt(5/6) |beta|, beta = ln e / sqrt(ln^2 e + pi^2) (EDEM theory reference
    guide, Hertz-Mindlin no-slip model): head-on e when the force may pull at the end."""
    ln_e = math.log(restitution)
    return 2.0 * math.sqrt(5.0 / 6.0) * (-ln_e) / math.sqrt(ln_e**2 + math.pi**2)


@functools.cache
def clipped_damping(restitution):
    """The damping factor (as edem_damping's) for which the head-on collision with the force
    clipped at zero returns e, the engine's default convention: inverted here by brentq on an
    RK45 solution of the normal ODE in units where E* = R* = m* = v = 1 (e depends on the
    damping factor only)."""
    if restitution >= 1.0:
        return 0.0

    def e_of(c):
        def fn(y):
            a = math.sqrt(max(y[0], 0.0))
            return 4.0 / 3.0 * a * max(y[0], 0.0) + c * math.sqrt(2.0 * a) * y[1]

        def end(_, y):
            return fn(y)

        end.terminal, end.direction = True, -1
        sol = solve_ivp(lambda _, y: [y[1], -max(fn(y), 0.0)], (0, 100), [1e-12, 1.0],
                        events=end, rtol=1e-11, atol=1e-14)
        return -sol.y_events[0][0][1]

    return brentq(lambda c: e_of(c) - restitution, edem_damping(restitution), 50.0, xtol=1e-12)


def hertz_elastic_collision(m_eff, r_eff, es, v_n):
    """m* xi'' = -4/3 E* sqrt(R*) xi^3/2 from xi' = v_n until xi = 0 again, by solve_ivp:
    (rebound speed, contact time)."""
    def end(_, y):
        return y[0]
    end.terminal, end.direction = True, -1
    t_scale = 3.0 * (m_eff**2 / (r_eff * es**2 * v_n)) ** 0.2
    t0 = 1e-9 * t_scale  # start a hair inside contact so that the end event does not fire at once
    sol = solve_ivp(lambda _, y: [y[1], -4.0 / 3.0 * es * math.sqrt(r_eff) * max(y[0], 0.0) ** 1.5
                                  / m_eff], (t0, 10 * t_scale), [v_n * t0, v_n], method="DOP853",
                    events=end, rtol=1e-11, atol=1e-16 * v_n * t_scale, max_step=t_scale / 100)
    return -sol.y_events[0][0][1], sol.t_events[0][0]
