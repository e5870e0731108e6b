"""What "leave out what a scene does not need" buys: one dry case, physics compiled out vs in.

    python bench/leave_out.py [--n 10000] [--steps 5000] [--repeats 3] [--variants ...] [--json FILE]

The case is the settled bed of the throughput benchmark (packing scene: Hertz-Mindlin spheres
r = 1 mm in a walled box, gravity). The same state is timed with five compiled loops:

- ``lean``: the scene's own spec (Hertz-Mindlin, walls, gravity);
- ``inactive``: the same plus Tavares breakage, lubrication and the energy audit compiled in but
  doing nothing physical (every fracture energy infinite, viscosity 0: the lubrication kernel
  runs and returns zero forces, and its h_max reach keeps more pairs in the neighbour list);
- ``breakage``: the lean spec plus Tavares breakage only (loading work per contact and particle,
  fracture energies infinite);
- ``lubrication``: the lean spec plus lubrication only (viscosity 0, h_max reach in the list);
- ``audit``: the lean spec plus the energy audit only.

Each measurement runs in its own process (so numba's thread pool and caches are fresh), is warmed
up (compile excluded) and timed once; the variants take turns, ``repeats`` rounds, so that the
shared machine's load changes hit them alike. The median particle-steps per second of each
variant and its ratio to ``lean`` are reported, with os.getloadavg() of every measurement. A settled state is taken from
bench/out/millsim_box_state.csv when the throughput benchmark left one, else the packing scene
settles a fresh bed first (slower).
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
VARIANTS = ("lean", "inactive", "breakage", "lubrication", "audit")
STATE = HERE / "out" / "millsim_box_state.csv"

RUN = r"""
import json, sys
import numpy as np
from millsim.engine import PhysicsSpec, Simulation, StepPolicy
from millsim.models import Lubrication, TavaresModel
from millsim.scenes import packing
from millsim.scenes.base import get_scene

variant, n, steps, repeats, state = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
values = get_scene("packing").resolve({"n": n, "init_file": state} if state else {"n": n})
base = packing.build(values)
if not state:
    base.run(values["settle_steps"], chunk=5000)
p = base.particles
models = {}
spec = base.spec
# every fracture energy infinite (the model's default), viscosity 0: compiled in, doing nothing
if variant == "inactive":
    spec = PhysicsSpec(dim=3, walls=True, energy_audit=True)
    models = dict(breakage=TavaresModel({"grain": (5.0, 0.0)}), fluid=Lubrication(eta=0.0))
elif variant == "breakage":
    models = dict(breakage=TavaresModel({"grain": (5.0, 0.0)}))
elif variant == "lubrication":
    models = dict(fluid=Lubrication(eta=0.0))
elif variant == "audit":
    spec = PhysicsSpec(dim=3, walls=True, energy_audit=True)
sim = Simulation(spec, base.table, x=p.x.copy(), radius=p.radius.copy(), material="grain",
                 v=p.v.copy(), w=p.w.copy(), walls=packing._walls(values), skin=base.skin,
                 step=StepPolicy(dt=values["dt"], impact_speed=1.0), **models)
sim.run(50, chunk=50)  # compile (or load) and warm up
rates = []
for _ in range(repeats):
    t0 = sim.wall_seconds
    sim.run(steps, chunk=steps)
    rates.append(sim.n_particles * steps / (sim.wall_seconds - t0))
import os, resource
print(json.dumps({"variant": variant, "rates": rates, "n": sim.n_particles,
                  "neighbour_pairs": int(sim.contacts.nbr.shape[0]),
                  "max_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "loadavg": os.getloadavg()}))
"""


def measure(variant, n, steps, repeats, state, threads=1):
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads))
    out = subprocess.run([sys.executable, "-c", RUN, variant, str(n), str(steps), str(repeats),
                          state], capture_output=True, text=True, check=True, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=10000)
    ap.add_argument("--steps", type=int, default=5000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1, help="numba threads of each measurement")
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS)
    args = ap.parse_args(argv)
    state = str(STATE) if STATE.exists() and args.n == 10000 else ""
    command = "python bench/leave_out.py " + " ".join(argv if argv is not None else sys.argv[1:])
    results = {"command": command, "loadavg_start": os.getloadavg(), "threads": args.threads,
               "steps": args.steps,
               "repeats": args.repeats}
    variants = ["lean"] + [v for v in args.variants if v != "lean"]
    # Interleaved: round after round every variant once (one process each), so that a change of
    # the machine's load hits all variants alike.
    for _ in range(args.repeats):
        for variant in variants:
            r = measure(variant, args.n, args.steps, 1, state, args.threads)
            if variant in results:
                results[variant]["rates"] += r["rates"]
                results[variant]["loadavg"].append(r["loadavg"])
            else:
                results[variant] = dict(r, loadavg=[r["loadavg"]])
    for variant in variants:
        r = results[variant]
        r["median"] = statistics.median(r["rates"])
        print(f"{variant:11s} median {r['median']:.3g} particle-steps/s "
              f"({r['neighbour_pairs']} listed pairs)", flush=True)
    results["loadavg_end"] = os.getloadavg()
    for variant in [v for v in args.variants if v != "lean"]:
        results[variant]["ratio_to_lean"] = results[variant]["median"] / results["lean"]["median"]
        print(f"{variant} / lean = {results[variant]['ratio_to_lean']:.3f}")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
