"""The ``millsim`` command line, the one front door of every pipeline stage: list scenes, run one
case to a netCDF file, describe a case file, stack cases into an aggregate, analyse a study
(``millsim analyse STUDY STAGE``), draw a figure of the plot registry, and write the report's
landing page with the verification verdicts (``millsim report``, ``millsim verdicts``).

Every pipeline rule calls this, so any stage can be re-run by hand with the same command.
Bad input ends with exit code 2, one line naming the key and its allowed range, and no output file:
outputs are checked before the work (a case's before its simulation), inputs as they are read, and
every output is written atomically. Ctrl-C or SIGTERM ends with one line and 128 + the signal.
"""

import argparse
import signal
import sys
import threading
from pathlib import Path

import millsim
from millsim.util import interrupt


def _parse_sets(pairs, option="--set"):
    """KEY=VALUE arguments of a repeatable option as a dict of strings; a key given twice is
    refused (the last would silently win)."""
    out = {}
    for item in pairs or ():
        if "=" not in item:
            raise ValueError(f"{option}: expected key=value, got {item!r}")
        key, value = (part.strip() for part in item.split("=", 1))
        if key in out:
            raise ValueError(f"{option}: {key} given twice ({out[key]!r} and {value!r}); "
                             "give it once")
        out[key] = value
    return out


def _load_scene_modules(modules):
    """The user's scene modules of ``--scene-module`` (files or module names), imported so that
    their scenes register themselves."""
    from .scenes import load_module

    for spec in modules or ():
        load_module(spec)


def cmd_scenes(args):
    from .scenes import load_all
    from .scenes.base import REGISTRY, get_scene

    _load_scene_modules(args.scene_module)
    if args.name:
        scene = get_scene(args.name)
        print(f"{scene.name}: {scene.summary}")
        for p in scene.params:
            print("  " + p.describe())
        series, outputs = (getattr(scene.build, key, ()) for key in ("series", "outputs"))
        if series or outputs:
            print("case file (besides the provenance):")
        for s in series:
            print(f"  {s.name}(time) [{s.units}]: {s.long_name}")
        for o in outputs:
            print("  " + o.describe())
        return 0
    load_all()
    for name in sorted(REGISTRY):
        print(f"{name:16s} {REGISTRY[name].summary}")
    return 0


def _check_out(out, inputs=(), suffix=None, key="--out"):
    """Refuse, before any work, an output that cannot be written or would replace an input."""
    from .io import check_writable

    out = Path(out)
    if suffix is not None and out.suffix != suffix:
        raise ValueError(f"{key}: must end in {suffix}, got {str(out)!r}")
    for path in inputs:
        if Path(path).resolve() == out.resolve():
            raise ValueError(f"{key}: {str(out)!r} is also an input; it would be overwritten")
    check_writable(out, key)


def _distinct(outputs):
    """Refuse two output options ({option: path or None}) naming one file: the later write
    would replace the earlier, and the command would still end well."""
    seen = {}
    for key, out in outputs.items():
        if out is None:
            continue
        where = Path(out).resolve()
        if where in seen:
            raise ValueError(f"{key}: {str(out)!r} is also {seen[where]}; give each output "
                             "its own file")
        seen[where] = key


def _threads(requested):
    """``--threads`` checked: at least 1; above the threads numba has, it runs on those and says
    so (the results are the same with any number of threads)."""
    if requested is None:
        return None
    if requested < 1:
        raise ValueError(f"--threads: must be >= 1, got {requested}")
    import numba

    available = numba.config.NUMBA_NUM_THREADS
    if requested > available:
        print(f"millsim: warning: --threads: {requested} is above the {available} threads numba "
              f"has here (cores or NUMBA_NUM_THREADS; allowed [1, {available}]); running on "
              f"{available}", file=sys.stderr)
        return available
    return requested


def cmd_run(args):
    from .io import SnapshotWriter
    from .scenes.base import RunContext, get_scene

    _load_scene_modules(args.scene_module)
    scene = get_scene(args.scene)
    sets = _parse_sets(args.set)
    if args.materials is not None:  # sugar for --set materials_file=FILE
        if "materials_file" not in {p.name for p in scene.params}:
            raise ValueError(f"--materials: scene {scene.name!r} takes no materials file")
        if "materials_file" in sets:
            raise ValueError("--materials: also given as --set materials_file; give one")
        sets["materials_file"] = args.materials
    from .util.memory import max_memory

    with max_memory(args.max_memory):  # the scenes' size bounds compare with it
        values = scene.resolve(sets)
    # checked before the run: a case that cannot be written would be lost after all its work
    _check_out(args.out, suffix=".nc")
    out = Path(args.out)
    if not args.checkpoint_every >= 0:
        raise ValueError(f"--checkpoint-every: must be >= 0, got {args.checkpoint_every:g}")
    if args.snapshots:
        # the XDMF sidecar is the same name with .xdmf: given that name, it would replace the frames
        if Path(args.snapshots).suffix not in (".h5", ".hdf5"):
            raise ValueError(f"--snapshots: must end in .h5 or .hdf5 (an .xdmf sidecar is written "
                             f"beside it), got {args.snapshots!r}")
        _check_out(args.snapshots, key="--snapshots")
        _check_out(Path(args.snapshots).with_suffix(".xdmf"), key="--snapshots")
    elif args.snapshot_contacts:
        raise ValueError("--snapshot-contacts: needs --snapshots (the contacts are written in "
                         "its frames)")
    threads = _threads(args.threads)
    snapshots = SnapshotWriter(args.snapshots, dim=values.get("dim", 3)) if args.snapshots else None
    ctx = RunContext(progress=not args.quiet, snapshots=snapshots, threads=threads,
                     checkpoint_every=args.checkpoint_every,
                     snapshot_contacts=args.snapshot_contacts)
    try:
        _, provenance = scene.run(values, ctx, out=out)
    finally:
        if snapshots is not None:
            snapshots.close()
    if not args.quiet:
        print(f"[millsim] wrote {out} ({provenance['steps']} steps, dt = {provenance['dt']:.4g} s, "
              f"{provenance['wall_time_s']:.1f} s)", file=sys.stderr)
    if snapshots is not None and snapshots.failure is not None:
        # the case is written; the snapshots asked for are not, which the exit code says
        print(f"millsim: error: --snapshots: {snapshots.failure}; snapshots removed, the case "
              f"{out} is written", file=sys.stderr)
        return 2
    return 0


def cmd_info(args):
    """Describe any netCDF file millsim writes: a case (provenance, parameters), an aggregate
    (the cases stacked and the values they were stacked over) or an analysis output; then its
    variables."""
    import json

    from .io import case_parameters, read_case

    ds = read_case(args.file)
    a = ds.attrs
    is_case = "scene" in a and "parameters_json" in a
    if not (is_case or "millsim_version" in a or str(a.get("title", "")).startswith("millsim")):
        raise ValueError(f"{args.file}: not a millsim file (no scene, millsim_version or millsim "
                         "title; `millsim run`, `aggregate` and `analyse` write them)")
    print(f"{args.file}")
    if not is_case:
        kind = "aggregate" if "stacked_over" in a else "analysis output"
        print(f"  {'kind':16s} {kind}: {a.get('title', '')}")
    for key in ("scene", "millsim_version", "engine_hash", "seed", "dt", "steps", "wall_time_s",
                "created_utc"):
        if key in a:
            print(f"  {key:16s} {a[key]}")
    if is_case:
        print("  parameters:")
        for key, value in case_parameters(ds).items():
            print(f"    {key} = {value}")
    if "source_cases" in a:
        print(f"  {'cases':16s} {len(json.loads(a['source_cases']))}")
    if "stacked_over" in a:
        print("  stacked over:")
        for name in json.loads(a["stacked_over"]):
            values = ", ".join(f"{v:g}" if isinstance(v, float) else str(v)
                               for v in ds[name].values.tolist()) if name in ds.coords else "?"
            print(f"    {name} = {values}")
    print("  variables:")
    for name, var in ds.data_vars.items():
        shape = "x".join(str(n) for n in var.shape) or "scalar"
        value = f" = {float(var):.6g}" if var.ndim == 0 and var.dtype.kind in "fiu" else ""
        print(f"    {name:28s} [{var.attrs.get('units', '?')}] {shape}{value}  {var.attrs.get('long_name', '')}")
    return 0


def cmd_aggregate(args):
    from .analysis.aggregate import aggregate
    from .io import write_netcdf
    from .scenes.base import get_scene

    _load_scene_modules(args.scene_module)
    scene = get_scene(args.scene)
    _check_out(args.out, args.cases, ".nc")
    # the scene declares each parameter once; its units label the stacking coordinates
    attrs = {p.name: {"units": p.units, "long_name": p.doc} for p in scene.params}
    write_netcdf(args.out, aggregate(scene.name, args.cases, args.over, attrs))
    return 0


def cmd_plot(args):
    from . import plots

    if args.list:
        if args.kind or args.input or args.out:
            raise ValueError("--list: takes no figure, input or --out")
        print(plots.listing())
        return 0
    if not (args.kind and args.input and args.out):
        raise ValueError("plot: give KIND INPUT --out FILE, or --list")
    _check_out(args.out, [args.input])
    plots.plot(args.kind, args.input, args.out)
    return 0


# ---- JSON and CSV outputs (also of millsim analyse: cli_analyse.py) -----------------------------

def _write_json(path, obj):
    import json

    from .io import atomic_target

    with atomic_target(path) as tmp, open(tmp, "w") as fh:
        json.dump(obj, fh, indent=2, sort_keys=True)
        fh.write("\n")


def _write_csv(path, table):
    from .io import atomic_target

    with atomic_target(path) as tmp:
        table.to_csv(tmp, index=False)


def _read_json(path, *keys):
    """A JSON file of an earlier stage, with ``keys`` required at its top level."""
    import json

    try:
        with open(path) as fh:
            obj = json.load(fh)
    except (OSError, ValueError) as exc:  # JSONDecodeError and UnicodeDecodeError are ValueErrors
        raise ValueError(f"{path}: not a readable JSON file ({exc})") from None
    missing = [k for k in keys if not isinstance(obj, dict) or k not in obj]
    if missing:
        raise ValueError(f"{path}: missing {missing}; not the choice file of the stage before")
    return obj


def cmd_report(args):
    import shlex

    from .analysis import report

    outputs = {"--json": args.json, "--rst": args.rst}
    inputs = [p for p in (args.ballmill, args.forcechain, args.bed, args.tavares, args.stirred,
                          args.ballmill3d, *(args.calibration or ())) if p]
    for key, out in outputs.items():
        _check_out(out, inputs, key=key)
    _distinct(outputs)
    summary = report.summarise(args.ballmill, args.forcechain, args.bed, args.tavares,
                               args.stirred, args.calibration,
                               command=shlex.join(["millsim", *sys.argv[1:]]),
                               ballmill3d_path=args.ballmill3d)
    _write_json(args.json, summary)
    from .io import atomic_target

    with atomic_target(args.rst) as tmp:
        tmp.write_text(report.landing_rst(summary))
    print("\n".join(report.verdict_lines(summary)))


def cmd_verdicts(args):
    from .analysis import report

    summary = _read_json(args.summary, "verdicts")
    print("\n".join(report.verdict_lines(summary)))


def cmd_evidence(args):
    """List the stale results pages; exit status 0 whatever they say (a stale page is a result to
    read), 2 for a folder that is not there."""
    from .analysis import evidence

    result = evidence.evidence(args.docs)
    if args.json:
        _write_json(args.json, result)
    print("\n".join(evidence.lines(result)))


def cmd_results_page(args):
    from .analysis import results_page

    _check_out(args.out, [args.aggregate], ".md")
    from . import plots

    results_page.write_page(args.study, args.aggregate, args.out, args.figures,
                            {p.name: (p.input, p.caption) for p in plots.PLOTS.values()})



SCENE_MODULE_HELP = ("a scene of your own: a .py file or an importable module that registers "
                     "it (repeatable; examples/my_scene.py); installed packages can instead name "
                     "it in the entry-point group millsim.scenes")


def _run_parser(sub):
    """``millsim run SCENE``: one case to a netCDF file."""
    p = sub.add_parser("run", help="run one case and write it as netCDF")
    p.add_argument("scene", help="scene name (see `millsim scenes`)")
    p.add_argument("--scene-module", action="append", metavar="FILE|MODULE", help=SCENE_MODULE_HELP)
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a parameter (repeatable)")
    p.add_argument("--out", required=True, help="output case file (.nc)")
    p.add_argument("--materials", metavar="FILE", help="materials file of the scenes that take "
                   "one (bed_impact, single_particle): --set materials_file=FILE")
    p.add_argument("--snapshots", help="optional particle snapshots (.h5 or .hdf5, with an .xdmf "
                   "sidecar of the same name for ParaView), with the walls of every frame")
    p.add_argument("--snapshot-contacts", action="store_true",
                   help="also write the touching particle pairs of every snapshot frame: a "
                        "segment between the centres with the contact point, normal and "
                        "tangential force (force chains in ParaView); not with breakage")
    p.add_argument("--threads", type=int, default=None,
                   help="threads of the compiled step loop (default, and at most: all numba has; "
                        "more is said on stderr and runs on those); systems of fewer than 2000 "
                        "particles run on one thread, which is faster there (docs/engine.md, "
                        "\"Determinism and threads\"); results are identical either way")
    p.add_argument("--checkpoint-every", type=float, default=600.0, metavar="SECONDS",
                   help="save the running case to OUT.ckpt at most this often (wall time; 0: "
                        "save none); the same command resumes from it after an interruption, "
                        "with the same result, and removes it when the case is written; not "
                        "with --snapshots (default: 600)")
    p.add_argument("--max-memory", metavar="SIZE",
                   help="memory the case may use (16G, 500M; default: the smallest of RAM, "
                        "cgroup, SLURM_MEM_PER_NODE or _PER_CPU, MILLSIM_MAX_MEMORY): a "
                        "count or grid parameter needing more is refused before the run")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=cmd_run)


def _report_parsers(sub):
    """``millsim report``, ``millsim verdicts`` and ``millsim evidence``."""
    p = sub.add_parser("report", help="the report's landing page: headline numbers, verification "
                       "verdicts, calibrated values (JSON summary + reStructuredText)")
    p.add_argument("--ballmill", help="ball-mill aggregate (.nc)")
    p.add_argument("--forcechain", help="ball-mill force-chain aggregate (.nc)")
    p.add_argument("--bed", help="bed-impact aggregate (.nc)")
    p.add_argument("--tavares", help="Tavares verification aggregate (.nc)")
    p.add_argument("--stirred", help="stirred-mill power aggregate (.nc)")
    p.add_argument("--ballmill3d", help="3D ball-mill aggregate (.nc)")
    p.add_argument("--calibration", nargs=4,
                   metavar=("FRICTION_JSON", "VISCOSITY_JSON", "PREDICTION_CSV", "REFERENCE_CSV"),
                   help="stirred-mill calibration: the choices of stages 1 and 2, the table of "
                        "stage 3 and the reference table")
    p.add_argument("--json", required=True, help="summary (JSON; `millsim verdicts` reads it)")
    p.add_argument("--rst", required=True, help="landing page (reStructuredText)")
    p.set_defaults(func=cmd_report)

    p = sub.add_parser("verdicts", help="print the verification verdicts of a summary, failed "
                       "first (exit status 0 whatever they say; 2 for an unreadable summary)")
    p.add_argument("summary", help="summary JSON of `millsim report`")
    p.set_defaults(func=cmd_verdicts)

    p = sub.add_parser("evidence", help="the results pages (docs/results) computed with another "
                       "engine than today's (millsim.provenance_hash()), and how many are current")
    p.add_argument("--docs", default="docs/results", help="folder of results pages (*.md; "
                   "default: docs/results)")
    p.add_argument("--json", help="also write the list (JSON)")
    p.set_defaults(func=cmd_evidence)

    from .analysis.results_page import STUDIES

    p = sub.add_parser("results-page", help="the markdown results page of a paper-scale study, "
                       "written from its aggregate: parameters, engine hash, cost, tables, figures")
    p.add_argument("study", choices=sorted(STUDIES), help="the study (its aggregate: ballmill.nc, "
                   "ballmill3d.nc, bed_breakage.nc, tavares_verification.nc, stirred_mill.nc)")
    p.add_argument("aggregate", help="the study's aggregate (.nc)")
    p.add_argument("--figures", help="folder of the study's figures (NAME.png; linked relative "
                   "to the page)")
    p.add_argument("--out", required=True, help="output page (.md)")
    p.set_defaults(func=cmd_results_page)


def build_parser():
    parser = argparse.ArgumentParser(
        prog="millsim", description="DEM parameter studies of mills and breakage (numba engine).")
    parser.add_argument("--version", action="version", version=f"millsim {millsim.__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("scenes", help="list scenes, or the parameters of one")
    p.add_argument("name", nargs="?", help="scene to describe")
    p.add_argument("--scene-module", action="append", metavar="FILE|MODULE", help=SCENE_MODULE_HELP)
    p.set_defaults(func=cmd_scenes)

    _run_parser(sub)

    p = sub.add_parser("info", help="describe a millsim netCDF file: a case, an aggregate or an "
                       "analysis output")
    p.add_argument("file")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("aggregate", help="stack case files along their swept parameters (netCDF)")
    p.add_argument("scene", help="scene the cases belong to")
    p.add_argument("--scene-module", action="append", metavar="FILE|MODULE", help=SCENE_MODULE_HELP)
    p.add_argument("cases", nargs="+", help="case files (.nc)")
    p.add_argument("--over", action="append", metavar="KEY",
                   help="parameter to stack along (repeatable; default: those that differ)")
    p.add_argument("--out", required=True, help="output aggregate (.nc)")
    p.set_defaults(func=cmd_aggregate)

    p = sub.add_parser("plot", help="draw a figure of the plot registry (`millsim plot --list`)")
    p.add_argument("kind", nargs="?", help="figure name (see --list)")
    p.add_argument("input", nargs="?", help="what the figure is drawn from: an aggregate (.nc), a "
                   "calibration table (.csv) or snapshots (.h5), as --list says")
    p.add_argument("--out", help="output figure (.png, .gif for animation)")
    p.add_argument("--list", action="store_true",
                   help="print the registry: name, input, caption (tab-separated)")
    p.set_defaults(func=cmd_plot)

    from .cli_analyse import analyse_parser

    analyse_parser(sub)

    _report_parsers(sub)
    return parser


def main(argv=None):
    args = build_parser().parse_args(argv)
    in_main_thread = threading.current_thread() is threading.main_thread()
    # SIGTERM (Snakemake, SLURM at the time limit) ends a run like Ctrl-C: the finally blocks of
    # the writers remove their temporary files
    previous = interrupt.install() if in_main_thread else None
    try:
        return args.func(args) or 0
    except KeyboardInterrupt as exc:
        signum = exc.args[0] if exc.args else signal.SIGINT
        print(f"millsim: interrupted ({signal.Signals(signum).name})", file=sys.stderr)
        return 128 + signum
    except KeyError as exc:
        if args.command not in ("analyse", "report", "verdicts"):
            raise
        # a column or variable the analysis needs is missing from its input
        print(f"millsim: error: missing {exc}", file=sys.stderr)
        return 2
    except (ValueError, OSError) as exc:
        # one line, also where a library's message spans several
        print(f"millsim: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except Exception as exc:  # SimulationError and friends: one clear line, non-zero exit
        from .engine import SimulationError

        if isinstance(exc, SimulationError):
            print(f"millsim: simulation stopped: {exc}", file=sys.stderr)
            return 3
        raise
    finally:
        if in_main_thread:
            interrupt.restore(previous)


if __name__ == "__main__":
    sys.exit(main())
