"""Write bench/RESULTS.md from the JSON files the benchmarks left in bench/out.

    python bench/make_results.py [--out bench/RESULTS.md]

Nothing is measured here: every number comes from a JSON file, and each table names the command
that writes it. Files read (any may be missing; its section then says so):

- ``box_<cores>.json``, ``drum_<cores>.json``: bench/engine_throughput.py (millsim vs LIGGGHTS);
- ``leave_out_*.json``: bench/leave_out.py (physics compiled out vs in but inactive);
- ``scaling*.json``: bench/scaling.py (cost vs particle count and time step, peak memory);
- ``strong_scaling*.json``: bench/strong_scaling.py (the same system on 1, 2, 4, ... cores);
- ``ls1*.json``: bench/ls1.py (full-scale LS1 stirred mill vs the LabStar LS1 paper's
  Table 3);
- ``size_ratio*.json``: bench/size_ratio.py (multi-level grid at wide size ratios);
- ``mesh_drum*.json``: bench/mesh_drum.py (a drum's shell as a triangle mesh vs the cylinder).
"""

import argparse
import json
import os
import platform
import statistics
from datetime import date
from pathlib import Path

HERE = Path(__file__).resolve().parent
OUT = HERE / "out"


def _load(pattern):
    return [(p, json.loads(p.read_text())) for p in sorted(OUT.glob(pattern))]


def _g(x, digits=3):
    if x is None:
        return "-"
    if isinstance(x, str):
        return x
    if x == 0:
        return "0"
    return f"{x:.{digits}g}"


def _load_note(loads):
    """'0.9-6.3' from a list of 1-minute load averages (None: not recorded)."""
    loads = [v for v in loads if v is not None]
    if not loads:
        return "not recorded"
    lo, hi = f"{min(loads):.1f}", f"{max(loads):.1f}"
    return lo if lo == hi else f"{lo}-{hi}"


def _one_minute(pair):
    """1-minute load averages of a [before, after] pair of os.getloadavg() tuples."""
    if not pair:
        return []
    if isinstance(pair[0], (int, float)):
        return [pair[0]]
    return [p[0] for p in pair]


def _command(d):
    text = f"`{d['command']}`" if d.get("command") else "command not recorded"
    return text + (f"; {d['note']}" if d.get("note") else "")


def cpu_model():
    """The processor's name from /proc/cpuinfo ("" where there is none)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return ""


def _machine():
    model = cpu_model()
    return f"{platform.system()} {platform.machine()}, {os.cpu_count()} logical CPUs" + (
        f" ({model})" if model else "")


def _table(head, rows):
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def _seconds(value):
    """One decimal, or "-" where the run skipped it (--no-start-times)."""
    return "-" if value is None else f"{value:.1f}"


def throughput():
    files = _load("box_*.json") + _load("drum_*.json")
    text = ["## Engine throughput against LIGGGHTS 3.8", ""]
    if not files:
        return text + ["No `box_*.json` / `drum_*.json` in bench/out.", ""]
    text += ["The same settled bed of 10,000 spheres (box) or the same spun-up drum, 20,000 steps at "
             "dt = 1e-6 s in both codes in the same run; particle-steps per second of the timed loop "
             "(one measurement per file). Command (per row): "
             "`python bench/engine_throughput.py --case <case> --cores <cores> "
             "[--force-sum colour] --json bench/out/<case>_<cores>[_<force sum>_<date>].json` "
             "(force sum: `PhysicsSpec.force_sum`, records before it existed). The runs of "
             "different dates ran on different VMs: compare ratios.", ""]
    rows = []
    for p, d in files:
        rows.append([d["case"], d["cores"], d.get("millsim_force_sum", "records"),
                     _g(d["millsim_psps"]), _g(d["liggghts_psps"]),
                     f"{d['ratio']:.2f}", _g(d["millsim_contacts_per_particle"]),
                     d.get("millsim_list_rebuilds", "-"), _seconds(d.get("compile_s")),
                     _seconds(d.get("cached_start_s")), _load_note(_one_minute(d.get("loadavg"))),
                     p.name])
    text.append(_table(["case", "cores", "force sum", "millsim [particle-steps/s]",
                        "LIGGGHTS [particle-steps/s]",
                        "millsim / LIGGGHTS", "contacts/particle", "list rebuilds", "compile [s]",
                        "cached start [s]", "load (1 min)", "file"], rows))
    ratios = [d["ratio"] for _, d in files]
    text += ["", f"Median ratio millsim / LIGGGHTS over the {len(ratios)} runs: "
             f"{statistics.median(ratios):.2f}.", ""]
    return text


def leave_out():
    files = _load("leave_out_*.json")
    text = ["## Leave out what a scene does not need", ""]
    if not files:
        return text + ["No `leave_out_*.json` in bench/out.", ""]
    text += ["The settled 10,000-sphere bed of the throughput case (dry Hertz-Mindlin), timed with "
             "loops compiled with more physics than it uses, all of it inactive (fracture energies "
             "infinite, eta = 0): `inactive` = Tavares breakage + lubrication + energy audit, "
             "`breakage`, `lubrication`, `audit` = each alone. Median of the repeats; ratio = "
             "median / median of `lean` (the scene's own loop) from the same file. Each file "
             "names the command that wrote it "
             "(`leave_out_1.json`: `python bench/leave_out.py`, three variants, one thread, before "
             "the split).", ""]
    for p, d in files:
        variants = [v for v in ("lean", "inactive", "breakage", "lubrication", "audit") if v in d]
        loads = [d.get("loadavg_start", [None])[0] if d.get("loadavg_start") else None]
        rows = []
        for v in variants:
            r = d[v]
            lv = r.get("loadavg")
            if isinstance(lv, list) and lv and isinstance(lv[0], list):
                vl = [x[0] for x in lv]
            elif isinstance(lv, list) and lv:
                vl = [lv[0]]
            else:
                vl = []
            loads += vl
            rows.append([v, _g(r["median"]), f"{r['median'] / d['lean']['median']:.3f}",
                         " ".join(_g(x) for x in r["rates"]), r.get("neighbour_pairs", "-"),
                         _g(r.get("max_rss_mb")), _load_note(vl)])
        threads = d.get("threads", "1 (README; not recorded)")
        text += [f"`{p.name}` ({_command(d)}): threads {threads}, {d.get('repeats', 3)} x "
                 f"{d.get('steps', 5000)} steps per variant, load (1 min) "
                 f"{_load_note(loads)}.", ""]
        text.append(_table(["variant", "median [particle-steps/s]", "ratio to lean",
                            "repeats [particle-steps/s]", "listed pairs", "peak RSS [MB]",
                            "load (1 min)"], rows))
        text.append("")
    return text


def _rpm(c):
    """Agitator speed of a bead case (files written before it was recorded ran at the scene's
    default, 2500 rpm)."""
    if c.get("physics") != "beads_lubrication":
        return "-"
    return f"{c.get('rpm', 2500.0):.0f}"


def scaling():
    files = _load("scaling*.json")
    text = ["## Cost against particle count and time step", ""]
    if not files:
        return text + ["No `scaling*.json` in bench/out.", ""]
    text += ["Each scene's physics compiled as its scene compiles it (bench/scaling.py docstring: "
             "2D ball-mill disks with the drum body, Gear, Weibull and pressure sums; Hertz "
             "spheres with walls, gravity, rolling friction and Tavares; stirred-mill beads with "
             "lubrication, agitator body and walls). One process per case: warm-up, then the timed "
             "steps (compiled chunks only); one measurement per case. `wall/sim s` = wall seconds "
             "per simulated second = seconds per step / dt. `N` counts all particles (grains or "
             "beads + drum/agitator particles), `free` the moving ones. Peak memory: ru_maxrss of "
             "the case's process. Each file names the command that wrote it.", ""]
    for p, d in files:
        cases = d["cases"]
        base = [c for c in cases if not c.get("failed") and c.get("dt_factor") == 1.0
                and c.get("eta", 0.1) in (0.1, None)]
        extra = [c for c in cases if not c.get("failed") and c not in base]
        failed = [c for c in cases if c.get("failed")]
        loads = [x for c in cases if not c.get("failed") for x in _one_minute(c.get("loadavg"))]
        text += [f"`{p.name}` ({_command(d)}): {d.get('steps')} timed steps per case, {d.get('threads')} threads "
                 f"requested (systems below 2,000 particles run on 1), load (1 min) "
                 f"{_load_note(loads)}.", ""]
        head = ["physics", "N", "free", "rpm", "threads", "dt [s]", "ms/step", "wall/sim s [s]",
                "particle-steps/s", "contacts/particle", "listed pairs/particle", "list rebuilds",
                "setup [s]", "peak RSS [MB]", "load (1 min)"]

        def row(c):
            return [c["physics"], c["n_particles"], c.get("free_particles", "-"), _rpm(c),
                    c.get("threads_used", "-"), _g(c["dt"]), _g(c["s_per_step"] * 1e3),
                    _g(c["wall_s_per_sim_s"]), _g(c["particle_steps_per_s"]),
                    _g(c["contacts_per_particle"]), _g(c["listed_pairs_per_particle"]),
                    c["list_rebuilds"], _g(c["setup_s"]), _g(c["max_rss_mb"]),
                    _load_note(_one_minute(c.get("loadavg")))]

        text += ["Against particle count (each physics at its scene's step):", ""]
        text.append(_table(head, [row(c) for c in base]))
        text.append("")
        for ph in sorted({c["physics"] for c in base}):
            rs = sorted((c for c in base if c["physics"] == ph), key=lambda c: c["n_particles"])
            # compare like with like: the same number of threads
            rs = [c for c in rs if c.get("threads_used") == rs[-1].get("threads_used")]
            if len(rs) > 1:
                a, b = rs[0], rs[-1]
                text.append(f"- {ph}: from {a['n_particles']} to {b['n_particles']} particles "
                            f"({b.get('threads_used')} threads) the cost per particle-step changes "
                            f"by x{a['particle_steps_per_s'] / b['particle_steps_per_s']:.2f} "
                            f"(1.00 = linear scaling).")
        text.append("")
        if extra:
            text += ["Against time step (at ~10,000 free particles; for the beads the step follows "
                     "the lubrication bound, so the viscosity sets it):", ""]
            head2 = ["physics", "rpm", "eta [Pa s]", "dt factor", "dt [s]", "ms/step", "wall/sim s [s]",
                     "list rebuilds", "contacts/particle", "load (1 min)"]
            ref = {c["physics"]: c for c in base if 5000 <= c.get("free_particles", 0) <= 20000}
            rows = []
            for c in sorted(ref.values(), key=lambda c: c["physics"]) + extra:
                rows.append([c["physics"], _rpm(c), _g(c.get("eta")) if c["physics"] == "beads_lubrication"
                             else "-", _g(c["dt_factor"]), _g(c["dt"]), _g(c["s_per_step"] * 1e3),
                             _g(c["wall_s_per_sim_s"]), c["list_rebuilds"],
                             _g(c["contacts_per_particle"]),
                             _load_note(_one_minute(c.get("loadavg")))])
            text.append(_table(head2, rows))
            text.append("")
        for c in failed:
            text.append(f"- not measured: {c['physics']} n = {c['n']} ({_rpm(c)} rpm, dt x{c['dt_factor']:g}): "
                        f"{c['error']}")
        if failed:
            text.append("")
    return text


def full_ls1_study():
    files = _load("full_ls1_study.json")
    if not files:
        return []
    from ls1_study import table

    _, d = files[0]
    return ["## Full LS1 power study: cost per case beside the LS1 paper's Table 3", "",
            f"{_command(d)}: the case files of `config/ls1_power.yaml`, one thread per case, two "
            "to four cases at a time on this VM's 2 cores (the last three cases two at a time: "
            "their costs are near one idle core's). Cost = the compiled loop's seconds per "
            "simulated ms on one core, projected to the LS1 paper's 52.5 ms; Table 3 ran eta = 0 on "
            "1 processor and 1 Pa s on 8 (it gives no other viscosity). Power: mean over the averaging window "
            "with its 95 % block interval; analysis in docs/results/stirred_mill.md.", "",
            table(d["cases"]), ""]


def full_ls1_steady():
    files = _load("full_ls1_steady.json")
    if not files:
        return []
    from ls1_study import revolution_table, table

    _, d = files[0]
    earlier = d.get("earlier_commands", [])
    carried = (", carrying the rows of " + "; ".join(f"`{c}`" for c in earlier)) if earlier else ""
    return ["## Full LS1 over several revolutions: steady power", "",
            f"{_command(d)}{carried}: the cases of bench/ls1_long.sh, bench/ls1_dry_speeds.sh and "
            "bench/ls1_wet_long.sh (the power study's parameters run for 3-12 revolutions, the "
            "first half or more discarded; rows of earlier sessions carried in by --rows-from). "
            "Window: the revolutions averaged; * where --window-from started it later than the "
            "run did, after its bed settled (energy balance and typology stay the run's window's). "
            "Cost: the compiled loop's seconds per simulated ms, on the threads and load each case "
            "ran with (docs/results/stirred_mill.md says which). Analysis: "
            "docs/results/stirred_mill.md, \"Steady state on the full chamber\".", "",
            table(d["cases"]), "", "Mean power of each revolution:", "",
            revolution_table(d["cases"]), ""]


def ls1():
    files = _load("ls1*.json")
    text = ["## Full-scale LS1 stirred mill against the LS1 paper's Table 3", ""]
    if not files:
        return text + ["No `ls1*.json` in bench/out.", ""]
    text += ["Scene `stirred_mill` at scale 1, slice false (the whole 4-disk chamber), 1.8 mm "
             "beads at the Table 2 filling (config/paper.yaml): beads + agitator-disk spheres. "
             "One process per case, started from the scene's lattice start (beads barely touch "
             "yet; the lubrication pairs are all there). `setup` = building the case after the "
             "imports; `first 5 steps` = loading (or compiling) the loop; the timed run = wall "
             "time of the compiled chunks for the simulated time shown. Projection = wall per "
             "simulated ms x 52.5 ms (the LS1 paper's run, Table 3: eta = 0 on 1 processor, 1 Pa "
             "s on 8). Each file names the command that wrote it.", ""]
    for p, d in files:
        rows = []
        loads = []
        failed = [c for c in d["cases"] if c.get("failed")]
        for c in d["cases"]:
            if c.get("failed"):
                continue
            lv = _one_minute(c.get("loadavg"))
            loads += lv
            paper = c.get("paper_table3_h")
            proj = c["projection_52p5ms_h"]
            rows.append([f"{_g(c['eta'])} {c.get('scheme', 'explicit')}",
                         f"{_g(c['dt'])} ({c.get('dt_choice', '-')})", c["steps"],
                         _g(c["sim_ms"]), _g(c["setup_s"]), _g(c["first_steps_s"]),
                         _g(c["s_per_step"]), _g(c["wall_s_per_sim_ms"]), _g(proj),
                         f"{_g(paper)} ({c.get('paper_table3_processors', '-')} proc.)" if paper else "-",
                         _g(proj / paper) if paper else "-", _g(c["particle_steps_per_s"]),
                         _g(c["contacts_per_particle"]), c["list_rebuilds"], _g(c["max_rss_mb"]),
                         _load_note(lv)])
        for c in failed:
            text += [f"`{p.name}` ({_command(d)}), {d['rpm']:g} rpm, eta = {c['eta']:g} Pa s: the run did not "
                     f"complete: `{c['error']}`", ""]
        ok = [c for c in d["cases"] if not c.get("failed")]
        if not ok:
            continue
        c0 = ok[0]
        text += [f"`{p.name}` ({_command(d)}): {c0['n_particles']} particles ({c0['n_beads']} beads, "
                 f"{c0['n_agitator_particles']} agitator spheres), {d['rpm']:g} rpm, "
                 f"{d['threads']} threads, load (1 min) {_load_note(loads)}.", ""]
        text.append(_table(["eta [Pa s], scheme", "dt [s]", "steps", "simulated [ms]", "setup [s]",
                            "first 5 steps [s]", "s/step", "wall s per simulated ms",
                            "projected 52.5 ms [h]", "the LS1 paper's Table 3 [h]", "projected / paper",
                            "particle-steps/s", "contacts/particle", "list rebuilds",
                            "peak RSS [MB]", "load (1 min)"], rows))
        text.append("")
    return text


def lubrication():
    """Explicit and implicit lubrication on the quick slice: cost and the paired power check."""
    text = ["## Lubrication schemes on the quick stirred-mill slice", ""]
    cost, paired = _load("lubrication_cost*.json"), _load("lubrication_schemes*.json")
    if not cost and not paired:
        return text + ["No `lubrication_cost*.json` or `lubrication_schemes*.json` in bench/out.", ""]
    for p, d in cost:
        text += [f"Cost (`{p.name}`, {_command(d)}; {d['threads']} thread(s), fastest of the "
                 f"repeats, load (1 min) {_load_note(_one_minute(d.get('loadavg')))}):", ""]
        rows = [[_g(c["eta"]), c["scheme"], _g(c["dt"]), _g(1e3 * c["s_per_step"]),
                 _g(c["s_per_sim_ms"]), _g(c["cost_ratio"]), _g(c["iterations_per_step"])]
                for c in d["cases"]]
        text += [_table(["eta [Pa s]", "scheme", "dt [s]", "ms/step", "s per simulated ms",
                         "x first row", "CG iterations/step"], rows), ""]
    for p, d in paired:
        text += [f"Net power, paired by seed (`{p.name}`, {_command(d)}):", ""]
        rows = [[_g(c["eta"]), c["seed"], c["scheme"], _g(c["dt"]), c["steps"],
                 _g(c["compute_s"]), f"{_g(c['net_power'], 4)} +- {_g(c['net_power_ci'], 2)}",
                 _g(c["energy_balance_error"])] for c in d["cases"]]
        text += [_table(["eta [Pa s]", "seed", "scheme", "dt [s]", "steps", "compute [s]",
                         "net power [W] (block 95 %)", "balance error"], rows), ""]
        for r in d["summary"]:
            text.append(f"- eta = {r['eta']:g} Pa s: implicit - explicit = "
                        f"{100 * r['relative_difference']:+.1f} +- {100 * r['relative_se']:.1f} % "
                        f"(mean of the paired differences +- its standard error, seeds "
                        f"{r['seeds']}); the explicit runs' own block 95 % half-width "
                        f"{100 * r['explicit_block_ci_mean'] / r['explicit_mean']:.1f} %.")
        text.append("")
    return text


def size_ratio():
    """Cost per particle-step at wide size ratios: multi-level grid against the single level."""
    text = ["## Wide size ratios (multi-level grid)", ""]
    files = _load("size_ratio*.json")
    if not files:
        return text + ["No `size_ratio*.json` in bench/out.", ""]
    for p, d in files:
        text += [f"`{p.name}` ({_command(d)}; {d['n']} particles, {d['steps']} timed steps per "
                 f"case, load (1 min) {_load_note(_one_minute(d.get('loadavg')))}). "
                 "Particle-steps per second of the compiled loop; the single-level code is the "
                 "commit before the multi-level grid (`--baseline-src`), run in the same "
                 "invocation. Cases: bench/size_ratio.py's docstring.", ""]
        base = {r["case"]: r for r in d.get("single_level", [])}
        ref = {r["case"]: r["particle_steps_per_s"] for r in d["multilevel"]}
        rows = []
        for r in d["multilevel"]:
            b = base.get(r["case"])
            peer = "bed" if r["case"] == "bed+ball" else "bimodal-1" if r["case"].startswith(
                "bimodal") else None
            rel = ref[peer] / r["particle_steps_per_s"] if peer in ref else None
            rows.append([r["case"], _g(r["ratio"]), r["n"], _g(r["contacts_per_particle"]),
                         r["list_rebuilds"], _g(r["particle_steps_per_s"] / 1e6),
                         _g(b["particle_steps_per_s"] / 1e6) if b else "-",
                         _g(r["particle_steps_per_s"] / b["particle_steps_per_s"]) if b else "-",
                         _g(rel), _g(r.get("rebuild_ms")), _g(b.get("rebuild_ms")) if b else "-"])
        text += [_table(["case", "size ratio", "particles", "contacts/particle", "rebuilds",
                         "multi-level [M/s]", "single level [M/s]", "speed-up",
                         "cost vs ratio-1 peer", "list build, multi-level [ms]",
                         "list build, single level [ms]"], rows), ""]
        text += ["Cost vs ratio-1 peer: cost per particle-step of the case / that of the same "
                 "bed without the ball (`bed+ball`) or of the monodisperse bed (`bimodal-R`), "
                 "both multi-level. Issue 17 targets: <= 1.3 (ball, ratio 10) and <= 2 "
                 "(bimodal, ratio 10).", ""]
    return text


def mesh_walls():
    """A drum whose shell is a triangle mesh against the analytic cylinder: cost and physics."""
    text = ["## Triangle-mesh walls (a drum's shell as a mesh)", ""]
    files = _load("mesh_drum*.json")
    if not files:
        return text + ["No `mesh_drum*.json` in bench/out.", ""]
    for p, d in files:
        rows, by_shell = [], {}
        for r in d["rows"]:
            by_shell.setdefault(r["shell"], []).append(r)
        for shell, sel in by_shell.items():
            rows.append([shell, sel[0]["n"], sel[0]["triangles"], len(sel),
                         _g(statistics.mean(r["power_W"] * 1e3 for r in sel), 4),
                         _g(statistics.mean(r["charge_angle_deg"] for r in sel), 4),
                         _g(statistics.median(r["us_per_particle_step"] for r in sel)),
                         _load_note([x for r in sel for x in _one_minute(r.get("loadavg"))])])
        cost = {s: statistics.median(r["us_per_particle_step"] for r in sel)
                for s, sel in by_shell.items()}
        text += [f"`{p.name}` ({_command(d)}). Cases: bench/mesh_drum.py's docstring; physics "
                 "comparison in docs/results/mesh_walls.md.", "",
                 _table(["shell", "particles", "triangles", "seeds", "power [mW]",
                         "charge angle [deg]", "us per particle-step (median)", "load (1 min)"],
                        rows), ""]
        if {"mesh", "cylinder"} <= set(cost):
            text += [f"Cost of the mesh shell / the cylinder: {cost['mesh'] / cost['cylinder']:.2f}"
                     " (issue 17 target: <= 1.5 at 10,000 spheres and ~10,000 triangles).", ""]
    return text


def summary():
    """A few headline numbers, each from the newest file of its kind."""
    text = ["## Summary", ""]
    lo = _load("leave_out_*.json")
    if lo:
        name, d = lo[-1]
        parts = [f"{v} {d[v]['median'] / d['lean']['median']:.2f}"
                 for v in ("inactive", "breakage", "lubrication", "audit") if v in d]
        text.append(f"- Leave out (`{name.name}`): particle-steps/s relative to the lean loop: "
                    + ", ".join(parts) + ".")
    for name, d in _load("ls1*.json"):
        for c in d["cases"]:
            if c.get("failed"):
                text.append(f"- LS1 at {d['rpm']:g} rpm, eta = {c['eta']:g} Pa s (`{name.name}`): did "
                            f"not complete ({c['error'].split(': ', 1)[-1][:90]}...).")
                continue
            paper = c.get("paper_table3_h")
            text.append(
                f"- LS1 at {d['rpm']:g} rpm, eta = {c['eta']:g} Pa s "
                f"({c.get('scheme', 'explicit')} lubrication), dt = {c['dt']:.3g} s "
                f"({c.get('dt_choice', '-')}), {d['threads']} threads (`{name.name}`): "
                f"{c['wall_s_per_sim_ms']:.3g} s per simulated ms -> "
                f"{c['projection_52p5ms_h']:.3g} h for 52.5 ms"
                + (f" (the LabStar LS1 paper's Table 3: {paper} h on "
                   f"{c['paper_table3_processors']} processor(s))" if paper else "")
                + f"; setup {c['setup_s']:.0f} s, peak {c['max_rss_mb']:.0f} MB.")
    text.append("")
    return text


def strong_scaling():
    files = _load("strong_scaling*.json")
    text = ["## Strong scaling", ""]
    if not files:
        return text + ["No `strong_scaling*.json` in bench/out.", ""]
    for p, d in files:
        m = d.get("machine")
        where = (f"{m['cpu_model']}, {m['logical_cpus']} logical CPUs, numba {m['numba']}"
                 + (f" ({m['note']})" if m.get("note") else "")) if m else f"{d['cpu_count']} logical CPUs"
        text += [f"`{p.name}` ({_command(d)}); machine: {where}. Efficiency = rate(N) / (N rate(1)) "
                 "against the one-core row of the same run; rebuilds = the list rebuilds' share of "
                 "the timed loop; load = 1-minute load average before-after the row (above the idle "
                 "cores: the row competed with other work). Rows \"K at once\": K one-thread "
                 "processes running together: the median rate of one process (smallest-largest), "
                 "and against the one-core row.", ""]
        rows, together = [], {}
        for r in d["rows"]:
            if r.get("concurrent"):
                together.setdefault(r["physics"], []).append(r)
                continue
            loop = (r.get("s_per_step") or 0) * (r.get("steps") or 0)
            share = f"{r['rebuild_s'] / loop:.0%}" if loop and r.get("rebuild_s") is not None else "-"
            rows.append([r["physics"], r["n_particles"], r["cores"], _g(r["rate"]),
                         f"{r['speedup']:.2f}" if "speedup" in r else "-",
                         f"{r['efficiency']:.0%}" if "efficiency" in r else "-", share,
                         _load_note(_one_minute(r.get("loadavg")))])
        for physics, group in together.items():  # one row: median (min-max) of the processes
            rates = sorted(r["rate"] for r in group if r.get("rate"))
            effs = sorted(r["efficiency"] for r in group if "efficiency" in r)
            if not rates:
                continue
            loads = [x for r in group for x in (_one_minute(r.get("loadavg")) or [])]
            rows.append([physics, group[0]["n_particles"], f"1 ({group[0]['concurrent']} at once)",
                         f"{_g(statistics.median(rates))} ({_g(rates[0])}-{_g(rates[-1])})", "-",
                         f"{statistics.median(effs):.0%} ({effs[0]:.0%}-{effs[-1]:.0%})" if effs else "-",
                         "-", _load_note(loads)])
        text += [_table(["physics", "particles", "cores", "particle-steps/s", "speed-up",
                         "efficiency", "rebuilds", "load (1 min)"], rows), ""]
    return text


def pass_times():
    files = _load("pass_times*.json") + _load("ab_front*.json")
    text = ["## Each parallel pass per thread count", ""]
    if not files:
        return text + ["No `pass_times*.json` in bench/out.", ""]
    text += ["Seconds for the timed steps: the engine's loop and its list rebuilds, then each pass "
             "driven from Python (`bench/pass_times.py`); speed-up against the first row of the "
             "same physics in the same file; front = the rebuild's bounding box, size levels and "
             "cell binning (run once more outside the rebuild there); rest = the rebuild's scans, "
             "state merge and reverse index. `ab_front*`: before / after the parallel front "
             "(`bench/device_ab_front.sh`). Discussion: docs/results/scaling.md.", ""]
    for p, d in files:
        env = " ".join(f"{k}={v}" for k, v in sorted(d.get("env", {}).items())
                       if not k.startswith("NUMBA"))
        text += [f"`{p.name}` ({_command(d)}); {d.get('machine') or str(d.get('cpu_count')) + ' logical CPUs'}"
                 + (f"; environment: {env}" if env else "") + ".", ""]
        rows, first = [], {}
        for r in d["rows"]:
            if "passes" not in r:  # ab_front: one row per run
                rows.append([r["tree"], r["physics"], r["threads"], f"{r['loop_s']:.3f}", "-",
                             f"{r['rebuild_s']:.3f}", "-", "-", "-", "-"])
                continue
            one = first.setdefault(r["physics"], r)
            q = r["passes"]
            front = sum(q.get(k, 0.0) for k in ("rebuild: bounding box", "rebuild: size levels",
                                                "rebuild: cell binning"))
            rest = q.get("rebuild: scans, merge, reverse index")
            rows.append(["-", r["physics"], r["threads"], f"{r['loop_s']:.3f}",
                         f"{one['loop_s'] / r['loop_s']:.2f}",
                         f"{r['rebuild_s']:.3f} ({r['rebuild_s'] / r['loop_s']:.0%})",
                         f"{q['pair pass']:.3f}", f"{q['particle pass']:.3f}",
                         f"{rest:.3f}" if rest else "-", f"{front:.3f}" if front else "-"])
        text += [_table(["tree", "physics", "threads", "loop [s]", "speed-up", "rebuilds [s]",
                         "pair pass [s]", "particle pass [s]", "rebuild rest [s]",
                         "rebuild front [s]"], rows), ""]
    return text


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(HERE / "RESULTS.md"))
    args = ap.parse_args(argv)
    text = ["# Benchmark results", "",
            f"Generated by `python bench/make_results.py` on {date.today().isoformat()} from the "
            "JSON files in bench/out (each section names the command that writes its files; "
            "rerun it, then this script). Machine of this generation: " + _machine() + ".", "",
            "**Load.** The benchmarks ran on the project's shared 2-core VM while other jobs ran "
            "(os.getloadavg() is stored with every measurement and shown per row). With a 1-minute "
            "load above the number of cores, a measurement runs slower than on a quiet machine, "
            "by up to load / cores; compare rows of similar load, and ratios measured in the same "
            "run (millsim / LIGGGHTS, variant / lean), which the interleaving of the measurements "
            "makes largely load-independent. Timings older than the load recording say \"not "
            "recorded\".", ""]
    for section in (summary, throughput, strong_scaling, pass_times, leave_out, scaling, ls1,
                    full_ls1_study, full_ls1_steady, lubrication, size_ratio, mesh_walls):
        text += section()
    Path(args.out).write_text("\n".join(text).rstrip() + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
