"""A drum whose shell is a triangle mesh against the same drum with the analytic cylinder (issue 17
item 2): the charge's power and angle, and the cost per particle-step.

    python bench/mesh_drum.py [--n 3000] [--segments 200] [--rings 25] [--seeds 1 2]
                              [--settle 20000] [--spinup 20000] [--steps 40000] [--dt 1e-5]
                              [--threads 2] [--json FILE]

The packing scene's drum (Hertz-Mindlin beads, r = 1 mm, mu 0.3, drum radius 40 mm and length
40 mm turning at 9.5 rad/s about y): settled, spun up, then a timed stage; the shell is either
the analytic ``cylinder_inner`` or a closed polygonal tube (inner surface on the circle of the
drum's radius: ``segments`` sides, cut into ``rings`` rings along the axis; ~2 x segments x rings
triangles) written to an STL and read back as the scene's ``liner``. Per case: the mean power
the shell puts in and the charge angle (the angle of the charge's centre of mass about the axis
from the downward vertical, mean of the timed stage's records every 1000 steps), and the timed
stage's compute time per particle-step (Simulation.wall_seconds). Seeds: the lattice jitter;
their spread is the noise the mesh is compared within. A polygon of 200 sides lies 0.012 % of
the radius inside the circle at mid-face: a geometric difference well below the noise.
"""

import argparse
import json
import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from millsim.engine.mesh_io import write_stl
from millsim.scenes.base import get_scene
from millsim.scenes.packing import build


def tube(radius, length, segments, rings, thickness):
    """Closed polygonal tube, axis along y from 0 to length; the inner surface cut into rings."""
    phi = 2.0 * math.pi * np.arange(segments) / segments
    cx, cz = np.cos(phi), np.sin(phi)
    ys = np.linspace(0.0, length, rings + 1)
    inner = np.array([[radius * cx[s], y, radius * cz[s]] for y in ys for s in range(segments)])
    outer = np.array([[(radius + thickness) * cx[s], y, (radius + thickness) * cz[s]]
                      for y in (0.0, length) for s in range(segments)])
    vertices = np.vstack([inner, outer])
    n_in = len(inner)

    def iv(ring, s):
        return ring * segments + s % segments

    def ov(end, s):
        return n_in + end * segments + s % segments

    faces = []
    for ring in range(rings):
        for s in range(segments):
            a, b, c, d = iv(ring, s), iv(ring, s + 1), iv(ring + 1, s + 1), iv(ring + 1, s)
            faces += [(a, c, b), (a, d, c)]
    for s in range(segments):
        a, b, c, d = ov(0, s), ov(0, s + 1), ov(1, s + 1), ov(1, s)
        faces += [(a, b, c), (a, c, d)]
        # ends: y = 0 faces -y, y = length faces +y
        faces += [(iv(0, s), iv(0, s + 1), ov(0, s + 1)), (iv(0, s), ov(0, s + 1), ov(0, s))]
        faces += [(iv(rings, s), ov(1, s + 1), iv(rings, s + 1)),
                  (iv(rings, s), ov(1, s), ov(1, s + 1))]
    return vertices, np.array(faces)[:, ::-1].copy()  # outward normals: into the drum inside


def run_case(args, seed, liner):
    values = get_scene("packing").resolve(dict(container="drum", n=args.n, seed=seed,
                                               liner=liner, settle_dt=args.dt, dt=args.dt))
    load = os.getloadavg()
    sim = build(values)
    sim.run(args.settle, chunk=args.settle, threads=args.threads)
    sim.set_wall(0, omega=values["drum_omega"])
    sim.run(args.spinup, chunk=args.spinup, threads=args.threads)
    work0, t0, wall0 = sim.work(wall=0), sim.time, sim.wall_seconds
    angles = []

    def record(s):
        x = s.particles.x[s.free]
        angles.append(math.degrees(math.atan2(x[:, 0].mean(), -x[:, 2].mean())))

    sim.run(args.steps, chunk=1000, observer=record, threads=args.threads)
    return dict(seed=seed, shell="mesh" if liner else "cylinder", n=sim.n_particles,
                loadavg=[load, os.getloadavg()],
                power_W=(sim.work(wall=0) - work0) / (sim.time - t0),
                charge_angle_deg=float(np.mean(angles)),
                us_per_particle_step=1e6 * (sim.wall_seconds - wall0) / (args.steps * sim.n_particles),
                triangles=int(sim._W.tri.shape[0]), rebuilds=int(sim.counters[0]))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=3000)
    ap.add_argument("--segments", type=int, default=200)
    ap.add_argument("--rings", type=int, default=25)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--settle", type=int, default=20000)
    ap.add_argument("--spinup", type=int, default=20000)
    ap.add_argument("--steps", type=int, default=40000)
    ap.add_argument("--dt", type=float, default=1e-5)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    values = get_scene("packing").resolve({})
    with tempfile.TemporaryDirectory() as tmp:
        stl = str(Path(tmp) / "tube.stl")
        write_stl(stl, *tube(values["drum_radius"], values["drum_length"], args.segments,
                             args.rings, 0.1 * values["drum_radius"]))
        rows = []
        for seed in args.seeds:
            for liner in ("", stl):
                rows.append(run_case(args, seed, liner))
                print(json.dumps(rows[-1]), flush=True)
    for shell in ("cylinder", "mesh"):
        sel = [r for r in rows if r["shell"] == shell]
        print(f"{shell:9s} power {np.mean([r['power_W'] for r in sel]):.5g} W "
              f"(seeds {[round(r['power_W'], 5) for r in sel]}), charge angle "
              f"{np.mean([r['charge_angle_deg'] for r in sel]):.3g} deg "
              f"({[round(r['charge_angle_deg'], 2) for r in sel]}), "
              f"{np.median([r['us_per_particle_step'] for r in sel]):.4g} us/particle-step")
    if args.json:
        command = "python bench/mesh_drum.py " + " ".join(sys.argv[1:] if argv is None else argv)
        args.json.write_text(json.dumps(dict(command=command, rows=rows), indent=1))


if __name__ == "__main__":
    main()
