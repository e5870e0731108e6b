"""Full-scale LS1 stirred mill: wall time per simulated ms, projected to the LabStar LS1 paper's run.

    python bench/ls1.py [--cases 0:auto:0.5 1:auto:0.1 0:5e-8:0.01 1:5e-8:0.01] [--rpm 2500]
                        [--threads 2] [--ramp-revolutions R] [--json FILE]

    python bench/ls1.py --cases 1:auto:0.5:implicit   # the implicit lubrication scheme

The case is config/paper.yaml's stirred mill: scene ``stirred_mill`` at scale 1, slice false
(the whole 4-disk chamber), 1.8 mm monodisperse beads from the Table 2 filling (128,739 beads,
the paper simulates 128,000) plus the 28,992 spheres of the agitator disks. Each viscosity runs in
its own process with ``--threads`` numba threads:

- ``setup_s``: building the case (lattice start, disks, neighbour list), after the imports;
- ``first_steps_s``: the first 5 steps (loading the compiled loop from numba's cache, or
  compiling it when the cache is empty);
- the timed run: the case's simulated milliseconds at its step, wall time of the compiled
  chunks only. A case is ``eta:dt:ms[:scheme]``; dt ``auto`` is the scene's automatic step (dry:
  t_c/25 = 1.0e-5 s; 1 Pa s: the lubrication bound, 3.6e-7 s, with the explicit scheme, the dry
  step with the implicit one), 5e-8 is the paper's; scheme ``explicit`` (default) or ``implicit``
  (docs/lubrication.md; its solver iterations per step are reported).

The run starts from the scene's start state (beads on FCC lattice sites, 0.1 of rigid swirl), so
the beads touch little yet (contacts per particle are reported) while the lubrication pairs are
already all there (lattice neighbours sit 0.001 d apart). The projection multiplies the wall time
per simulated ms by the paper's 52.5 ms (at the case's own step: for the cases at the paper's
step, 0.05 us of the paper's Table 2, that is the like-for-like comparison with Table 3; at larger
steps the agitator moves more per step and the list is rebuilt more often). Peak memory is the child's
``ru_maxrss``; ``loadavg`` is os.getloadavg() before and after (the machine is shared).
``--ramp-revolutions R`` starts the agitator from rest (the scene's ``ramp_revolutions``): the
timed run then covers the start-up, which is what a start at 2500 rpm and above needs.
"""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

PAPER_SIM_MS = 52.5  # the LS1 paper's Table 3 is the elapsed time for 52.5 ms of simulated time
# the LS1 paper's Table 3: total elapsed time [h] for 52.5 ms, eta = 0 on 1 processor,
# eta = 1 Pa s on 8
PAPER_TABLE3_H = {1000: (44.2, 21.2), 1500: (44.4, 12.1), 2000: (42.4, 31.2), 2500: (46.3, 30.3),
                  3000: (44.8, 38.6), 3500: (44.8, 43.4), 4000: (45.0, 35.6)}
PAPER_TABLE3_PROCESSORS = (1, 8)

RUN = r"""
import json, os, resource, sys, time
t0 = time.perf_counter()
load0 = os.getloadavg()
import numba
from millsim.scenes import stirred_mill as sm
from millsim.scenes.base import get_scene
eta, dt, rpm, sim_ms, threads, ramp = (float(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3]),
                                       float(sys.argv[4]), int(sys.argv[5]), float(sys.argv[6]))
scheme = sys.argv[7]
numba.set_num_threads(threads)
values = get_scene("stirred_mill").resolve(dict(scale=1.0, slice=False, bead_diameter_min=1.8e-3,
                                               bead_diameter_max=1.8e-3, eta=eta, rpm=rpm, seed=1,
                                               dt=dt, ramp_revolutions=ramp,
                                               lubrication_scheme=scheme))
t1 = time.perf_counter()
sim, g = sm.build(values)
t2 = time.perf_counter()
sim.run(5, chunk=5, threads=threads)
t3 = time.perf_counter()
steps = max(1, int(round(sim_ms * 1e-3 / sim.dt)))
loop0, rebuilds0, iterations0 = sim.wall_seconds, int(sim.counters[0]), int(sim.counters[2])
sim.run(steps, chunk=steps, threads=threads)
loop_s = sim.wall_seconds - loop0
i, j, _ = sim.contact_pairs()
print(json.dumps({
    "eta": eta, "scheme": scheme, "rpm": rpm, "threads": threads, "n_particles": sim.n_particles,
    "n_beads": g["n_beads"], "n_agitator_particles": g["n_agitator_particles"], "dt": sim.dt,
    "dt_binding": sim.dt_report.binding.interaction, "import_s": t1 - t0, "setup_s": t2 - t1,
    "first_steps_s": t3 - t2, "steps": steps, "sim_ms": steps * sim.dt * 1e3, "loop_s": loop_s,
    "s_per_step": loop_s / steps, "wall_s_per_sim_ms": loop_s / (steps * sim.dt * 1e3),
    "particle_steps_per_s": sim.n_particles * steps / loop_s,
    "list_rebuilds": int(sim.counters[0]) - rebuilds0,
    "solver_iterations_per_step": (int(sim.counters[2]) - iterations0) / steps,
    "listed_pairs_per_particle": 2 * len(sim.contacts.nbr) / sim.n_particles,
    "contacts_per_particle": 2 * len(i) / sim.n_particles,
    "max_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    "ramp_revolutions": ramp, "kinetic_energy_end": sim.kinetic_energy(),
    "loadavg": [load0, os.getloadavg()]}))
"""


def measure(eta, dt, rpm, sim_ms, threads, ramp=0.0, scheme="explicit"):
    env = dict(os.environ, NUMBA_NUM_THREADS=str(max(threads, 1)))
    out = subprocess.run([sys.executable, "-c", RUN, str(eta), str(dt), str(rpm), str(sim_ms),
                          str(threads), str(ramp), scheme], capture_output=True, text=True,
                         env=env)
    if out.returncode:  # e.g. a guard that stopped the run: recorded, not hidden
        lines = out.stderr.strip().splitlines()
        return {"eta": eta, "scheme": scheme, "dt_given": dt, "rpm": rpm, "threads": threads,
                "failed": True, "ramp_revolutions": ramp,
                "error": lines[-1] if lines else f"exit code {out.returncode}"}
    r = json.loads(out.stdout.strip().splitlines()[-1])
    r["dt_choice"] = "auto" if dt == 0 else "given"
    r["projection_52p5ms_h"] = r["wall_s_per_sim_ms"] * PAPER_SIM_MS / 3600
    paper = PAPER_TABLE3_H.get(int(rpm))
    if paper:
        k = 0 if eta == 0 else 1
        r["paper_table3_h"] = paper[k]
        r["paper_table3_processors"] = PAPER_TABLE3_PROCESSORS[k]
    return r


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=["0:auto:0.5", "1:auto:0.1", "0:5e-8:0.01",
                                                   "1:5e-8:0.01"],
                    help="eta [Pa s]:dt [s or auto]:simulated ms[:explicit|implicit]")
    ap.add_argument("--rpm", type=float, default=2500.0)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--ramp-revolutions", type=float, default=0.0,
                    help="agitator start-up from rest (the scene's ramp_revolutions)")
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args(argv)
    results = []
    for case in args.cases:
        eta, dt, ms, *scheme = case.split(":")
        r = measure(float(eta), 0.0 if dt == "auto" else float(dt), args.rpm, float(ms),
                    args.threads, args.ramp_revolutions, *scheme)
        results.append(r)
        if r.get("failed"):
            print(f"eta = {r['eta']:g} Pa s {r['scheme']}, dt {dt}: FAILED {r['error']}",
                  flush=True)
            continue
        print(f"eta = {r['eta']:g} Pa s {r['scheme']}, dt {r['dt']:.3g} s ({r['dt_choice']}): "
              f"{r['n_particles']} particles, setup {r['setup_s']:.1f} s, "
              f"{r['wall_s_per_sim_ms']:.1f} s per simulated ms -> {r['projection_52p5ms_h']:.2f} h "
              f"for 52.5 ms (the LS1 paper's Table 3: {r.get('paper_table3_h', float('nan'))} h); "
              f"load {r['loadavg'][0][0]:.1f}", flush=True)
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        command = "python bench/ls1.py " + " ".join(argv if argv is not None else sys.argv[1:])
        Path(args.json).write_text(json.dumps({"benchmark": "ls1", "command": command,
                                               "rpm": args.rpm,
                                               "threads": args.threads, "cases": results},
                                              indent=2))


if __name__ == "__main__":
    main()
