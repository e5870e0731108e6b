"""Cost of each scene's physics: wall time per simulated second vs particle count and time step.

    python bench/scaling.py [--physics ballmill2d hertz_tavares beads_lubrication]
                            [--n 1000 10000 100000] [--steps 300] [--dt-factors 0.5 0.25]
                            [--etas 0.01 1.0] [--rpm 1000] [--threads 2] [--json FILE]

Three physics, each compiled exactly as its scene compiles it:

- ``ballmill2d``: 2D disks, linear_hw, Gear, a rotating drum built of body particles, pressure
  sums and Weibull fracture compiled in (c = 1e-30 m^3 N^-4: no grain breaks). The drum of the
  ``ballmill2d`` scene (2.5 mm grains, wall disks, 16 lifters) sized for n grains at 40 %
  filling, at 0.75 n_c; the grains start as a dense hexagonal bed (spacing 0.999 d: every
  neighbour touches, the densest 2D state). Step: the scene's (t_c/25 of the sieve-size fragment,
  capped by the Haff-Werner dashpot bound: 4.7e-6 s).
- ``hertz_tavares``: 3D Hertz-Mindlin spheres with walls, gravity, rolling friction and Tavares
  breakage compiled in (the ``bed_impact`` variant; fracture energies infinite, so the loading
  work is accumulated but nothing breaks). The settled 10,000-sphere box of the throughput
  benchmark (bench/out/millsim_box_state.csv: r = 1 mm, E = 5 MPa), cut to a smaller square box
  for fewer particles and tiled side by side for more. Step 1e-6 s (the throughput case).
- ``beads_lubrication``: the ``stirred_mill`` scene with lubrication (eta = 0.1 Pa s unless
  --etas), at --rpm (default 1000: at 2500 rpm the whole chamber's first agitator hits overlap
  beads beyond the scene's guard, docs/engine.md "Stability suite"): a periodic slice scaled so
  that n beads fill it at the Table 2 filling (the whole chamber beyond 27,290 beads), from the
  scene's lattice start, where beads barely touch yet but all lubrication pairs are there. Step:
  the scene's (lubrication-bound at 0.1 Pa s: 3.4e-6 s).

Every case runs in its own process with ``--threads`` numba threads (systems below 2,000
particles run on one, as the engine does): build, 50 warm-up steps (loading the compiled loop),
then ``--steps`` timed steps (the compiled chunks only). Reported: seconds per step, wall seconds
per simulated second (per step / dt), particle-steps per second, contacts and listed pairs per
particle, list rebuilds and the seconds they took (``rebuild_s``, inside the timed loop), the
threading layer, peak memory (``ru_maxrss`` of the child) and os.getloadavg() before and
after. "vs time step": at n = 10,000 each physics again at --dt-factors x its step, and the beads
at the --etas viscosities (their step follows the lubrication bound).
"""

import argparse
import json
import math
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
BOX_STATE = HERE / "out" / "millsim_box_state.csv"
BOX_WIDTH = 0.044  # the packing scene's box side (the settled state's)
PHYSICS = ("ballmill2d", "hertz_tavares", "beads_lubrication")


# ---- builders (run in the child) -----------------------------------------------------------------

def build_ballmill2d(n, dt_factor, eta, rpm, skin_factor=1.0):
    from dataclasses import replace

    import numpy as np

    from millsim.engine import Guards, Simulation
    from millsim.models import WeibullModel
    from millsim.scenes import ballmill2d as bm
    from millsim.scenes.base import get_scene

    r = 2.5e-3
    drum = math.sqrt(n * 2 * math.sqrt(3) * r * r / (0.4 * math.pi)) + 5e-3
    values = get_scene("ballmill2d").resolve(dict(drum_radius=drum, n_grains=1, grain_radius=r,
                                                  n_over_nc=0.75, weibull_c=1e-30))
    # the scene's own simulation (one grain) gives the drum wall, the spec, the table and the step
    scene, _, omega = bm.build(values)
    p = scene.particles
    wall = p.body >= 0
    # dense hexagonal bed at the bottom of the drum, inside the lifters
    a = 2 * r * 0.999
    inner = drum - values["lifter_height"] - 1.01 * r
    k = int(inner / a) + 2
    i, j = np.meshgrid(np.arange(-k, k + 1), np.arange(-2 * k, 2 * k + 1), indexing="ij")
    xy = np.column_stack([(i + 0.5 * (j % 2)).ravel() * a, j.ravel() * a * math.sqrt(3) / 2])
    xy = xy[np.hypot(xy[:, 0], xy[:, 1]) < inner]
    xy = xy[np.argsort(xy[:, 1], kind="stable")][:n]
    if len(xy) < n:
        raise ValueError(f"ballmill2d: room for {len(xy)} grains, asked for {n}")
    x = np.vstack([p.x[wall], np.column_stack([xy, np.zeros(len(xy))])])
    radius = np.concatenate([p.radius[wall], np.full(len(xy), r)])
    body = np.concatenate([p.body[wall], np.full(len(xy), -1)])
    sim = Simulation(scene.spec, scene.table, x=x, radius=radius, material="grain", body=body,
                     bodies=[dict(kind="rotate", center=(0, 0, 0), axis=(0, 0, 1), rate=-omega)],
                     gravity=scene.gravity, thickness=scene.thickness, skin=scene.skin * skin_factor,
                     step=replace(scene.policy, dt=scene.dt * dt_factor),
                     guards=Guards(max_overlap=0.5),
                     breakage=WeibullModel(values["weibull_c"]))  # c = 1e-30: nothing breaks
    return sim, {"free_particles": len(xy), "drum_radius": drum}


def build_hertz_tavares(n, dt_factor, eta, rpm):
    import numpy as np

    from millsim.engine import Simulation, StepPolicy
    from millsim.models import Interaction, Material, MaterialTable, TavaresModel
    from millsim.scenes import bed_impact, packing
    from millsim.scenes.base import get_scene

    values = get_scene("packing").resolve({})
    x0, v0, w0 = packing.read_state(BOX_STATE)
    r = values["radius"]
    if n <= len(x0):
        side = BOX_WIDTH * math.sqrt(n / len(x0))
        keep = (x0[:, 0] <= side - r) & (x0[:, 1] <= side - r)
        x, v, w = x0[keep], v0[keep], w0[keep]
        lx = ly = side
    else:
        tiles = math.ceil(n / len(x0))
        kx = math.ceil(math.sqrt(tiles))
        ky = math.ceil(tiles / kx)
        shifts = [(ix * BOX_WIDTH, iy * BOX_WIDTH) for iy in range(ky) for ix in range(kx)][:tiles]
        x = np.vstack([x0 + [sx, sy, 0.0] for sx, sy in shifts])
        v, w = np.vstack([v0] * tiles), np.vstack([w0] * tiles)
        lx, ly = kx * BOX_WIDTH, ky * BOX_WIDTH
    # the packing scene's material (the throughput case), with its Tavares-variant spec
    table = MaterialTable([Material("grain", values["density"], values["youngs_modulus"],
                                    values["poisson_ratio"])],
                          {"*": Interaction(restitution=values["restitution"],
                                            friction=values["friction"])}, "hertz_mindlin")
    walls = [dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="grain"),
             dict(kind="plane", point=(0, 0, 0), normal=(1, 0, 0), material="grain"),
             dict(kind="plane", point=(lx, 0, 0), normal=(-1, 0, 0), material="grain"),
             dict(kind="plane", point=(0, 0, 0), normal=(0, 1, 0), material="grain"),
             dict(kind="plane", point=(0, ly, 0), normal=(0, -1, 0), material="grain")]
    sim = Simulation(bed_impact.SPEC, table, x=x, radius=np.full(len(x), r), material="grain",
                     v=v, w=w, walls=walls, skin=values["skin"],
                     step=StepPolicy(dt=values["dt"] * dt_factor, impact_speed=1.0),
                     breakage=TavaresModel({"grain": (5.0, 0.0)}))
    return sim, {"free_particles": len(x), "box": [lx, ly]}


def build_beads_lubrication(n, dt_factor, eta, rpm):
    from millsim.scenes import stirred_mill as sm
    from millsim.scenes.base import get_scene

    per_slice, per_mill = 27290, 109160  # beads at the Table 2 filling, scale 1 (slice, chamber)
    whole = n > per_slice
    scale = min(1.0, (n / (per_mill if whole else per_slice)) ** (1 / 3))
    # n beads; where the lattice start has no room for them at the Table 2 filling (small
    # slices: walls and disk take a larger share), the slice grows until it has
    while True:
        values = get_scene("stirred_mill").resolve(dict(scale=scale, slice=not whole, n_beads=n,
                                                        eta=eta, dt_factor=dt_factor, rpm=rpm,
                                                        seed=1))
        try:
            sim, g = sm.build(values)
            break
        except ValueError as err:
            if "do not fit" not in str(err) or scale >= 1.0:
                raise
            scale = min(1.0, 1.05 * scale)
    return sim, {"free_particles": g["n_beads"], "agitator_particles": g["n_agitator_particles"],
                 "scale": scale, "slice": not whole, "eta": eta, "rpm": rpm}


BUILDERS = {"ballmill2d": build_ballmill2d, "hertz_tavares": build_hertz_tavares,
            "beads_lubrication": build_beads_lubrication}


def time_list_rebuilds():
    """Time the list rebuilds from now on: a one-element list holding their seconds so far.

    They run between the compiled step passes and their serial parts cap the speed-up, so the
    rebuild the chunk runner calls is wrapped in a timer (reset the element to start a window)."""
    import time

    from millsim.engine.loop import runner as engine_loop

    rebuild_s = [0.0]
    untimed_rebuild = engine_loop.rebuilt_contacts

    def timed_rebuild(*args):
        t = time.perf_counter()
        contacts = untimed_rebuild(*args)
        rebuild_s[0] += time.perf_counter() - t
        return contacts

    engine_loop.rebuilt_contacts = timed_rebuild
    return rebuild_s


def child(physics, n, steps, dt_factor, threads, eta, rpm):
    import resource
    import time

    import numba

    rebuild_s = time_list_rebuilds()
    load0 = os.getloadavg()
    numba.set_num_threads(threads)
    t0 = time.perf_counter()
    sim, info = BUILDERS[physics](n, dt_factor, eta, rpm)
    setup_s = time.perf_counter() - t0

    def drop_events(s):  # nothing is meant to break; keep the run going if something does
        s.pop_events()

    sim.run(50, chunk=50, threads=threads, on_events=drop_events)
    loop0, rebuilds0 = sim.wall_seconds, int(sim.counters[0])
    rebuild_s[0] = 0.0
    sim.run(steps, chunk=steps, threads=threads, on_events=drop_events)
    loop_s = sim.wall_seconds - loop0
    i, _, _ = sim.contact_pairs()
    return dict(physics=physics, n=n, dt_factor=dt_factor, n_particles=sim.n_particles, **info,
                threads_requested=threads, threads_used=1 if sim.n_particles < 2000 else threads,
                dt=sim.dt, steps=steps, setup_s=setup_s, loop_s=loop_s, s_per_step=loop_s / steps,
                wall_s_per_sim_s=loop_s / (steps * sim.dt),
                particle_steps_per_s=sim.n_particles * steps / loop_s,
                contacts_per_particle=2 * len(i) / sim.n_particles,
                listed_pairs_per_particle=2 * len(sim.contacts.nbr) / sim.n_particles,
                list_rebuilds=int(sim.counters[0]) - rebuilds0, rebuild_s=rebuild_s[0],
                threading_layer=numba.threading_layer(),
                max_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                loadavg=[load0, os.getloadavg()], finite=bool((abs(sim.particles.v) < 1e30).all()))


def start(physics, n, steps, dt_factor, threads, eta, rpm):
    """The child process of one case, started (subprocess.Popen); ``result`` reads it."""
    env = dict(os.environ, NUMBA_NUM_THREADS=str(max(threads, 1)))
    cmd = [sys.executable, __file__, "--child", physics, str(n), str(steps), str(dt_factor),
           str(threads), str(eta), str(rpm)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    proc.case = dict(physics=physics, n=n, dt_factor=dt_factor, eta=eta, rpm=rpm)
    return proc


def result(proc):
    out, err = proc.communicate()
    if proc.returncode:
        return dict(proc.case, failed=True,
                    error=err.strip().splitlines()[-1] if err.strip() else "?")
    return json.loads(out.strip().splitlines()[-1])


def measure(physics, n, steps, dt_factor, threads, eta, rpm):
    return result(start(physics, n, steps, dt_factor, threads, eta, rpm))


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "--child":
        physics, n, steps, dt_factor, threads, eta, rpm = argv[1:8]
        print(json.dumps(child(physics, int(n), int(steps), float(dt_factor), int(threads),
                               float(eta), float(rpm))))
        return
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--physics", nargs="+", default=list(PHYSICS), choices=PHYSICS)
    ap.add_argument("--n", type=int, nargs="+", default=[1000, 10000, 100000])
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--dt-factors", type=float, nargs="*", default=[0.5, 0.25],
                    help="extra step factors at n = 10,000")
    ap.add_argument("--etas", type=float, nargs="*", default=[0.01, 1.0],
                    help="extra viscosities of the beads at n = 10,000")
    ap.add_argument("--eta", type=float, default=0.1, help="viscosity of the bead cases")
    ap.add_argument("--rpm", type=float, default=1000.0, help="agitator speed of the bead cases")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args(argv)
    plan = [(ph, n, 1.0, args.eta) for ph in args.physics for n in args.n]
    plan += [(ph, 10000, f, args.eta) for ph in args.physics for f in args.dt_factors]
    if "beads_lubrication" in args.physics:
        plan += [("beads_lubrication", 10000, 1.0, e) for e in args.etas]
    results = []
    command = "python bench/scaling.py " + " ".join(argv)
    for physics, n, factor, eta in plan:
        r = measure(physics, n, args.steps, factor, args.threads, eta, args.rpm)
        results.append(r)
        if args.json:  # written after every case, so an interrupted run keeps what it measured
            Path(args.json).parent.mkdir(parents=True, exist_ok=True)
            Path(args.json).write_text(json.dumps({"benchmark": "scaling", "command": command,
                                                   "steps": args.steps,
                                                   "threads": args.threads, "cases": results},
                                                  indent=2))
        if r.get("failed"):
            print(f"{physics:18s} n={n:<7d} dt x{factor:g}: FAILED {r['error']}", flush=True)
            continue
        print(f"{physics:18s} n={r['n_particles']:<7d} dt={r['dt']:.3g} s: "
              f"{r['s_per_step'] * 1e3:8.2f} ms/step, {r['wall_s_per_sim_s']:9.4g} s per simulated s, "
              f"{r['particle_steps_per_s']:.3g} particle-steps/s, {r['contacts_per_particle']:.2f} "
              f"contacts/particle, {r['max_rss_mb']:.0f} MB, load {r['loadavg'][0][0]:.1f}",
              flush=True)


if __name__ == "__main__":
    main()
