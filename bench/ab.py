"""A/B timing of two source trees on the same case, interleaved (a change must not cost speed).

    python bench/ab.py --a OLD/src --b NEW/src [--repeats 5] [--threads 1] -- SCENE --set k=v ...
    python bench/ab.py --a src --b src --b-set force_sum=colour -- SCENE ...   (an option, one tree)

Each repeat runs ``millsim run SCENE ...`` once with tree A first on PYTHONPATH and once with tree
B, alternating, so that load changes of the machine hit both alike. Reported per tree: the median
and spread of the compute seconds of the compiled loop (``--measure``: by default the provenance
``compute_seconds``; compilation excluded: the first run of each tree warms its kernel cache and
is not counted) and the ratio B/A.
A separate pass with empty kernel caches measures the cold start (compilation included).
Output: a table on stdout and, with --json, the raw numbers.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import xarray as xr


def run(src, scene_args, threads, cache, out, measure):
    env = dict(os.environ, PYTHONPATH=str(Path(src).resolve()), NUMBA_CACHE_DIR=str(cache))
    cmd = [sys.executable, "-m", "millsim.cli", "run", *scene_args, "--quiet", "--out", str(out)]
    if threads:
        cmd += ["--threads", str(threads)]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(f"{src}: {proc.stderr[-2000:]}")
    process_s = time.perf_counter() - t0
    with xr.open_dataset(out) as ds:
        value = ds.attrs[measure] if measure in ds.attrs else ds[measure].values
        return process_s, float(value)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--a", required=True, help="source tree A (the directory holding millsim/)")
    ap.add_argument("--b", required=True, help="source tree B")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--measure", default="compute_seconds",
                    help="case attribute or scalar variable timed (default: compute_seconds, the "
                         "compiled loop's seconds; packing: timed_wall_time)")
    ap.add_argument("--b-set", action="append", default=[], metavar="K=V",
                    help="a scene parameter for B only (repeatable): A/B of an option")
    ap.add_argument("--json", help="write the raw numbers here")
    ap.add_argument("scene_args", nargs=argparse.REMAINDER, help="-- SCENE --set k=v ...")
    args = ap.parse_args(argv)
    scene_args = [a for a in args.scene_args if a != "--"]
    trees = {"A": args.a, "B": args.b}
    extra = {"A": [], "B": [a for kv in args.b_set for a in ("--set", kv)]}
    result = {"case": scene_args, "b_set": args.b_set, "threads": args.threads,
              "repeats": args.repeats,
              "load": os.getloadavg(), "cold_s": {}, "compute_s": {"A": [], "B": []}}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, src in trees.items():  # cold start, then the kernel cache stays warm
            result["cold_s"][name] = run(src, scene_args + extra[name], args.threads,
                                         tmp / f"cache{name}", tmp / "case.nc", args.measure)[0]
        for _ in range(args.repeats):
            for name, src in trees.items():
                _, compute = run(src, scene_args + extra[name], args.threads,
                                 tmp / f"cache{name}", tmp / "case.nc", args.measure)
                result["compute_s"][name].append(compute)
    med = {k: statistics.median(v) for k, v in result["compute_s"].items()}
    print(f"case: {' '.join(scene_args)}  B: {' '.join(args.b_set) or '-'}  "
          f"threads {args.threads}  repeats {args.repeats}  "
          f"load {result['load'][0]:.1f}")
    for name in trees:
        v = result["compute_s"][name]
        print(f"{name}: compute median {med[name]:.3f} s (min {min(v):.3f}, max {max(v):.3f}); "
              f"cold start {result['cold_s'][name]:.1f} s")
    print(f"B/A compute time ratio {med['B'] / med['A']:.3f}; cold start ratio "
          f"{result['cold_s']['B'] / result['cold_s']['A']:.3f}")
    result["median_s"] = med
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
