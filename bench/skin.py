"""The 2D ball mill's list rebuilds against the Verlet skin: is a larger skin cheaper?

    python bench/skin.py [--n 100000] [--steps 400] [--factors 1 2 4 8] [--threads 1]
                         [--json bench/out/skin_ballmill2d.json]

bench/scaling.py's ``ballmill2d`` system (its drum of wall disks turning at 0.75 n_c, a dense
hexagonal bed) with the scene's skin (half the sieve radius) times each factor, each in its own
process: 50 warm-up steps, then --steps timed. Reported per factor: particle-steps/s, list
rebuilds and their seconds, listed pairs per particle, and a SHA-1 of the final positions,
velocities and spins, and the largest difference of the final velocities from factor 1's,
relative to the largest speed. The skin decides only which pairs are listed, never which touch,
so a factor may change the result only by rounding: the passes sum a particle's slot records
(more listed slots, more zero terms) with fast-math reassociation. The run fails if a factor's
velocities differ from factor 1's by more than 1e-6 of the largest speed (400 steps of a dense
bed amplify rounding, but not to that).
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

CHILD = r"""
import hashlib, json, sys
import numpy as np
sys.path.insert(0, sys.argv[1])
import scaling

n, steps, factor, threads = int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5])
rebuild_s = scaling.time_list_rebuilds()
sim, info = scaling.build_ballmill2d(n, 1.0, 0.0, 0.0, skin_factor=factor)
sim.run(50, chunk=50, threads=threads)
loop0, rebuilds0 = sim.wall_seconds, int(sim.counters[0])
rebuild_s[0] = 0.0
sim.run(steps, chunk=steps, threads=threads)
loop_s = sim.wall_seconds - loop0
p = sim.particles
digest = hashlib.sha1(p.x.tobytes() + p.v.tobytes() + p.w.tobytes()).hexdigest()[:12]
np.save(sys.argv[6], p.v)
print(json.dumps(dict(skin_factor=factor, skin=sim.skin, n_particles=sim.n_particles, steps=steps,
                      threads=threads, loop_s=loop_s, particle_steps_per_s=sim.n_particles * steps / loop_s,
                      list_rebuilds=int(sim.counters[0]) - rebuilds0, rebuild_s=rebuild_s[0],
                      listed_pairs_per_particle=2 * len(sim.contacts.nbr) / sim.n_particles,
                      state_sha1=digest)))
"""


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100000)
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--factors", type=float, nargs="+", default=[1.0, 2.0, 4.0, 8.0])
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--json", default=str(HERE / "out" / "skin_ballmill2d.json"))
    args = ap.parse_args(argv)
    if 1.0 not in args.factors:
        ap.error("--factors must include 1 (the reference the others are compared with)")
    rows, velocities = [], {}
    env = dict(os.environ, NUMBA_NUM_THREADS=str(args.threads))
    factors = [1.0] + [f for f in args.factors if f != 1.0]  # the reference first
    tmp = tempfile.TemporaryDirectory()
    for factor in factors:
        load0 = os.getloadavg()
        v_file = Path(tmp.name) / f"v_{factor:g}.npy"
        out = subprocess.run([sys.executable, "-c", CHILD, str(HERE), str(args.n), str(args.steps),
                              str(factor), str(args.threads), str(v_file)], capture_output=True,
                             text=True, env=env)
        if out.returncode:
            sys.exit(f"skin factor {factor}: {out.stderr.strip().splitlines()[-1]}")
        r = json.loads(out.stdout.strip().splitlines()[-1])
        r["loadavg"] = [load0, os.getloadavg()]
        velocities[factor] = np.load(v_file)
        v1 = velocities[1.0]
        r["max_velocity_difference"] = float(np.abs(velocities[factor] - v1).max() / np.abs(v1).max())
        rows.append(r)
        print(f"skin x{factor:g} ({r['skin'] * 1e3:.2f} mm): {r['particle_steps_per_s']:.3g} particle-steps/s, "
              f"{r['list_rebuilds']} rebuilds ({r['rebuild_s']:.2f} of {r['loop_s']:.2f} s), "
              f"{r['listed_pairs_per_particle']:.2f} listed pairs/particle, state {r['state_sha1']}, "
              f"velocities differ from x1 by {r['max_velocity_difference']:.2g} of the largest speed",
              flush=True)
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps({"benchmark": "skin", "command": "python bench/skin.py " + " ".join(argv),
                                           "rows": rows}, indent=2))
    differ = [r["skin_factor"] for r in rows if r["max_velocity_difference"] > 1e-6]
    if differ:
        sys.exit(f"FAILED: skin factors {differ} end more than rounding away from factor 1")


if __name__ == "__main__":
    main()
