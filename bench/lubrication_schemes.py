"""Implicit against explicit lubrication on the quick stirred-mill slice: net power, paired by seed.

    python bench/lubrication_schemes.py [--eta 0.1 1] [--seeds 1 2 3] [--threads 1]
                                        [--schemes explicit implicit]
                                        [--json bench/out/lubrication_schemes.json]

Each case is config/config.yaml's quick slice (scale 0.45, periodic slice around one disk, 4
revolutions with 2 discarded, 2500 rpm, mu = 0.3) at one viscosity and seed, run twice: the
explicit scheme at its automatic step (0.25 of the lubrication stability limit) and the implicit
scheme at its automatic step (the contacts': the dry step, t_c/50). The seed fixes the start state,
so the pair (explicit, implicit) of one seed starts identically and decorrelates later (the flow
is chaotic). Printed and stored per case: net power and its block-mean 95 % half-width (the
scene's own statistic), the energy-balance error of the window, the step, steps, compute seconds
and, for the implicit scheme, its solver iterations per step; per viscosity the mean paired
difference implicit - explicit with the standard error of the paired differences.
"""

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

QUICK = dict(scale=0.45, slice=True, revolutions=4, transient_revolutions=2, initial_swirl=0.1,
             rpm=2500, friction=0.3)


def run_case(eta, seed, scheme, threads):
    from millsim.scenes.base import RunContext, get_scene

    scene = get_scene("stirred_mill")
    values = scene.resolve(dict(QUICK, eta=eta, seed=seed, lubrication_scheme=scheme))
    t0 = time.perf_counter()
    ds, prov = scene.run(values, RunContext(progress=False, threads=threads))
    return {"eta": eta, "seed": seed, "scheme": scheme, "dt": prov["dt"],
            "dt_binding": prov["dt_binding"], "steps": prov["steps"],
            "compute_s": prov["compute_seconds"], "wall_s": time.perf_counter() - t0,
            "net_power": float(ds["net_power"]), "net_power_ci": float(ds["net_power_ci"]),
            "energy_balance_error": float(ds["energy_balance_error"]),
            "iterations_per_step": prov.get("lubrication_iterations_per_step"),
            "iterations_max": prov.get("lubrication_iterations_max")}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--eta", type=float, nargs="+", default=[0.1, 1.0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--schemes", nargs="+", default=["explicit", "implicit"],
                    choices=["explicit", "implicit"], help="(the paired summary needs both)")
    ap.add_argument("--json", help="write the cases and the paired differences here")
    args = ap.parse_args(argv)
    cases, summary = [], []
    for eta in args.eta:
        diffs = []
        for seed in args.seeds:
            pair = {}
            for scheme in args.schemes:
                r = run_case(eta, seed, scheme, args.threads)
                cases.append(r)
                pair[scheme] = r
                print(f"eta {eta:g} seed {seed} {scheme:8s} dt {r['dt']:.3g} s, "
                      f"{r['steps']} steps, {r['compute_s']:.0f} s: net power "
                      f"{r['net_power']:.4g} +- "
                      f"{r['net_power_ci']:.2g} W, balance {r['energy_balance_error']:+.2e}"
                      + (f", {r['iterations_per_step']:.2f} iterations/step"
                         if r["iterations_per_step"] is not None else ""), flush=True)
            if len(pair) == 2:
                diffs.append(pair["implicit"]["net_power"] - pair["explicit"]["net_power"])
        if not diffs:
            continue
        explicit = [c["net_power"] for c in cases if c["eta"] == eta and c["scheme"] == "explicit"]
        mean_explicit = statistics.mean(explicit)
        se = statistics.stdev(diffs) / math.sqrt(len(diffs)) if len(diffs) > 1 else math.nan
        ci = statistics.mean(c["net_power_ci"] for c in cases
                             if c["eta"] == eta and c["scheme"] == "explicit")
        row = {"eta": eta, "seeds": args.seeds, "explicit_mean": mean_explicit,
               "paired_difference": statistics.mean(diffs), "paired_difference_se": se,
               "relative_difference": statistics.mean(diffs) / mean_explicit,
               "relative_se": se / mean_explicit, "explicit_block_ci_mean": ci}
        summary.append(row)
        print(f"eta {eta:g}: implicit - explicit = {row['paired_difference']:+.4g} +- {se:.2g} W "
              f"({100 * row['relative_difference']:+.1f} +- {100 * row['relative_se']:.1f} %), "
              f"explicit {mean_explicit:.4g} W, its block 95 % half-width {ci:.2g} W", flush=True)
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        command = "python bench/lubrication_schemes.py " + " ".join(
            argv if argv is not None else sys.argv[1:])
        Path(args.json).write_text(json.dumps({"benchmark": "lubrication_schemes",
                                               "command": command, "quick": QUICK,
                                               "cases": cases, "summary": summary}, indent=2))


if __name__ == "__main__":
    main()
