"""Where the step loop spends its time: a sampling profile (Linux ``perf``) of the compiled passes.

    python bench/profile_loop.py [--case box|drum|ls1] [--state CSV] [--seconds 12] [--src DIR]
                                 [--threads N] [--force-sum records|colour] [--json FILE]

Runs the throughput case of ``bench/engine_throughput.py`` (the settled 10,000-sphere bed or the
spun-up drum, from the state that script wrote, ``bench/out/millsim_<case>_state.csv``), or
(``--case ls1``) bench/ls1.py's implicit case (the full LS1 chamber at 1 Pa s and 2500 rpm, in
its ramp-up), on one thread (``--threads``), and samples it with ``perf record`` for
``--seconds`` once the loop is compiled and warm. numba's JIT code has no symbols perf can read,
so the child process writes ``/tmp/perf-<pid>.map`` (start, size, name of every function numba
compiled in it) for perf to resolve the samples. Each pass is one compiled function: the
particle pass is ``particle_block``; the box's and drum's pair pass is inlined into the parallel
loop of ``advance`` that calls it (a ``__numba_parfor_gufunc``), so the hottest parfor function
is reported as their pair pass. The sampling rate (2 kHz) gives about 24,000 samples in 12 s:
shares to about +-0.5 %. ``--src``: profile another source tree (the directory holding
millsim/), e.g. an older commit's worktree, for a profile before a change. ``--threads N``: run
on N numba threads and count the samples of each part per thread as well (a thread that
finishes its share of a parallel loop first waits in the threading library, "Python, numpy,
kernel and libraries"): a pass whose threads hold unequal sample counts is unevenly split.
"""

import argparse
import collections
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
# bench/ls1.py's implicit case: the full chamber at 1 Pa s, 2500 rpm, the agitator ramped up
# over its first revolution (the window profiled is in that ramp)
LS1 = dict(scale=1.0, slice=False, bead_diameter_min=1.8e-3, bead_diameter_max=1.8e-3, eta=1.0,
           rpm=2500.0, seed=1, ramp_revolutions=1.0, lubrication_scheme="implicit")

CHILD = r"""
import gc, json, os, sys, time
from numba.core.codegen import CPUCodeLibrary
from millsim.scenes import packing
from millsim.scenes.base import get_scene

values = json.loads(sys.argv[1])
if "container" in values:
    values = get_scene("packing").resolve(values)
    sim = packing.build(values)
    if values["container"] == "drum":
        sim.set_wall(0, omega=values["drum_omega"])
    sim.set_time_step(values["dt"])
    warm, chunk = 2000, 1000
else:  # the full LS1 (bench/ls1.py's case)
    from millsim.scenes import stirred_mill
    sim, _ = stirred_mill.build(get_scene("stirred_mill").resolve(values))
    warm, chunk = 5, 5
sim.run(warm, chunk=warm)  # compiled and warm

starts = {}
for lib in (o for o in gc.get_objects() if isinstance(o, CPUCodeLibrary)):
    module = getattr(lib, "_final_module", None)
    if module is None:
        continue
    engine = lib._codegen._engine
    for f in module.functions:
        if not f.is_declaration and engine.is_symbol_defined(f.name):
            address = engine.get_function_address(f.name)
            if address:
                starts.setdefault(address, f.name)
ordered = sorted(starts)
with open(f"/tmp/perf-{os.getpid()}.map", "w") as fh:
    for a, b in zip(ordered, ordered[1:] + [ordered[-1] + 4096]):
        fh.write(f"{a:x} {min(b - a, 1 << 20):x} {starts[a]}\n")
open(sys.argv[2], "w").write(str(os.getpid()))
w0, s0 = sim.wall_seconds, sim.step
deadline = time.perf_counter() + float(sys.argv[3])
while time.perf_counter() < deadline:
    sim.run(chunk, chunk=chunk)
print(json.dumps({"n": sim.n_particles, "psps": sim.n_particles * (sim.step - s0)
                  / (sim.wall_seconds - w0)}))
"""


def label(symbol, hottest_parfor):
    if "_setup_kernels" in symbol or "pair_resistances" in symbol or "expm1" in symbol \
            or "ieee754_log" in symbol:
        return "implicit lubrication: row set-up (resistances, thetas, preconditioner)"
    if "_product_kernels" in symbol:
        return "implicit lubrication: CG product (partner records)"
    if "_update_kernels" in symbol:
        return "implicit lubrication: CG update (impulses, residual, direction)"
    if "lub_finish" in symbol:
        return "implicit lubrication: kick with the impulses, drift"
    if "pair_block" in symbol:
        return "pair pass (contacts, in advance's parallel loop)"
    if "particle_block" in symbol:
        return "particle pass (gather, walls, integrate)"
    if symbol == hottest_parfor:
        return "pair pass (contacts, in advance's parallel loop)"
    if "parfor_gufunc" in symbol:
        return "other parallel loops (start of step; with the solve: own rows of the CG product)"
    if "build_verlet" in symbol or "neighbours" in symbol:
        return "neighbour list rebuild"
    if "reductions" in symbol:
        return "reductions (walls, bodies, audit)"
    if "models7contact" in symbol:
        return "contact law called out of line (wall contacts)"
    if "memset" in symbol or "memmove" in symbol or "memcpy" in symbol:
        return "memset / memcpy"
    if symbol.startswith("_ZN"):
        return "other compiled code"
    return "Python, numpy, kernel and libraries"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", choices=("box", "drum", "ls1"), default="box")
    ap.add_argument("--state", help="start state CSV (default: bench/out/millsim_<case>_state.csv)")
    ap.add_argument("--seconds", type=float, default=12.0)
    ap.add_argument("--src", default=str(HERE.parent / "src"), help="source tree to profile")
    ap.add_argument("--threads", type=int, default=1, help="numba threads")
    ap.add_argument("--force-sum", choices=("records", "colour"), default="records",
                    help="box and drum: PhysicsSpec.force_sum")
    ap.add_argument("--json", help="write the result here")
    args = ap.parse_args(argv)
    if shutil.which("perf") is None:
        ap.error("perf not found: install it (Debian: apt-get install linux-perf)")
    if args.case == "ls1":
        values = dict(LS1)
    else:
        state = Path(args.state or HERE / "out" / f"millsim_{args.case}_state.csv")
        if not state.exists():
            ap.error(f"{state}: no such state; write it with python bench/engine_throughput.py "
                     f"--case {args.case} --cores 1")
        values = {"container": args.case, "init_file": str(state), "dt": 1e-6, "skin": 2e-4,
                  "convention": "unclipped", "force_sum": args.force_sum}
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        ready, data = work / "ready", work / "perf.data"
        env = dict(os.environ, NUMBA_NUM_THREADS=str(args.threads), NUMBA_CACHE_DIR=str(work / "cache"),
                   PYTHONPATH=str(Path(args.src).resolve()))
        child = subprocess.Popen([sys.executable, "-c", CHILD, json.dumps(values), str(ready),
                                  str(args.seconds + 3.0)], env=env, stdout=subprocess.PIPE,
                                 text=True)
        while not ready.exists():
            if child.poll() is not None:
                raise SystemExit(f"the case stopped before the loop was warm (exit {child.returncode})")
            time.sleep(0.5)
        pid = ready.read_text()
        subprocess.run(["perf", "record", "-F", "1999", "-p", pid, "-o", str(data), "--", "sleep",
                        str(args.seconds)], check=True, capture_output=True)
        out, _ = child.communicate()
        rate = json.loads(out.strip().splitlines()[-1])
        # (perf prints symbols only beside the addresses)
        script = subprocess.run(["perf", "script", "-i", str(data), "-F", "tid,ip,sym"],
                                check=True, capture_output=True, text=True).stdout
        Path(f"/tmp/perf-{pid}.map").unlink(missing_ok=True)
    samples = collections.Counter()  # (thread id, symbol)
    for line in script.splitlines():
        fields = line.split(None, 2)
        if len(fields) >= 2:
            samples[fields[0], (fields[2:] or ["[unknown]"])[0].strip()] += 1
    symbols = collections.Counter()
    for (_, symbol), count in samples.items():
        symbols[symbol] += count
    total = sum(symbols.values())
    parfor = [s for s, _ in symbols.most_common() if "parfor_gufunc" in s]
    # the pair pass is inlined into advance's parallel loop, except where it is too large to
    # inline (the LS1's, with its lubrication rows: then it has its own symbol)
    hottest = parfor[0] if parfor and args.case != "ls1" else None
    shares, per_thread = collections.Counter(), collections.defaultdict(collections.Counter)
    for (tid, symbol), count in samples.items():
        shares[label(symbol, hottest)] += count
        per_thread[label(symbol, hottest)][tid] += count
    # the main thread first (it runs the first share of each parallel loop: the lowest rows),
    # then the threads with most samples
    tids = sorted({tid for tid, _ in samples},
                  key=lambda t: (t != pid, -sum(c for (u, _), c in samples.items() if u == t)))
    tids = tids[:args.threads]
    rows = [{"part": part, "share": count / total,
             "samples_per_thread": [per_thread[part][t] for t in tids]}
            for part, count in shares.most_common()]
    result = {"case": args.case, "src": args.src, "threads": args.threads, "samples": total,
              "seconds": args.seconds, "particle_steps_per_s": rate["psps"],
              "n_particles": rate["n"], "parts": rows, "loadavg": os.getloadavg()}
    print(f"{args.case}: {rate['psps']:.3g} particle-steps/s on {args.threads} thread(s), "
          f"{total} samples" + (", samples per thread in brackets (main thread first)"
                               if args.threads > 1 else ""))
    for row in rows:
        counts = (f"  [{', '.join(str(c) for c in row['samples_per_thread'])}]"
                  if args.threads > 1 else "")
        print(f"  {100 * row['share']:5.1f} %  {row['part']}{counts}")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(result, indent=2))
    return result


if __name__ == "__main__":
    main()
