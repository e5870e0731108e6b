"""Cost per step and per simulated time of the lubrication schemes on the quick stirred-mill slice.

    python bench/lubrication_cost.py [--cases 0:explicit 1:explicit 0.1:implicit 1:implicit
                                      10:implicit] [--steps 500] [--repeats 3] [--threads 1]
                                     [--json FILE]

Each case (eta [Pa s]:scheme) is the quick slice (config/config.yaml's geometry, seed 1,
2500 rpm) at its automatic step, started from its start state; the compiled chunks of ``--steps``
steps are timed after 5 warm-up steps, the cases taken in turn ``--repeats`` times (the machine
is shared: the fastest repeat is reported, with the load average). Reported: step, seconds per
step, seconds per simulated millisecond, the implicit solve's iterations per step, and the ratio
to the first case's cost per simulated millisecond.
"""

import argparse
import json
import os
import sys
from pathlib import Path

from millsim.scenes import stirred_mill as sm
from millsim.scenes.base import get_scene

QUICK = dict(scale=0.45, slice=True, initial_swirl=0.1, rpm=2500, friction=0.3, seed=1)


def measure(eta, scheme, steps, threads):
    values = get_scene("stirred_mill").resolve(dict(QUICK, eta=eta, lubrication_scheme=scheme))
    sim, _ = sm.build(values)
    sim.run(5, chunk=5, threads=threads)
    wall0, iterations0 = sim.wall_seconds, int(sim.counters[2])
    sim.run(steps, chunk=steps, threads=threads)
    seconds = (sim.wall_seconds - wall0) / steps
    return {"eta": eta, "scheme": scheme, "dt": sim.dt, "s_per_step": seconds,
            "s_per_sim_ms": seconds * 1e-3 / sim.dt,
            "iterations_per_step": (int(sim.counters[2]) - iterations0) / steps,
            "n_particles": sim.n_particles}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=["0:explicit", "1:explicit", "0.1:implicit",
                                                   "1:implicit", "10:implicit"])
    ap.add_argument("--steps", type=int, default=500)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    cases = [(float(c.split(":")[0]), c.split(":")[1]) for c in args.cases]
    best = {}
    load = [os.getloadavg()]
    for _ in range(args.repeats):
        for eta, scheme in cases:
            r = measure(eta, scheme, args.steps, args.threads)
            key = (eta, scheme)
            if key not in best or r["s_per_step"] < best[key]["s_per_step"]:
                best[key] = r
    load.append(os.getloadavg())
    first = best[cases[0]]["s_per_sim_ms"]
    rows = []
    for key in cases:
        r = dict(best[key], cost_ratio=best[key]["s_per_sim_ms"] / first)
        rows.append(r)
        print(f"eta {r['eta']:g} Pa s {r['scheme']:8s} dt {r['dt']:.3g} s: "
              f"{1e3 * r['s_per_step']:.2f} ms/step, {r['s_per_sim_ms']:.2f} s per simulated ms "
              f"({r['cost_ratio']:.2f} x {cases[0][1]} at {cases[0][0]:g} Pa s), "
              f"{r['iterations_per_step']:.2f} iterations/step", flush=True)
    print(f"load average before/after: {load[0][0]:.1f} / {load[1][0]:.1f}")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        command = "python bench/lubrication_cost.py " + " ".join(
            argv if argv is not None else sys.argv[1:])
        Path(args.json).write_text(json.dumps({"benchmark": "lubrication_cost",
                                               "command": command, "threads": args.threads,
                                               "loadavg": load, "cases": rows}, indent=2))


if __name__ == "__main__":
    main()
