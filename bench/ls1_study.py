"""Stirred-mill case files, above all the full-LS1 power study's: cost per case beside the
LabStar LS1 paper's Table 3, and the power, its drift, energy balance, typology and region shares
of each case (issue 12, items 2-3).

    python bench/ls1_study.py CASE.nc [CASE.nc ...] [--rows-from EARLIER.json ...]
                              [--drop CARRIED_CASE.nc ...] [--window-from CASE.nc=REV ...]
                              [--json bench/out/full_ls1_study.json]
                              [--figure docs/figures/ls1_power_series.png]

The cases are those of ``config/ls1_power.yaml`` (``snakemake ... --configfile config/paper.yaml
config/ls1_power.yaml``), each run on one thread. Cost: the compiled loop's seconds
(``compute_seconds``) per simulated millisecond, projected to the paper's 52.5 ms on one core;
the paper's Table 3 ran eta = 0 on 1 processor and eta = 1 Pa s on 8. The figure draws each
case's agitator power against time, with the averaging window and the mean with its 95 % interval,
so that a reader sees how far each case is from a steady state. ``--window-from CASE.nc=REV``
averages that case's power (mean, interval, drift) from REV revolutions instead of from the run's
own window start, for a case whose bed settled later than its run assumed
(docs/results/stirred_mill.md, "The dry bed sinks"); its energy balance and typology stay the
run's window's, and the row keeps the run's own values under ``run_window``.
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ls1 import PAPER_SIM_MS, PAPER_TABLE3_H, PAPER_TABLE3_PROCESSORS  # noqa: E402


def drift(time, power, start, blocks=8):
    """Change of the power over the averaging window [W] and its 95 % half-width: the slope of
    the block means against time (least squares, Student-t with blocks - 2 degrees of freedom)
    times the window's length. A steady state has an interval that holds 0."""
    from scipy import stats

    keep = time > start
    t, p = np.array_split(time[keep], blocks), np.array_split(power[keep], blocks)
    tm, pm = np.array([x.mean() for x in t]), np.array([x.mean() for x in p])
    fit = stats.linregress(tm, pm)
    length = time[keep][-1] - start
    return fit.slope * length, stats.t.ppf(0.975, blocks - 2) * fit.stderr * length


def window_stats(time, power, start, blocks=8):
    """Mean power over the records after ``start`` [s] (the scene's own window rule) with its 95 %
    block interval, and the window's drift with its half-width: (mean, ci, drift, drift_ci)."""
    from millsim.util.stats import block_mean_ci

    mean, ci = block_mean_ci(power[time > start + 1e-12], blocks)
    return (float(mean), float(ci), *(float(x) for x in drift(time, power, start, blocks)))


def case_row(path, window_from=None):
    """One case file's row; ``window_from`` [revolutions] moves the start of its power window."""
    from millsim.io import read_case

    ds = read_case(path, "stirred_mill")
    p = json.loads(ds.attrs["parameters_json"])
    sim_ms = float(ds.attrs["steps"]) * float(ds.attrs["dt"]) * 1e3
    s_per_ms = float(ds.attrs["compute_seconds"]) / sim_ms
    paper_h = PAPER_TABLE3_H.get(int(p["rpm"]))
    time, power, blocks = ds["time"].values, ds["agitator_power"].values, int(p["ci_blocks"])
    start = float(ds["statistics_start"])
    mean, ci = float(ds["net_power"]), float(ds["net_power_ci"])
    change, change_ci = drift(time, power, start, blocks)
    run_window = None
    if window_from is not None:
        run_window = dict(statistics_start=start, net_power=mean, net_power_ci=ci,
                          window_drift=change, window_drift_ci=change_ci)
        start = window_from * 60.0 / p["rpm"]
        if not time[0] <= start < time[-1]:
            raise SystemExit(f"--window-from: {path}: {window_from:g} revolutions is outside its "
                             f"run ({time[-1] * p['rpm'] / 60:.3g} revolutions)")
        mean, ci, change, change_ci = window_stats(time, power, start, blocks)
    wet = p["eta"] > 0
    return dict(
        case=str(path), domain=f"slice {p['scale']:g}" if p["slice"] else "full", eta=p["eta"],
        rpm=p["rpm"], dt_factor=p["dt_factor"], seed=p["seed"],
        scheme=p["lubrication_scheme"] if wet else "-",
        threads=int(ds.attrs["threads"]), dt=float(ds.attrs["dt"]), steps=int(ds.attrs["steps"]),
        sim_ms=sim_ms, revolutions=p["revolutions"], ramp_revolutions=p["ramp_revolutions"],
        initial_swirl=p["initial_swirl"],
        compute_s=float(ds.attrs["compute_seconds"]),
        s_per_sim_ms=s_per_ms, projected_h_per_52_5_ms=s_per_ms * PAPER_SIM_MS / 3600,
        # Table 3 gives the full chamber at eta = 0 and 1 Pa s only
        paper_table3_h=(paper_h[wet] if paper_h and p["eta"] in (0.0, 1.0) and not p["slice"]
                        else None),
        paper_table3_processors=PAPER_TABLE3_PROCESSORS[wet],
        cg_iterations_per_step=float(ds.attrs.get("lubrication_iterations_per_step", 0.0)),
        n_beads=int(ds["n_bead"]), n_agitator_particles=int(ds["n_agitator_particles"]),
        net_power=mean, net_power_ci=ci, statistics_start=start, run_window=run_window,
        steady_state_start=float(ds["steady_state_start"]),
        steady_state_detected=bool(ds["steady_state_detected"]),
        window_drift=change, window_drift_ci=change_ci,
        energy_balance_error=float(ds["energy_balance_error"]),
        energy_balance_error_run=float(ds["energy_balance_error_run"]),
        typology={str(k): float(v) for k, v in zip(ds["typology"].values,
                                                   ds["typology_fraction"].values)},
        regions={str(k): float(v) for k, v in zip(ds["region"].values,
                                                  ds["collision_frequency_relative"].values)},
        engine_hash=ds.attrs["engine_hash"],
        series=dict(time=ds["time"].values.tolist(), power=ds["agitator_power"].values.tolist()),
        revolution_means=revolution_means(ds["time"].values, ds["agitator_power"].values,
                                          p["rpm"]),
    )


def swirl(row):
    """The row's initial bead swirl (fraction of rigid rotation); rows carried from files made
    before it was stored all ran at 0.1 (every bench script and config did)."""
    return row.get("initial_swirl", 0.1)


def revolution_means(time, power, rpm, parts=1, partial=False):
    """Mean agitator power [W] over each 1/parts of a revolution from the start (a record at t
    stands for the interval that ends at t). A last part short of more than 2 % is left out,
    unless ``partial`` (a stopped run's last records)."""
    period = 60.0 / (rpm * parts)
    slack = 1e-9 * period  # record times are sums of steps, not exact multiples of the period
    # a case ends on its last whole record, up to a record short of the revolutions asked
    whole = int(np.ceil(time[-1] / period - 1e-9) if partial else np.floor(time[-1] / period + 0.02))
    return [float(power[(time > k * period + slack) & (time <= (k + 1) * period + slack)].mean())
            for k in range(whole)]


def revolution_table(rows):
    """Mean power over each revolution: how the start-up settles (rows carried from files made
    before this table existed have none and are left out)."""
    rows = [r for r in rows if "revolution_means" in r]
    if not rows:
        return ""
    n = max(len(r["revolution_means"]) for r in rows)
    head = ("| eta [Pa s] | rpm | ramp [rev] | initial swirl | "
            + " | ".join(f"rev {k + 1} [W]" for k in range(n)) + " |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in sorted(rows, key=lambda r: (r["eta"], r["rpm"], -swirl(r))):
        cells = [f"{m:.3g}" for m in r["revolution_means"]] + ["-"] * (n - len(r["revolution_means"]))
        lines.append(f"| {r['eta']:g} | {r['rpm']:g} | {r['ramp_revolutions']:g} | {swirl(r):g} | "
                     + " | ".join(cells) + " |")
    return "\n".join(lines)


def window(row):
    """The power window as 'from-to' revolutions, '*' where --window-from moved it."""
    rev = row["rpm"] / 60.0
    end = row["sim_ms"] * 1e-3
    moved = "*" if row.get("run_window") else ""
    return f"{row['statistics_start'] * rev:.1f}-{end * rev:.1f}{moved}"


def table(rows):
    head = ("| domain | seed | eta [Pa s] | rpm | initial swirl | dt [s] | simulated [ms] | "
            "s per simulated ms [threads] | projected 52.5 ms [h] | the LS1 paper's Table 3 [h] | "
            "CG it./step | window [rev] | net power [W] | "
            "drift over the window [W] | energy balance [%] | impact / shearing / rolling [%] |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in sorted(rows, key=lambda r: (r["domain"], r["eta"], r["rpm"], -swirl(r), r["dt"],
                                         r["seed"])):
        t = r["typology"]
        paper = (f"{r['paper_table3_h']:g} ({r['paper_table3_processors']} proc.)"
                 if r["paper_table3_h"] else "-")
        lines.append(
            f"| {r['domain']} | {r['seed']} | {r['eta']:g} | {r['rpm']:g} | {swirl(r):g} | "
            f"{r['dt']:.3g} | {r['sim_ms']:.1f} | "
            f"{r['s_per_sim_ms']:.3g} [{r['threads']}] | {r['projected_h_per_52_5_ms']:.2f} | {paper} | "
            f"{r['cg_iterations_per_step']:.2f} | {window(r)} | "
            f"{r['net_power']:.3g} +- {r['net_power_ci']:.2g} | "
            f"{r['window_drift']:+.2g} +- {r['window_drift_ci']:.2g} | "
            f"{100 * r['energy_balance_error']:+.3f} | {100 * t['impact']:.0f} / "
            f"{100 * t['shearing']:.0f} / {100 * t['rolling']:.0f} |")
    return "\n".join(lines)


def figure(rows, out):
    import matplotlib
    from matplotlib.figure import Figure

    from millsim.plots.style import RC

    speeds = sorted({r["rpm"] for r in rows})
    # one colour per viscosity and initial swirl in every panel
    kinds = sorted({(r["eta"], -swirl(r)) for r in rows})
    swirls = {swirl(r) for r in rows}
    with matplotlib.rc_context(RC):
        fig = Figure(figsize=(3.4 * len(speeds), 3.8), layout="constrained")
        axes = np.atleast_1d(fig.subplots(1, len(speeds), sharey=False))
        handles = {}
        for ax, rpm in zip(axes, speeds):
            for r in sorted((r for r in rows if r["rpm"] == rpm), key=lambda r: r["eta"]):
                kind = (r["eta"], -swirl(r))
                colour = f"C{kinds.index(kind)}"
                t = np.asarray(r["series"]["time"]) * 1e3
                label = f"{r['eta']:g} Pa s" + (f", swirl {swirl(r):g}" if len(swirls) > 1 else "")
                handles[kind], = ax.plot(t, r["series"]["power"], lw=0.9, color=colour,
                                         label=label)
                t0 = r["statistics_start"] * 1e3
                ax.hlines(r["net_power"], t0, t[-1], color=colour, lw=2)
                ax.fill_between([t0, t[-1]], r["net_power"] - r["net_power_ci"],
                                r["net_power"] + r["net_power_ci"], color=colour, alpha=0.2, lw=0)
                ax.axvline(t0, color=colour, lw=0.8, ls="--")
            ax.set(xlabel="time [ms]", ylabel="agitator power [W]", title=f"{rpm:g} min$^{{-1}}$")
            means = [r["net_power"] for r in rows if r["rpm"] == rpm]
            if max(means) > 5 * min(means):  # dry beside wet: a linear axis flattens the dry
                ax.set_yscale("log")
                ax.set_ylim(0.3 * min(means), 3 * max(means))
            else:
                ax.set_ylim(0, None)
        axes[0].legend(handles=[handles[k] for k in kinds],
                       title="simulation viscosity" + (", initial swirl" if len(swirls) > 1 else ""))
        fig.suptitle("Full LS1: agitator power against time\nthick: mean over the averaging "
                     "window (from the dashed line), band: its 95 % interval", fontsize=9)
        fig.savefig(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cases", nargs="*")
    ap.add_argument("--rows-from", nargs="+", default=[], metavar="JSON",
                    help="earlier --json files of this script: their cases join the table and "
                         "figure (case files of earlier sessions, which this machine may not have)")
    ap.add_argument("--drop", nargs="+", default=[], metavar="CASE",
                    help="carried rows to leave out, by their case path (a longer run of the same "
                         "case supersedes a shorter one)")
    ap.add_argument("--window-from", nargs="+", default=[], metavar="CASE=REV",
                    help="average this case's power from REV revolutions (a case given on the "
                         "command line)")
    ap.add_argument("--json")
    ap.add_argument("--figure")
    args = ap.parse_args(argv)
    window_from = {}
    for item in args.window_from:
        case, _, rev = item.rpartition("=")
        try:
            window_from[case] = float(rev)
        except ValueError:
            ap.error(f"--window-from: expected CASE=REVOLUTIONS, got {item!r}")
    unknown = set(window_from) - set(args.cases)
    if unknown:
        ap.error(f"--window-from: {sorted(unknown)[0]} is not among the case files given")
    earlier = [json.loads(Path(path).read_text()) for path in args.rows_from]
    rows = [row for d in earlier for row in d["cases"]]
    unknown = set(args.drop) - {row["case"] for row in rows}
    if unknown:
        ap.error(f"--drop: no carried row has case {sorted(unknown)[0]}")
    rows = [row for row in rows if row["case"] not in args.drop]
    rows += [case_row(p, window_from.get(p)) for p in args.cases]
    if not rows:
        ap.error("no cases: give case files or --rows-from")
    print(table(rows))
    print()
    print(revolution_table(rows))
    if args.json:
        command = "python bench/ls1_study.py " + " ".join(argv if argv is not None else sys.argv[1:])
        # the commands that made the carried rows: what regenerates each row
        earlier_commands = [c for d in earlier for c in [d["command"], *d.get("earlier_commands", [])]]
        Path(args.json).write_text(json.dumps(dict(command=command, earlier_commands=earlier_commands,
                                                   cases=rows), indent=1))
    if args.figure:
        figure(rows, args.figure)


if __name__ == "__main__":
    main()
