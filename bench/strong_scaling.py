"""Strong scaling: the same system on 1, 2, 4, 8, 16 cores (those the machine has).

    python bench/strong_scaling.py [--cores 1 2 4 8 16] [--n 100000] [--steps 200]
                                   [--physics ballmill2d hertz_tavares beads_lubrication]
                                   [--box | --no-box] [--box-steps 20000] [--concurrent K]
                                   [--concurrent-n M]
                                   [--json bench/out/strong_scaling.json]

Rows: the three physics of bench/scaling.py at --n particles (each compiled as its scene compiles
it, each case in its own process, warm-up then --steps timed steps of the compiled chunks), and
the settled 10,000-sphere Hertz box of bench/engine_throughput.py in millsim and in LIGGGHTS
(``mpirun -np N``) from the same prepared state for every N. Each row stores the machine's logical
CPU count and the 1-minute load average before and after it: a load above the idle cores means
the row competed with other work. Speed-up and parallel efficiency are against the same physics'
one-core row of the same run: efficiency = rate(N) / (N rate(1)). The physics rows also store
the list rebuilds in the timed steps and the seconds they took (``rebuild_s``: the part between
the compiled passes, partly serial), and the threading layer. Where LIGGGHTS cannot run (not
installed, no MPI), the box row is millsim's alone and the error is stored.

``--concurrent K``: afterwards, each physics as K separate one-thread processes at once (K <= the
CPUs). The processes share no work, so each one's rate against the one-core row shows what the
shared memory system and clock leave of a core when K are busy: a yardstick for the threaded
efficiency, not a strict bound (K processes hold K copies of the data, threads share one).
``--concurrent-n M``: those processes at M particles each (e.g. --n / K: one threaded run's
memory in all), beside a lone one-thread process at M as their reference; the clock's share of
the loss then stays, the memory's shrinks.

Core counts above the machine's are refused (a row on oversubscribed cores measures the
scheduler). bench/make_results.py turns the JSON into the "Strong scaling" table of RESULTS.md.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import engine_throughput  # noqa: E402  (bench/engine_throughput.py)
import scaling  # noqa: E402  (bench/scaling.py)
from make_results import cpu_model  # noqa: E402  (bench/make_results.py)


def default_cores():
    return [c for c in (1, 2, 4, 8, 16, 32, 64) if c <= (os.cpu_count() or 1)]


def machine_info():
    """The processor and the numerical stack, stored with the table."""
    import platform

    import numba
    import numpy

    return {"cpu_model": cpu_model() or "unknown", "logical_cpus": os.cpu_count(), "python": platform.python_version(),
            "numba": numba.__version__, "numpy": numpy.__version__}


def row(physics, cores, cpus, n, r):
    """One physics row of the table from bench/scaling.py's child result ``r``."""
    keep = ("s_per_step", "steps", "list_rebuilds", "rebuild_s", "setup_s", "threading_layer",
            "contacts_per_particle")
    return {"physics": physics, "code": "millsim", "cores": cores, "cpu_count": cpus, "n": n,
            "n_particles": r.get("n_particles", n),
            "rate": None if r.get("failed") else r["particle_steps_per_s"],
            "loadavg": r.get("loadavg"), "error": r.get("error"), **{k: r.get(k) for k in keep}}


def efficiency(rows):
    """Adds speedup and efficiency to each row, against the one-core row of the same physics and
    size (concurrent rows: their rate against it, efficiency = speed-up)."""
    one = {(r["physics"], r.get("n")): r["rate"] for r in rows
           if r["cores"] == 1 and r.get("rate") and not r.get("concurrent")}
    for r in rows:
        base = one.get((r["physics"], r.get("n")))
        if base and r.get("rate"):
            r["speedup"] = r["rate"] / base
            r["efficiency"] = r["speedup"] / r["cores"]
    return rows


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cores", type=int, nargs="+", default=default_cores())
    ap.add_argument("--n", type=int, default=100000, help="particles of the scaling.py physics")
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--physics", nargs="*", default=list(scaling.PHYSICS), choices=scaling.PHYSICS)
    ap.add_argument("--box", action=argparse.BooleanOptionalAction, default=True,
                    help="the Hertz box in millsim and LIGGGHTS (default on)")
    ap.add_argument("--box-steps", type=int, default=20000, help="millsim's timed box steps")
    ap.add_argument("--concurrent", type=int, default=0,
                    help="then each physics as this many one-thread processes at once")
    ap.add_argument("--concurrent-n", type=int,
                    help="particles of each concurrent process (default --n)")
    ap.add_argument("--json", default=str(HERE / "out" / "strong_scaling.json"))
    args = ap.parse_args(argv)
    cpus = os.cpu_count() or 1
    too_many = [c for c in args.cores + [args.concurrent] if c < 0 or c > cpus] + [
        c for c in args.cores if c < 1]
    if too_many:
        ap.error(f"--cores {too_many}: this machine has {cpus} logical CPUs (allowed 1-{cpus})")

    command = "python bench/strong_scaling.py " + " ".join(argv)
    rows = []

    machine = machine_info()

    def save():
        efficiency(rows)
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps({"benchmark": "strong_scaling", "command": command,
                                               "cpu_count": cpus, "machine": machine,
                                               "rows": rows}, indent=2))

    for cores in sorted(set(args.cores)):
        if args.box:  # first: it writes the settled state hertz_tavares is cut from
            prep = HERE / "out" / "liggghts" / "box_1"  # one prepared state for every core count
            load0 = os.getloadavg()
            box = ["--case", "box", "--cores", str(cores), "--steps", str(args.box_steps),
                   "--no-start-times"]
            # not installed here (and not installed on the fly: a machine without a network
            # would wait on apt-get), or it fails: millsim's row alone, from the state an
            # earlier run left
            error = ("LIGGGHTS: not on PATH" if not shutil.which("liggghts") else
                     "LIGGGHTS: mpirun not on PATH" if cores > 1 and not shutil.which("mpirun")
                     else None)
            try:
                d = None if error else engine_throughput.main(box + ["--prep-from", str(prep)])
            except (RuntimeError, OSError, subprocess.CalledProcessError) as err:
                error = f"LIGGGHTS: {str(err).strip().splitlines()[-1] if str(err).strip() else err!r}"
            if error:
                print(error, flush=True)
                d = engine_throughput.main(box + ["--no-liggghts"])
            load = [load0, os.getloadavg()]
            for code, rate in (("millsim", d["millsim_psps"]), ("LIGGGHTS", d["liggghts_psps"])):
                rows.append({"physics": f"hertz_box ({code})", "code": code, "cores": cores, "cpu_count": cpus,
                             "n_particles": d["n_particles"], "rate": rate, "loadavg": load,
                             "error": error if code == "LIGGGHTS" else None})
            save()
        for physics in args.physics:
            r = scaling.measure(physics, args.n, args.steps, 1.0, cores, 0.1, 1000.0)
            rows.append(row(physics, cores, cpus, args.n, r))
            save()
            print(f"{physics:18s} {cores:3d} cores: {rows[-1]['rate'] or r.get('error')}", flush=True)
    if args.concurrent:
        m = args.concurrent_n or args.n
        for physics in args.physics:
            if m != args.n:  # the lone process at this size, the reference of the K below
                r = scaling.measure(physics, m, args.steps, 1.0, 1, 0.1, 1000.0)
                rows.append(row(physics, 1, cpus, m, r))
            procs = [scaling.start(physics, m, args.steps, 1.0, 1, 0.1, 1000.0)
                     for _ in range(args.concurrent)]
            for r in [scaling.result(p) for p in procs]:
                rows.append(dict(row(physics, 1, cpus, m, r), concurrent=args.concurrent))
            save()
            rates = [r["rate"] for r in rows[-args.concurrent:] if r["rate"]]
            print(f"{physics:18s} {args.concurrent} one-thread processes at once: "
                  f"{min(rates, default=0):.3g}-{max(rates, default=0):.3g}", flush=True)
    for r in rows:
        eff = f"{r['efficiency']:.0%}" if "efficiency" in r else "-"
        together = f" ({r['concurrent']} at once)" if r.get("concurrent") else ""
        print(f"{r['physics']:24s} {r['n_particles']:8d} particles {r['cores']:3d} cores{together}  "
              f"{r['rate'] or 0:10.3g} particle-steps/s  efficiency {eff}")
    return rows


if __name__ == "__main__":
    main()
