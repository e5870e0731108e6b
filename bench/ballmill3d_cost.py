"""Cost of scene ``ballmill3d`` (issue 52 item 6): the lab mill of 0.3 m at 30 % filling (25 mm
balls, 5-10 mm copper ore, ball:ore mass 1:1) with its liner against the analytic shell, and
with Tavares breakage and the collision energy spectra against without either, in seconds of
wall time per revolution.

    python bench/ballmill3d_cost.py [--length 0.5] [--steps 2000] [--repeats 3] [--threads 2]
                                    [--pour-time 0.1] [--settle-time 0.05] [--prep-dt-factor 4]
                                    [--json FILE]

drum_length 0.5 m gives about 19,000 particles (ballmill3d_charge.charge_counts); a shorter drum
is the same mill with fewer particles. Each arm (shell cylinder or liner x breakage on or off) is
built and poured and settled once (the drum still: a brief settle, not a steady charge; at
``prep-dt-factor`` x the recommended step, within the engine's limit of 5x); then the
drum turns and the arms are timed in turn, ``steps`` steps each, ``repeats`` times (interleaved,
so that machine noise falls on all arms alike); the medians of the compute time per step
(Simulation.wall_seconds) and of the wall time (the breakage handler included) are extrapolated
to one revolution at the arm's time step (2 pi / omega / dt steps). The liner is the shipped
one's design scaled to 0.3 m (engine.mesh_io.liner_mesh: 8 lifters, 15 mm high and wide, 288
sides), written to a temporary STL. An arm the engine refuses (mesh walls with breakage, until
issue 52's engine change is merged) is reported as refused.
"""

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from millsim.engine.mesh_io import liner_mesh, write_stl
from millsim.scenes import load_all
from millsim.scenes.base import get_scene

LAB = dict(drum_diameter=0.3, filling=0.3, ball_ore_ratio=1.0, ball_diameter_min=0.025,
           ball_diameter_max=0.025, ore_diameter_min=0.005, ore_diameter_max=0.010,
           n_over_nc=0.75, revolutions=1e3, transient_revolutions=0.0)


def lab_liner(path, length):
    v, f = liner_mesh(0.15, length, segments=288, lifters=8, lifter_height=0.015,
                      lifter_width=0.015)
    write_stl(path, np.column_stack([v[:, 0], v[:, 2], -v[:, 1]]), f)


def prepare(scene, values, threads, prep_factor):
    """The arm's case, poured and settled at ``prep_factor`` x the recommended step, the drum
    started; then at the recommended step (the one timed)."""
    case = scene.build(scene.resolve(dict(values, dt_factor=prep_factor)))
    sim = case.sim
    t0 = time.perf_counter()
    while case.stage != "mill":
        sim.run(case.chunk(), chunk=case.chunk(), threads=threads,
                on_events=case.on_events if sim.breakage is not None else None)
        case.after_chunk()
    sim.set_time_step(dt_factor=1.0)
    return case, time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--length", type=float, default=0.5, help="drum length [m]")
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--pour-time", type=float, default=0.1)
    ap.add_argument("--settle-time", type=float, default=0.05)
    ap.add_argument("--prep-dt-factor", type=float, default=4.0,
                    help="step of the pour and settle / the recommended step (not timed)")
    ap.add_argument("--stiffness-scale", type=float, default=1.0,
                    help="the scene's stiffness_scale (1: the materials file's moduli)")
    ap.add_argument("--d-min-ratio", type=float, default=0.05,
                    help="the scene's d_min_ratio (smallest progeny / top feed size)")
    ap.add_argument("--shells", default="cylinder,liner", help="arms' shells, comma-separated")
    ap.add_argument("--json", default="bench/out/ballmill3d_cost.json")
    a = ap.parse_args(argv)
    load_all()
    scene = get_scene("ballmill3d")
    tmp = Path(tempfile.mkdtemp())
    liner = tmp / "lab_liner.stl"
    lab_liner(liner, a.length)
    arms, refused = {}, {}
    for shell in a.shells.split(","):
        for breakage in (False, True):
            name = f"{shell}{'+breakage' if breakage else ''}"
            values = dict(LAB, drum_length=a.length, liner=str(liner) if shell == "liner" else "",
                          breakage=breakage, spectra=breakage, pour_time=a.pour_time,
                          settle_time=a.settle_time, stiffness_scale=a.stiffness_scale,
                          d_min_ratio=a.d_min_ratio)
            try:
                arms[name], prep = prepare(scene, values, a.threads, a.prep_dt_factor)
            except ValueError as exc:
                refused[name] = str(exc)
                print(f"{name}: refused: {exc}", file=sys.stderr)
                continue
            sim = arms[name].sim
            print(f"{name}: {sim.n_particles} particles, dt {sim.dt:.3g} s, prepared in "
                  f"{prep:.0f} s", file=sys.stderr, flush=True)
    compute = {name: [] for name in arms}
    wall = {name: [] for name in arms}
    for _ in range(a.repeats):
        for name, case in arms.items():
            sim = case.sim
            c0, w0 = sim.wall_seconds, time.perf_counter()
            sim.run(a.steps, chunk=a.steps, threads=a.threads,
                    on_events=case.on_events if sim.breakage is not None else None)
            compute[name].append((sim.wall_seconds - c0) / a.steps)
            wall[name].append((time.perf_counter() - w0) / a.steps)
    rows = {}
    for name, case in arms.items():
        sim = case.sim
        per_rev = case.period / sim.dt
        step_s = statistics.median(wall[name])
        rows[name] = dict(particles=sim.n_particles, dt=sim.dt, steps_per_revolution=per_rev,
                          compute_s_per_step=statistics.median(compute[name]),
                          wall_s_per_step=step_s, s_per_revolution=step_s * per_rev,
                          particle_steps_per_s=sim.n_particles / step_s,
                          breakage_events=len(case.replace.events) if case.replace else 0,
                          list_rebuilds=int(sim.counters[0]))
        print(f"{name}: {rows[name]}", file=sys.stderr)
    ratios = {}
    for shell in a.shells.split(","):
        on, off = rows.get(f"{shell}+breakage"), rows.get(shell)
        if on and off:
            ratios[f"{shell}: breakage / none, per step"] = on["wall_s_per_step"] / off["wall_s_per_step"]
            ratios[f"{shell}: breakage / none, per revolution"] = on["s_per_revolution"] / off["s_per_revolution"]
    if "liner" in rows and "cylinder" in rows:
        ratios["liner / cylinder, per step"] = rows["liner"]["wall_s_per_step"] / rows["cylinder"]["wall_s_per_step"]
    out = dict(command=" ".join(sys.argv), length=a.length, steps=a.steps, repeats=a.repeats,
               threads=a.threads, arms=rows, ratios=ratios, refused=refused,
               date=time.strftime("%Y-%m-%d"))
    Path(a.json).parent.mkdir(parents=True, exist_ok=True)
    Path(a.json).write_text(json.dumps(out, indent=1))
    print(json.dumps(ratios, indent=1))


if __name__ == "__main__":
    main()
