"""``millsim analyse STUDY STAGE``: the command lines of the analyses over case files
(millsim.analysis): the accuracy study, the stirred-mill calibration stages and the Tavares
verification. ``millsim.cli.build_parser`` adds them; their errors end as every command's do."""

from .cli import _check_out, _distinct, _parse_sets, _read_json, _write_csv, _write_json


def cmd_accuracy_collect(args):
    from .analysis import accuracy

    _check_out(args.out, args.cases)
    table = accuracy.collect(args.cases, args.name, args.series, args.ladder)
    _write_csv(args.out, table)
    print(f"{args.name}/{args.series}: {table['path'].nunique()} cases, "
          f"{table['observable'].nunique()} observables")


def cmd_accuracy_aggregate(args):
    from .analysis import accuracy
    from .io import atomic_target, write_netcdf

    _check_out(args.out, args.tables, ".nc")
    if args.summary:
        _check_out(args.summary, args.tables, key="--summary")
    _distinct({"--out": args.out, "--summary": args.summary})
    links = {tuple(k.split("/", 1)): v for k, v in _parse_sets(args.reference, "--reference").items()}
    decide = {k: v.split(",") for k, v in _parse_sets(args.decide, "--decide").items()}
    methods = _parse_sets(args.method, "--method")
    cases = accuracy.read_tables(args.tables)
    ds, text = accuracy.study(cases, args.tolerance, links, methods, decide, args.limit_fraction,
                              args.config_json)
    write_netcdf(args.out, ds)
    if args.summary:
        with atomic_target(args.summary) as tmp:
            tmp.write_text(text)
    print(text)


def cmd_accuracy_summary(args):
    from .analysis import accuracy
    from .io import read_case

    ds = read_case(args.input)
    if "point_name" not in ds.variables:
        raise ValueError(f"{args.input}: not an accuracy aggregate (`millsim analyse accuracy "
                         "aggregate` writes one)")
    print(accuracy.summary_markdown(accuracy.points_frame(ds, "point"),
                                    accuracy.points_frame(ds, "choice")))


def cmd_stirred_friction(args):
    from .analysis import stirred_mill as sm

    inputs = [*args.cases, args.reference]
    outputs = {"--table": args.table, "--summary": args.summary, "--choice": args.choice}
    for key, out in outputs.items():
        _check_out(out, inputs, key=key)
    _distinct(outputs)
    table, summary, choice = sm.calibrate_friction(sm.case_table(args.cases),
                                                   sm.read_reference(args.reference))
    _write_csv(args.table, table)
    _write_csv(args.summary, summary)
    _write_json(args.choice, choice)
    print(f"stage 1: friction = {choice['friction']:g} (refined {choice['friction_refined']:.4g})")


def cmd_stirred_viscosity(args):
    from .analysis import stirred_mill as sm

    inputs = [*args.cases, args.reference, args.friction]
    outputs = {"--table": args.table, "--choice": args.choice}
    for key, out in outputs.items():
        _check_out(out, inputs, key=key)
    _distinct(outputs)
    friction = _read_json(args.friction, "friction")["friction"]
    cases = sm.case_table(args.cases)
    table, choice = sm.calibrate_viscosity(cases, sm.read_reference(args.reference), friction,
                                           args.rpm)
    _write_csv(args.table, table)
    _write_json(args.choice, dict(friction=friction, rpm=args.rpm, fluids=choice,
                                  replicates=sm.replicate_summary(cases)))
    for fluid, c in choice.items():
        print(f"stage 2: {fluid}: eta_sim = {c['eta_sim']:g} Pa s "
              f"(refined {c['eta_sim_refined']:.4g})")


def cmd_stirred_predict(args):
    from .analysis import stirred_mill as sm

    _check_out(args.table, [*args.cases, args.reference, args.viscosity], key="--table")
    visc = _read_json(args.viscosity, "friction", "fluids")
    etas = {f: c["eta_sim"] for f, c in visc["fluids"].items()}
    table = sm.predict(sm.case_table(args.cases), sm.read_reference(args.reference),
                       visc["friction"], etas)
    _write_csv(args.table, table)


def cmd_tavares_aggregate(args):
    from .analysis import tavares_verification as tv
    from .io import write_netcdf

    _check_out(args.out, args.cases, ".nc")
    ds = tv.aggregate(args.cases)
    write_netcdf(args.out, ds)
    print("\n".join(tv.summary(ds)))


def cmd_tavares_summary(args):
    from .analysis import tavares_verification as tv
    from .io import read_case

    ds = read_case(args.input)
    if not any(key.startswith("pass_rule_") for key in ds.attrs):
        raise ValueError(f"{args.input}: not a Tavares verification aggregate (`millsim analyse "
                         "tavares aggregate` writes one)")
    print("\n".join(tv.summary(ds)))


def analyse_parser(sub):
    """``millsim analyse STUDY STAGE``: the analyses over case files (millsim.analysis)."""
    analyse = sub.add_parser("analyse", help="analyse a study's case files (accuracy, stirred-mill "
                             "calibration, Tavares verification)")
    studies = analyse.add_subparsers(dest="study", required=True, metavar="STUDY")

    acc = studies.add_parser("accuracy", help="error against run time (work-precision)")
    stages = acc.add_subparsers(dest="stage", required=True, metavar="STAGE")
    p = stages.add_parser("collect", help="one series' cases -> long table (CSV)")
    p.add_argument("cases", nargs="+")
    p.add_argument("--name", required=True, help="study name (ballmill, stirred_mill, ...)")
    p.add_argument("--series", required=True)
    p.add_argument("--ladder", required=True, help="the swept step parameter")
    p.add_argument("--out", required=True)
    p.set_defaults(func=cmd_accuracy_collect)
    p = stages.add_parser("aggregate", help="series tables -> accuracy.nc (+ markdown summary)")
    p.add_argument("tables", nargs="+")
    p.add_argument("--tolerance", type=float, default=0.01)
    p.add_argument("--limit-fraction", type=float, default=1.0,
                   help="a chosen step stays <= this fraction of the stability limit")
    p.add_argument("--reference", action="append", metavar="NAME/SERIES=OTHER",
                   help="series compared with the reference of another series of that name")
    p.add_argument("--method", action="append", metavar="NAME=METHOD",
                   help="reference method per name: auto | finest | richardson")
    p.add_argument("--decide", action="append", metavar="NAME=OBS,OBS",
                   help="observables that decide the default step (default: headline ones)")
    p.add_argument("--config-json", default="", help="the study's config, recorded as attribute")
    p.add_argument("--out", required=True)
    p.add_argument("--summary", help="markdown summary file")
    p.set_defaults(func=cmd_accuracy_aggregate)
    p = stages.add_parser("summary", help="print the markdown tables of accuracy.nc")
    p.add_argument("input")
    p.set_defaults(func=cmd_accuracy_summary)

    stirred = studies.add_parser("stirred-mill", help="stirred-mill power-draw calibration stages")
    stages = stirred.add_subparsers(dest="stage", required=True, metavar="STAGE")
    p = stages.add_parser("friction", help="stage 1: friction from dry power vs speed")
    p.add_argument("cases", nargs="+")
    p.add_argument("--reference", required=True)
    p.add_argument("--table", required=True, help="residuals per case (CSV)")
    p.add_argument("--summary", required=True, help="sum of squared residuals per friction (CSV)")
    p.add_argument("--choice", required=True, help="chosen friction (JSON)")
    p.set_defaults(func=cmd_stirred_friction)
    p = stages.add_parser("viscosity", help="stage 2: eta_sim per fluid at one speed")
    p.add_argument("cases", nargs="+")
    p.add_argument("--reference", required=True)
    p.add_argument("--friction", required=True, help="stage 1 choice (JSON)")
    p.add_argument("--rpm", type=float, required=True)
    p.add_argument("--table", required=True)
    p.add_argument("--choice", required=True)
    p.set_defaults(func=cmd_stirred_viscosity)
    p = stages.add_parser("predict", help="stage 3: power curves at the calibrated mu and eta_sim")
    p.add_argument("cases", nargs="+")
    p.add_argument("--reference", required=True)
    p.add_argument("--viscosity", required=True, help="stage 2 choice (JSON)")
    p.add_argument("--table", required=True)
    p.set_defaults(func=cmd_stirred_predict)

    tav = studies.add_parser("tavares", help="Tavares single-particle verification")
    stages = tav.add_subparsers(dest="stage", required=True, metavar="STAGE")
    p = stages.add_parser("aggregate", help="single_particle cases -> verification aggregate "
                          "(with the pass-rule results)")
    p.add_argument("cases", nargs="+")
    p.add_argument("--out", required=True)
    p.set_defaults(func=cmd_tavares_aggregate)
    p = stages.add_parser("summary", help="print the pass-rule results of an aggregate")
    p.add_argument("input")
    p.set_defaults(func=cmd_tavares_summary)
