"""Engine throughput: the same settled bed (or rotating drum) in millsim and in LIGGGHTS 3.8.

    python bench/engine_throughput.py --case box|drum --cores N [--json FILE] [--quick]
                                      [--prep-from DIR] [--no-liggghts] [--no-start-times]
                                      [--force-sum records|colour]

Case (shared/reference/peers.md part B): 10,000 spheres r = 1 mm, rho = 2500 kg/m3, Hertz-Mindlin
with tangential history, E = 5 MPa, nu = 0.3, COR 0.5, mu 0.3, gravity; box 44 x 44 mm, or drum
D = 80 mm, L = 40 mm at 9.5 rad/s; timed: 20,000 steps at dt = 1e-6 s. LIGGGHTS settles (and spins
up) the bed; millsim starts from that very state, so both codes time the same configuration.
Throughput = particles x steps / seconds of the timed loop (LIGGGHTS "Loop time"; millsim: the
compiled chunks, excluding start-up), both on the same number of cores in the same run.
``compile_s``: first start with an empty numba cache (compile + 10 steps); ``cached_start_s``: the
same start with the cache filled. Both are whole-process wall times. LIGGGHTS runs on N MPI ranks
(``mpirun -np N``), millsim on N numba threads; ``--prep-from`` takes LIGGGHTS' prepared state
from another run's directory, so that every core count starts from the same bed.
``--no-liggghts``: millsim alone, from the state an earlier run left in
``<workdir>/millsim_<case>_state.csv`` (a machine without LIGGGHTS: the other code's row is then
missing, not estimated). ``--no-start-times``: skip the two untimed start-up measurements (each
a whole process; a scaling study that times only the loop needs neither). ``--force-sum``: millsim's
``PhysicsSpec.force_sum`` (default ``records``).
"""

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import liggghts  # noqa: E402  (bench/liggghts.py)

DRUM_CENTRE_X = DRUM_CENTRE_Z = 0.04  # LIGGGHTS drum axis; millsim's drum axis is the y axis

MILLSIM_RUN = r"""
import json, sys, time
t0 = time.perf_counter()
import numba
from millsim.scenes import packing
from millsim.scenes.base import get_scene
values = get_scene("packing").resolve(json.loads(sys.argv[1]))
steps = int(sys.argv[2])
sim = packing.build(values)
if values["container"] == "drum":
    sim.set_wall(0, omega=values["drum_omega"])
sim.set_time_step(values["dt"])
sim.run(10, chunk=10)
start_s = time.perf_counter() - t0
loop0 = sim.wall_seconds
if steps:
    sim.run(steps, chunk=5000)
i, _, _ = sim.contact_pairs()
print(json.dumps({"start_s": start_s, "loop_s": sim.wall_seconds - loop0, "n": sim.n_particles,
                  "threads": numba.get_num_threads(), "contacts_per_particle": 2 * len(i) / sim.n_particles,
                  "list_rebuilds": int(sim.counters[0])}))
"""


def to_millsim_frame(src, dst, case):
    """LIGGGHTS state CSV -> millsim frame (drum axis moved onto the y axis)."""
    with open(src) as f, open(dst, "w", newline="") as g:
        rows = csv.DictReader(f)
        out = csv.writer(g)
        out.writerow(["x", "y", "z", "vx", "vy", "vz", "omegax", "omegay", "omegaz"])
        for r in rows:
            x, z = float(r["x"]), float(r["z"])
            if case == "drum":
                x, z = x - DRUM_CENTRE_X, z - DRUM_CENTRE_Z
            out.writerow([x, r["y"], z, r["vx"], r["vy"], r["vz"], r["omegax"], r["omegay"], r["omegaz"]])


def run_millsim(values, steps, cores, cache_dir):
    env = dict(os.environ, NUMBA_NUM_THREADS=str(cores))
    if cache_dir is not None:  # else millsim's own kernel cache (XDG_CACHE_HOME)
        env["NUMBA_CACHE_DIR"] = str(cache_dir)
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", MILLSIM_RUN, json.dumps(values), str(steps)], env=env,
                         capture_output=True, text=True)
    if out.returncode:
        raise RuntimeError(out.stderr[-3000:])
    result = json.loads(out.stdout.strip().splitlines()[-1])
    result["process_s"] = time.perf_counter() - t0
    return result


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", choices=("box", "drum"), default="box")
    ap.add_argument("--cores", type=int, default=1, help="MPI ranks / numba threads (1 to the CPUs)")
    ap.add_argument("--prep-from", help="directory of a LIGGGHTS run whose prepared state to reuse")
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--force-sum", choices=("records", "colour"), default="records",
                    help="how millsim turns contacts into particle forces (PhysicsSpec.force_sum)")
    ap.add_argument("--json", help="write the result here")
    ap.add_argument("--quick", action="store_true", help="shorter LIGGGHTS settling/spin-up (drum)")
    ap.add_argument("--workdir", default=str(HERE / "out"))
    ap.add_argument("--liggghts", action=argparse.BooleanOptionalAction, default=True,
                    help="run LIGGGHTS beside millsim (default on)")
    ap.add_argument("--start-times", action=argparse.BooleanOptionalAction, default=True,
                    help="measure the cold (compile) and cached start of millsim (default on)")
    args = ap.parse_args(argv)
    cpus = os.cpu_count() or 1
    if not 1 <= args.cores <= cpus:
        ap.error(f"--cores {args.cores}: this machine has {cpus} logical CPUs (allowed 1-{cpus})")

    load0 = os.getloadavg()
    work = Path(args.workdir)
    mine = work / f"millsim_{args.case}_state.csv"
    if args.liggghts:
        lig = liggghts.run_liggghts(args.case, args.cores, work / "liggghts" / f"{args.case}_{args.cores}",
                                    quick=args.quick, prep_from=args.prep_from)
        state = lig["spun_state_path"] if args.case == "drum" else lig["settled_state_path"]
        to_millsim_frame(state, mine, args.case)
    elif not mine.exists():
        ap.error(f"--no-liggghts needs the state of an earlier run: {mine} is missing")
    else:
        lig = dict.fromkeys(("liggghts_psps", "loop_time_s", "liggghts_version", "binary"))
    # LIGGGHTS' default end of contact (limitForce off): the same force law in both codes
    values = {"container": args.case, "init_file": str(mine), "dt": 1e-6, "skin": 2e-4,
              "convention": "unclipped", "force_sum": args.force_sum}

    if args.start_times:  # an empty kernel cache, then the same start with it filled
        with tempfile.TemporaryDirectory() as cache:
            cold = run_millsim(values, 0, args.cores, cache)
            warm = run_millsim(values, 0, args.cores, cache)
            timed = run_millsim(values, args.steps, args.cores, cache)
    else:
        cold = warm = {}
        timed = run_millsim(values, args.steps, args.cores, None)
    psps = timed["n"] * args.steps / timed["loop_s"]
    result = {
        "case": args.case, "cores": args.cores, "steps": args.steps, "n_particles": timed["n"],
        "millsim_force_sum": args.force_sum,
        "millsim_psps": psps, "liggghts_psps": lig["liggghts_psps"],
        "ratio": psps / lig["liggghts_psps"] if lig["liggghts_psps"] else None,
        "compile_s": cold.get("process_s"), "cached_start_s": warm.get("process_s"),
        "millsim_loop_s": timed["loop_s"], "liggghts_loop_s": lig["loop_time_s"],
        "millsim_threads": timed["threads"], "millsim_contacts_per_particle": timed["contacts_per_particle"],
        "millsim_list_rebuilds": timed["list_rebuilds"], "liggghts_version": lig["liggghts_version"],
        "liggghts_binary": lig["binary"], "liggghts_quick_prep": args.quick,
        "cpu_count": cpus, "loadavg": [load0, os.getloadavg()],
    }
    print(f"{'engine':10s} {'cores':>5s} {'particle-steps/s':>17s} {'loop s':>8s}")
    print(f"{'millsim':10s} {args.cores:5d} {psps:17.3g} {timed['loop_s']:8.1f}")
    if args.liggghts:
        print(f"{'LIGGGHTS':10s} {args.cores:5d} {lig['liggghts_psps']:17.3g} {lig['loop_time_s']:8.1f}")
        print(f"ratio millsim/LIGGGHTS = {result['ratio']:.2f}")
    if args.start_times:
        print(f"compile {result['compile_s']:.1f} s, cached start {result['cached_start_s']:.1f} s")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(result, indent=2))
    return result


if __name__ == "__main__":
    main()
