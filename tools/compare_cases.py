"""Compare the case files of two result trees variable by variable (bit-identity of a change).

    python tools/compare_cases.py OLD_DIR NEW_DIR [--quiet]

Every ``case.nc`` under OLD_DIR is paired with the same relative path under NEW_DIR. Data
variables and coordinates are compared exactly (NaN equal to NaN); provenance attributes that
change with every run (wall time, creation time, code hash) and the variables that time the
machine (``WALL_CLOCK``) are ignored. Prints one line per case
(identical, or the variables that differ with their largest relative difference) and exits 1 when
any case differs or is missing.
"""

import argparse
import sys
from pathlib import Path

import numpy as np
import xarray as xr

# data variables that measure the machine, not the physics (the packing scene's timed window)
WALL_CLOCK = ("particle_steps_per_second", "timed_wall_time")


def differences(a: xr.Dataset, b: xr.Dataset):
    """{name: largest relative difference, or a reason} for variables that are not identical
    (the wall-clock measurements left out)."""
    out = {}
    names = sorted((set(a.variables) | set(b.variables)) - set(WALL_CLOCK))
    for name in names:
        if name not in a.variables or name not in b.variables:
            out[name] = "only in " + ("new" if name not in a.variables else "old")
            continue
        x, y = a[name].values, b[name].values
        if x.shape != y.shape:
            out[name] = f"shape {x.shape} -> {y.shape}"
            continue
        if x.dtype.kind not in "fiub":
            if not np.array_equal(x, y):
                out[name] = "differs"
            continue
        x, y = x.astype(float), y.astype(float)
        same = (x == y) | (np.isnan(x) & np.isnan(y))
        if not same.all():
            scale = np.maximum(np.abs(x), np.abs(y))
            with np.errstate(invalid="ignore", divide="ignore"):
                rel = np.where(same, 0.0, np.abs(x - y) / np.where(scale > 0, scale, 1.0))
            out[name] = float(np.nanmax(np.where(np.isnan(rel), np.inf, rel)))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--quiet", action="store_true", help="only the summary line")
    args = ap.parse_args(argv)
    old, new = Path(args.old), Path(args.new)
    cases = sorted(old.rglob("*.nc"))
    bad = 0
    for path in cases:
        rel = path.relative_to(old)
        other = new / rel
        if not other.exists():
            print(f"MISSING  {rel}")
            bad += 1
            continue
        with xr.open_dataset(path) as a, xr.open_dataset(other) as b:
            diff = differences(a.load(), b.load())
        if diff:
            bad += 1
            worst = ", ".join(f"{k} ({v:.2e})" if isinstance(v, float) else f"{k} ({v})"
                              for k, v in sorted(diff.items())[:8])
            print(f"DIFFERS  {rel}: {len(diff)} variables: {worst}")
        elif not args.quiet:
            print(f"same     {rel}")
    print(f"{len(cases) - bad} of {len(cases)} cases identical")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
