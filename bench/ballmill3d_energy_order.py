"""Which energy book of scene ``ballmill3d`` is first order in the time step (issue 52): the
0.3 m lab mill of config/ballmill3d_lab_power.yaml (0.1 m long, 30 % filling, contacts softened
1e4x, breakage on) at n/n_c 1.0, where its energy balance missed 2 % at the recommended step.

    python bench/ballmill3d_energy_order.py [--window 0.3] [--transient 0.5] [--threads 2]
                                            [--json FILE]

The charge is poured, settled and spun up for ``transient`` revolutions once (at the
recommended step); that state is then run for ``window`` revolutions in each arm: dt_factor 1,
0.5 and 0.25 with the materials file's rolling friction, and 1 and 0.5 with it set to zero
(every pair and wall, in place in the copied state). Each arm prints the change of every term of
``ballmill3d_observables.energy_state`` (the dissipation split into the audit's terms) over the
window, as a fraction of the drive work, and the residual (work - everything else). A book whose
share moves with dt by about the residual's change is the first-order one; an arm without rolling
friction whose residual is far smaller says the rolling-friction torque (EDEM's constant torque
against each body's spin, which flips every step on a body that barely spins) is the source.
"""

import argparse
import json
import pickle
import sys
import time

from millsim.models.contact.hertz_mindlin import P_MU_ROLL
from millsim.scenes import ballmill3d_observables as obs
from millsim.scenes import load_all
from millsim.scenes.base import get_scene

LAB = dict(drum_diameter=0.3, drum_length=0.1, filling=0.3, n_over_nc=1.0,
           stiffness_scale=1e-4, d_min_ratio=0.2, breakage=True, seed=1, liner="",
           revolutions=1e3, transient_revolutions=0.0)


def prepared(threads, transient):
    load_all()
    scene = get_scene("ballmill3d")
    case = scene.build(scene.resolve(LAB))
    sim = case.sim
    while case.stage != "mill":
        sim.run(case.chunk(), chunk=case.chunk(), threads=threads, on_events=case.on_events)
        case.after_chunk()
    steps = int(round(transient * case.period / sim.dt))
    sim.run(steps, chunk=steps, threads=threads, on_events=case.on_events)
    return pickle.dumps(case)


def state(case):
    s = obs.energy_state(case.sim, case.removed)
    s.update(case.sim.energy_audit())
    s["removed"] = case.removed
    return s


def arm(frozen, dt_factor, rolling, window, threads, parts=6):
    case = pickle.loads(frozen)
    sim = case.sim
    if not rolling:
        sim.pair_params[:, :, P_MU_ROLL] = 0.0
    sim.set_time_step(dt_factor=dt_factor)
    start, t0, wall = state(case), sim.time, time.perf_counter()
    rows = []
    for k in range(1, parts + 1):
        t_target = t0 + k / parts * window * case.period
        steps = max(1, int(round((t_target - sim.time) / sim.dt)))
        sim.run(steps, chunk=steps, threads=threads, on_events=case.on_events)
        end = state(case)
        work = end["work"] - start["work"]
        shares = {key: (end[key] - start[key]) / work for key in end
                  if key not in ("time", "work", "dissipated")}
        rows.append(dict(revolutions=(sim.time - t0) / case.period, work=work,
                         residual=obs.energy_balance_error(start, end), shares=shares))
    return dict(dt_factor=dt_factor, rolling=rolling, dt=sim.dt, wall_s=time.perf_counter() - wall,
                steps=sim.step, n_particles=sim.n_particles, rows=rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--window", type=float, default=0.3, help="revolutions per arm")
    ap.add_argument("--transient", type=float, default=0.5, help="revolutions before the arms")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--json", help="write the arms here")
    a = ap.parse_args(argv)
    frozen = prepared(a.threads, a.transient)
    arms = []
    for dt_factor, rolling in ((1.0, True), (1.0, False), (0.5, True), (0.5, False),
                               (0.25, True)):
        r = arm(frozen, dt_factor, rolling, a.window, a.threads)
        arms.append(r)
        last = r["rows"][-1]
        parts = " ".join(f"{100 * w['residual']:+.2f}" for w in r["rows"])
        terms = "  ".join(f"{k} {100 * v:+.3f}" for k, v in last["shares"].items() if v)
        print(f"dt_factor {dt_factor:<5g} rolling {'on ' if rolling else 'off'} dt {r['dt']:.3e} "
              f"wall {r['wall_s']:.0f} s  residual {100 * last['residual']:+.3f} % "
              f"(by part: {parts})\n"
              f"    % of drive work {last['work']:.4g} J: {terms}", flush=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(dict(lab=LAB, window=a.window, transient=a.transient, arms=arms), f,
                      indent=1)


if __name__ == "__main__":
    sys.exit(main())
