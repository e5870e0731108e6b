"""Cost per particle-step at wide size ratios (issue 17 item 4): the multi-level grid against the
single-level cell list it replaced, measured in the same run.

    python bench/size_ratio.py [--n 25000] [--steps 1000] [--baseline-src DIR] [--json FILE]

Cases (all spheres of one rock-like material, E = 5 GPa, rho = 2500 kg/m3, COR 0.5, mu 0.3, in a
walled box under gravity, time step the engine's recommended one):
- ``bed``: n spheres of 2 mm diameter in a simple-cubic packing at contact (6 contacts each; a
  regular stand-in for a settled bed, not a poured one) with a 20 mm cavity in its middle;
- ``bed+ball``: the same bed with a 20 mm sphere in the cavity moving through it at 5 m/s;
- ``bimodal-R``: spheres of 2 mm and 2R mm diameter in equal volumes, n in all (R = 1, 2, 5, 10,
  20; R = 1 is the monodisperse bed), the large ones on their own lattice, the small ones on theirs
  where it does not overlap a large one; agitated: every sphere starts with a random velocity of
  1 m/s rms per axis, so that the list is rebuilt as in a running mill (a static bed never
  rebuilds it and would not time the search at all).

``rebuild_ms``: the neighbour-list build alone (engine.neighbours.build_verlet) on the final
state of the case, median of 5, the most direct measure of the search's cost against the ratio.

Each case: 200 steps (compiling, first neighbour list), then ``--steps`` timed steps (the
compiled chunks only, ``Simulation.wall_seconds``). ``--baseline-src`` runs the same cases with
another checkout's ``src`` first on ``PYTHONPATH`` (e.g. a worktree of the commit before the
multi-level grid) in a separate process, so both codes are timed under the same load.
"""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

RUN = r"""
import json, sys, time
import numpy as np
import numba
from scipy.spatial import cKDTree
from millsim.engine import PhysicsSpec, Simulation, StepPolicy
from millsim.engine.neighbours import build_verlet
from millsim.engine.state import empty_contacts
from millsim.models import Interaction, Material, MaterialTable

cfg = json.loads(sys.argv[1])
RS = 1e-3  # small radius [m]


def lattice(lo, hi, a):
    axes = [np.arange(lo[k] + a / 2, hi[k] - a / 2 + 1e-12, a) for k in range(3)]
    g = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return g[np.lexsort((g[:, 0], g[:, 1], g[:, 2]))]


def case(name, n):
    if name.startswith("bed"):
        side = 2 * RS * round((n / 1.0) ** (1 / 3) * 1.02)
        cav = np.array([side / 2, side / 2, side / 2])
        small = lattice((0, 0, 0), (side, side, 10 * side), 2 * RS)
        small = small[np.linalg.norm(small - cav, axis=1) > 10e-3 + RS * 1.02][:n]
        if name == "bed":
            return small, np.full(len(small), RS), None, side
        x = np.vstack([cav, small])
        r = np.concatenate([[10e-3], np.full(len(small), RS)])
        v = np.zeros_like(x)
        v[0, 0] = 5.0
        return x, r, v, side
    ratio = float(name.split("-")[1])
    RL = ratio * RS
    n_large = 0 if ratio == 1 else max(1, round(n / (1 + ratio ** 3)))
    n_small = n - n_large
    # box: the volume of both lattices, square in x and y
    vol = n_small * (2 * RS) ** 3 + n_large * (2 * RL + 2 * RS) ** 3
    side = max(vol ** (1 / 3) * 0.9, 2 * RL + 4 * RS)
    side = 2 * RS * np.ceil(side / (2 * RS))
    large = lattice((0, 0, 0), (side, side, 100 * side), 2 * RL + 2 * RS)[:n_large]
    # small lattice tall enough for n_small sites outside the large spheres (20 % margin)
    height = 1.2 * vol / side ** 2 + 2 * RL + 4 * RS
    small = lattice((0, 0, 0), (side, side, height), 2 * RS)
    if n_large:
        gap, _ = cKDTree(large).query(small)
        small = small[gap > RL + RS * 1.02]
    if len(small) < n_small:
        raise RuntimeError(f"{name}: lattice too small ({len(small)} < {n_small})")
    small = small[:n_small]
    x = np.vstack([large, small])
    r = np.concatenate([np.full(len(large), RL), np.full(len(small), RS)])
    v = np.random.default_rng(1).normal(0.0, 1.0, x.shape)
    return x, r, v, side


def walls(side):
    return [dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="rock"),
            dict(kind="plane", point=(0, 0, 0), normal=(1, 0, 0), material="rock"),
            dict(kind="plane", point=(side, 0, 0), normal=(-1, 0, 0), material="rock"),
            dict(kind="plane", point=(0, 0, 0), normal=(0, 1, 0), material="rock"),
            dict(kind="plane", point=(0, side, 0), normal=(0, -1, 0), material="rock")]


out = []
for name in cfg["cases"]:
    x, r, v, side = case(name, cfg["n"])
    table = MaterialTable([Material("rock", 2500.0, 5e9, 0.25)],
                          {"*": Interaction(restitution=0.5, friction=0.3)}, "hertz_mindlin")
    spec = PhysicsSpec(dim=3, integrator="verlet", walls=True)
    sim = Simulation(spec, table, x=x, radius=r, material="rock", v=v, walls=walls(side),
                     skin=0.1 * RS, step=StepPolicy(dt_factor=1.0, impact_speed=5.0))
    sim.run(200, chunk=200)
    t0, rebuilds0 = sim.wall_seconds, int(sim.counters[0])
    sim.run(cfg["steps"], chunk=cfg["steps"])
    loop = sim.wall_seconds - t0
    i, _, _ = sim.contact_pairs()
    p = sim.particles
    c = empty_contacts(len(p.x), 3)
    lists = build_verlet(p.x, p.radius, p.body, 0.1 * RS, 3, np.zeros(3), np.zeros(3), c.start,
                         c.nbr, c.state)
    times = []
    for _ in range(5):
        t1 = time.perf_counter()
        build_verlet(p.x, p.radius, p.body, 0.1 * RS, 3, np.zeros(3), np.zeros(3), lists[0],
                     lists[1], lists[2])
        times.append(time.perf_counter() - t1)
    out.append({"case": name, "n": sim.n_particles, "ratio": float(r.max() / r.min()),
                "steps": cfg["steps"], "loop_s": loop, "dt": sim.dt,
                "particle_steps_per_s": sim.n_particles * cfg["steps"] / loop,
                "list_rebuilds": int(sim.counters[0]) - rebuilds0,
                "contacts_per_particle": 2 * len(i) / sim.n_particles,
                "rebuild_ms": 1e3 * float(np.median(times)),
                "threads": numba.get_num_threads()})
    print(json.dumps(out[-1]), file=sys.stderr, flush=True)
print(json.dumps(out))
"""

CASES = ["bed", "bed+ball", "bimodal-1", "bimodal-2", "bimodal-5", "bimodal-10", "bimodal-20"]


def measure(cases, n, steps, src=None):
    env = dict(os.environ)
    if src:
        env["PYTHONPATH"] = str(Path(src).resolve())
    run = subprocess.run([sys.executable, "-c", RUN, json.dumps({"cases": cases, "n": n,
                                                                  "steps": steps})],
                         env=env, capture_output=True, text=True)
    if run.returncode:
        raise RuntimeError(run.stderr[-3000:])
    return json.loads(run.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=25000, help="particles per case (default 25000)")
    ap.add_argument("--steps", type=int, default=1000, help="timed steps per case")
    ap.add_argument("--cases", nargs="+", default=CASES, choices=CASES)
    ap.add_argument("--baseline-src", help="src directory of the single-level code to compare")
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args(argv)
    results = {"command": "python " + " ".join(["bench/size_ratio.py", *(argv or sys.argv[1:])]),
               "n": args.n, "steps": args.steps, "loadavg": [os.getloadavg()],
               "multilevel": measure(args.cases, args.n, args.steps)}
    if args.baseline_src:
        results["single_level"] = measure(args.cases, args.n, args.steps, args.baseline_src)
    results["loadavg"].append(os.getloadavg())
    for key in ("multilevel", "single_level"):
        for row in results.get(key, []):
            print(f"{key:12s} {row['case']:11s} ratio {row['ratio']:5.1f}  "
                  f"{row['particle_steps_per_s'] / 1e6:6.2f} M particle-steps/s  "
                  f"{row['list_rebuilds']:4d} rebuilds  {row['contacts_per_particle']:.2f} contacts/particle  "
                  f"rebuild {row['rebuild_ms']:.1f} ms")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
