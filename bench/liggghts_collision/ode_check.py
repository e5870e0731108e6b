"""Independent check of config/reference/liggghts_collision.csv: the continuum (dt -> 0) limit.

Integrates LIGGGHTS 3.8's Hertz normal law (src/normal_model_hertz.h, see
config/reference/SOURCES.md) for one head-on contact with scipy's DOP853 at rtol 1e-12:

    m* d2(delta)/dt2 = -Fn,  Fn = 4/3 Y* sqrt(R* delta) delta + gamma_n d(delta)/dt,
    gamma_n = -2 sqrt(5/6) beta sqrt(2 Y* sqrt(R* delta) m*),  beta = ln e / sqrt(ln^2 e + pi^2),
    Y* = E / (2 (1 - nu^2)); pair: R* = r/2, m* = m/2; wall: R* = r, m* = m;
    limitForce on: Fn = max(Fn, 0).

and prints, for every ``reference = 1`` row of the CSV, LIGGGHTS' e_measured and contact duration
next to the ODE's (contact = from delta = 0 approaching to delta = 0 separating). The relative
differences are LIGGGHTS' remaining time-step error (first order in dt).

Usage: python bench/liggghts_collision/ode_check.py [CSV]   (needs numpy and scipy)
"""
from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

from scipy.integrate import solve_ivp

ROOT = Path(__file__).resolve().parent.parent.parent
E_MOD, NU, RADIUS, RHO, V_IMPACT = 5.0e6, 0.3, 1.0e-3, 2500.0, 1.0


def continuum(case: str, limit: str, e: float) -> tuple[float, float]:
    y_eff = E_MOD / (2.0 * (1.0 - NU**2))
    m = RHO * 4.0 / 3.0 * math.pi * RADIUS**3
    r_eff, m_eff = (RADIUS / 2, m / 2) if case == "pair" else (RADIUS, m)
    ln_e = math.log(e)
    beta = ln_e / math.sqrt(ln_e**2 + math.pi**2)
    clip = limit == "on"

    def rhs(_t, y):
        d, v = y                      # overlap and its rate (> 0 approaching)
        d = max(d, 0.0)
        sq = math.sqrt(r_eff * d)
        gamma_n = -2.0 * math.sqrt(5.0 / 6.0) * beta * math.sqrt(2.0 * y_eff * sq * m_eff)
        fn = 4.0 / 3.0 * y_eff * sq * d + gamma_n * v
        if clip and fn < 0.0:
            fn = 0.0
        return [v, -fn / m_eff]

    def separated(_t, y):
        return y[0]
    separated.terminal, separated.direction = True, -1
    sol = solve_ivp(rhs, (0.0, 5e-3), [1e-30, V_IMPACT], events=separated, method="DOP853",
                    rtol=1e-12, atol=1e-22)
    return -sol.y_events[0][0][1] / V_IMPACT, float(sol.t_events[0][0])


def main() -> None:
    path = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "config/reference/liggghts_collision.csv"
    rows = [r for r in csv.DictReader(line for line in path.open() if not line.startswith("#"))
            if r["reference"] == "1"]
    print(f"{'case':5} {'limit':5} {'e_input':>12} {'dt':>10} {'e LIGGGHTS':>13} {'e ODE':>13} "
          f"{'rel diff':>9} {'t_c LIGGGHTS':>13} {'t_c ODE':>13} {'rel diff':>9}")
    worst = 0.0
    for r in rows:
        e_ode, tc_ode = continuum(r["case"], r["limitForce"], float(r["e_input"]))
        e_l, tc_l = float(r["e_measured"]), float(r["contact_duration"])
        de, dt_c = (e_l - e_ode) / e_ode, (tc_l - tc_ode) / tc_ode
        worst = max(worst, abs(de))
        print(f"{r['case']:5} {r['limitForce']:5} {r['e_input']:>12} {float(r['dt']):10.4g} "
              f"{e_l:13.10f} {e_ode:13.10f} {de:9.1e} {tc_l:13.8g} {tc_ode:13.8g} {dt_c:9.1e}")
    print(f"largest relative difference in e: {worst:.1e}")


if __name__ == "__main__":
    main()
