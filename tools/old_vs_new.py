"""Headline observables of two quick-study result trees side by side (a physics change, old vs new).

    python tools/old_vs_new.py OLD_RESULTS NEW_RESULTS

Prints Markdown tables: the stirred mill's net power per (eta, rpm) with its 95 % interval and the
calibration choices; the single-particle verification (breakage probability and t10 against the
Tavares model, with the inside-the-interval verdicts); the bed impact's breakage. Reads the
aggregates and calibration files `make run` writes; bit-identity per case is
``tools/compare_cases.py``.
"""

import argparse
import json
from pathlib import Path

import xarray as xr


def stirred(old, new):
    a, b = (xr.open_dataset(r / "aggregate" / "stirred_mill.nc") for r in (old, new))
    print("| eta [Pa s] | rpm [min-1] | net power old [W] | net power new [W] | new / old |")
    print("|---|---|---|---|---|")
    for eta in a.eta.values:
        for rpm in a.rpm.values:
            po, co = (float(a[v].sel(eta=eta, rpm=rpm)) for v in ("net_power", "net_power_ci"))
            pn, cn = (float(b[v].sel(eta=eta, rpm=rpm)) for v in ("net_power", "net_power_ci"))
            print(f"| {eta:g} | {rpm:g} | {po:.3f} +- {co:.3f} | {pn:.3f} +- {cn:.3f} | "
                  f"{pn / po:.3f} |")
    print()
    for name in ("stirred_mill_friction.json", "stirred_mill_viscosity.json"):
        for label, root in (("old", old), ("new", new)):
            path = root / "calibration" / name
            if path.exists():
                print(f"- {label} {name}: {json.dumps(json.loads(path.read_text()))}")
    print()


def tavares(old, new):
    a, b = (xr.open_dataset(r / "aggregate" / "tavares_verification.nc") for r in (old, new))
    print("| test | mode | E/E50 | old (95 % CI) | new (95 % CI) | model | inside old / new |")
    print("|---|---|---|---|---|---|---|")
    for mode in a.prob_mode.values:
        for ratio in a.energy_ratio.values:
            row = []
            for ds in (a, b):
                s = ds.sel(prob_mode=mode, energy_ratio=ratio).isel(prob_material=0)
                row.append((float(s.prob_fraction), float(s.prob_ci_lo), float(s.prob_ci_hi),
                            float(s.prob_analytic), bool(s.prob_inside)))
            (fo, lo, ho, m, io), (fn, ln, hn, _, i_n) = row
            print(f"| P(broken) | {mode} | {ratio:g} | {fo:.3f} ({lo:.3f}-{ho:.3f}) | "
                  f"{fn:.3f} ({ln:.3f}-{hn:.3f}) | {m:.3f} | {io} / {i_n} |")
    print()
    print("| t10 [%] | set | E/E50 | old (95 % CI) | new (95 % CI) | mean of eq 8 | eq 7 | "
          "tested value inside: old (eq 7) / new (its reference) |")
    print("|---|---|---|---|---|---|---|---|")
    for case in a.frag_case.values:
        for ratio in a.frag_ratio.values:
            so, sn = (ds.sel(frag_case=case, frag_ratio=ratio) for ds in (a, b))
            expected = float(sn.t10_expected) if "t10_expected" in sn else float("nan")
            print(f"| t10 | {case} | {float(ratio):g} | {float(so.t10):.2f} "
                  f"({float(so.t10_lo):.2f}-{float(so.t10_hi):.2f}) | {float(sn.t10):.2f} "
                  f"({float(sn.t10_lo):.2f}-{float(sn.t10_hi):.2f}) | {expected:.2f} | "
                  f"{float(sn.t10_model):.2f} | {bool(so.t10_inside)} / {bool(sn.t10_inside)} |")
    print()


def bed(old, new):
    a, b = (xr.open_dataset(r / "aggregate" / "bed_breakage.nc") for r in (old, new))
    print("| bed observable | old | new | units |")
    print("|---|---|---|---|")
    for v in ("broken_fraction", "broken_particles", "breakage_events", "breakage_energy",
              "ball_energy_final", "capture_radius", "contact_time"):
        print(f"| {v} | {float(a[v].values.ravel()[0]):.5g} | {float(b[v].values.ravel()[0]):.5g} "
              f"| {a[v].attrs.get('units', '')} |")
    print()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", type=Path)
    ap.add_argument("new", type=Path)
    args = ap.parse_args(argv)
    stirred(args.old, args.new)
    tavares(args.old, args.new)
    bed(args.old, args.new)


if __name__ == "__main__":
    main()
