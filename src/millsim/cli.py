"""The ``millsim`` command line: list scenes, run one case to a netCDF file, describe a case file.

Every pipeline stage calls this, so any stage can be re-run by hand with the same command.
Bad input ends with exit code 2, one line naming the key and its allowed range, and no output file.
"""

import argparse
import sys
from pathlib import Path

import millsim


def _parse_sets(pairs):
    out = {}
    for item in pairs or ():
        if "=" not in item:
            raise ValueError(f"--set: expected key=value, got {item!r}")
        key, value = item.split("=", 1)
        out[key.strip()] = value.strip()
    return out


def cmd_scenes(args):
    from .scenes import load_all
    from .scenes.base import REGISTRY, get_scene

    if args.name:
        scene = get_scene(args.name)
        print(f"{scene.name}: {scene.summary}")
        for p in scene.params:
            print("  " + p.describe())
        return 0
    load_all()
    for name in sorted(REGISTRY):
        print(f"{name:16s} {REGISTRY[name].summary}")
    return 0


def cmd_run(args):
    from .scenes.base import RunContext, get_scene

    scene = get_scene(args.scene)
    values = scene.resolve(_parse_sets(args.set))
    out = Path(args.out)
    if out.suffix != ".nc":
        raise ValueError(f"--out: must end in .nc, got {str(out)!r}")
    if args.threads:
        import numba

        numba.set_num_threads(min(args.threads, numba.config.NUMBA_NUM_THREADS))
    from .io import SnapshotWriter, write_case

    snapshots = SnapshotWriter(args.snapshots, dim=values.get("dim", 3)) if args.snapshots else None
    try:
        data, info = scene.run(values, RunContext(progress=not args.quiet, snapshots=snapshots))
    finally:
        if snapshots is not None:
            snapshots.close()
    provenance = {"scene": scene.name, "parameters": values, "seed": info.seed, "dt": info.dt,
                  "steps": info.steps, "wall_time_s": info.wall_time_s, **info.extra}
    write_case(out, data, provenance)
    if not args.quiet:
        print(f"[millsim] wrote {out} ({info.steps} steps, dt = {info.dt:.4g} s, "
              f"{info.wall_time_s:.1f} s)", file=sys.stderr)
    return 0


def cmd_info(args):
    from .io import case_parameters, read_case

    ds = read_case(args.file)
    a = ds.attrs
    print(f"{args.file}")
    for key in ("scene", "millsim_version", "engine_hash", "seed", "dt", "steps", "wall_time_s",
                "created_utc"):
        if key in a:
            print(f"  {key:16s} {a[key]}")
    print("  parameters:")
    for key, value in case_parameters(ds).items():
        print(f"    {key} = {value}")
    print("  variables:")
    for name, var in ds.data_vars.items():
        shape = "x".join(str(n) for n in var.shape) or "scalar"
        value = f" = {float(var):.6g}" if var.ndim == 0 and var.dtype.kind in "fiu" else ""
        print(f"    {name:28s} [{var.attrs.get('units', '?')}] {shape}{value}  {var.attrs.get('long_name', '')}")
    return 0


def cmd_aggregate(args):
    from .analysis.aggregate import aggregate, write_aggregate
    from .scenes.base import get_scene

    scene = get_scene(args.scene)
    # the scene declares each parameter once; its units label the stacking coordinates
    attrs = {p.name: {"units": p.units, "long_name": p.doc} for p in scene.params}
    write_aggregate(aggregate(scene.name, args.cases, args.over, attrs), args.out)
    return 0


def cmd_plot(args):
    from .plots import plot

    plot(args.kind, args.input, args.out)
    return 0


def build_parser():
    parser = argparse.ArgumentParser(
        prog="millsim", description="DEM parameter studies of mills and breakage (numba engine).")
    parser.add_argument("--version", action="version", version=f"millsim {millsim.__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("scenes", help="list scenes, or the parameters of one")
    p.add_argument("name", nargs="?", help="scene to describe")
    p.set_defaults(func=cmd_scenes)

    p = sub.add_parser("run", help="run one case and write it as netCDF")
    p.add_argument("scene", help="scene name (see `millsim scenes`)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a parameter (repeatable)")
    p.add_argument("--out", required=True, help="output case file (.nc)")
    p.add_argument("--snapshots", help="optional particle snapshots (.h5, with an .xdmf sidecar)")
    p.add_argument("--threads", type=int, default=0, help="numba threads (default: all)")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("info", help="describe a case file")
    p.add_argument("file")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("aggregate", help="stack case files along their swept parameters (netCDF)")
    p.add_argument("scene", help="scene the cases belong to")
    p.add_argument("cases", nargs="+", help="case files (.nc)")
    p.add_argument("--over", action="append", metavar="KEY",
                   help="parameter to stack along (repeatable; default: those that differ)")
    p.add_argument("--out", required=True, help="output aggregate (.nc)")
    p.set_defaults(func=cmd_aggregate)

    p = sub.add_parser("plot", help="draw a figure from an aggregate, or a GIF from snapshots")
    p.add_argument("kind", help="ballmill_rate | ballmill_size_distributions | "
                   "ballmill_fragmentation_maps | ballmill_pressure_maps | ballmill_force_chains | "
                   "animation")
    p.add_argument("input", help="aggregate (.nc), or snapshots (.h5) for animation")
    p.add_argument("--out", required=True, help="output figure (.png, .gif for animation)")
    p.set_defaults(func=cmd_plot)
    return parser


def main(argv=None):
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, FileNotFoundError) as exc:
        print(f"millsim: error: {exc}", file=sys.stderr)
        return 2
    except Exception as exc:  # SimulationError and friends: one clear line, non-zero exit
        from .engine import SimulationError

        if isinstance(exc, SimulationError):
            print(f"millsim: simulation stopped: {exc}", file=sys.stderr)
            return 3
        raise


if __name__ == "__main__":
    sys.exit(main())
