"""Where the threads lose time: each parallel pass of the step loop timed alone, per thread count.

    python bench/pass_times.py [--physics ballmill2d hertz_tavares beads_lubrication]
                               [--n 100000] [--steps 200] [--threads 1 2 4 8 16] [--json FILE]

For each physics of ``bench/scaling.py`` (built as there, one process per physics, built again
for each row so that every row starts from the same state, 50 steps after the build) it runs,
at each thread count (``numba.set_num_threads``):

1. the compiled step loop as the engine runs it (``loop``: 20 warm-up steps, then ``--steps``
   timed), with the list rebuilds inside it timed (``rebuild``), and the process's minor page
   faults and context switches over the timed steps;
2. the same steps with each pass of ``engine.loop``'s ``advance`` called from Python in its own
   parallel loop (``passes``), so that each pass is timed alone: the pair pass, the particle
   pass, the serial reductions, the rebuild's parts (``neighbours.build_verlet``: the bounding
   box, size levels and cell binning timed apart on the same positions), and the per-list-lifetime
   work (scratch arrays with the pair pass's order, the near-wall pass). A pass that takes the same
   share at every thread count scales with the loop; one whose share grows is what stops it.

The Python-driven steps cost one call per pass more than the compiled loop (tens of
microseconds a step), and the rebuild's front runs twice there (timed alone, then inside the
rebuild); the ``loop`` row beside them says how far their sum is from the engine's.
Only the explicit step (no implicit lubrication: the scaling physics do not use it).
"""

import argparse
import json
import os
import resource
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import scaling  # noqa: E402  (bench/scaling.py: the builders)


def timed_parts(parts, spec, layout, clock):
    """An ``advance`` and a ``start_forces`` with the signatures of engine.loop's, each pass in
    its own parallel loop and timed into ``clock`` (name -> seconds); the colour sums' pass is
    not among them."""
    import numpy as np
    from numba import njit, prange

    from millsim.engine.loop import runner as L

    pair_block, particle_block = parts.pair_block, parts.particle_block
    start_block, reductions, near_walls_block = (parts.start_block, parts.reductions,
                                                 parts.near_walls_block)
    TRANSLATING, MESHES = spec.translating_walls, spec.mesh_walls
    BLOCK = L.BLOCK

    @njit(parallel=L.PRANGE_ONLY, fastmath=L.FAST)
    def pair_pass(n_blocks, step_now, dt, P, C, R, err, S, bs, fp):
        slots = C.nbr.shape[0]
        for b in prange(n_blocks):
            pair_block(b * slots // n_blocks, (b + 1) * slots // n_blocks, step_now, dt, P, C, R,
                       err, S, bs, fp)

    @njit(parallel=L.PRANGE_ONLY, fastmath=L.FAST)
    def particle_pass(n_blocks, step, last, t_pose, dt, P, C, W, B, R, err, S, bs, fp,
                      half_skin2):
        for blk in prange(n_blocks):
            particle_block(np.int64(blk), step, last, t_pose, dt, P, C, W, B, R, err, S, bs, fp,
                           half_skin2)

    @njit(parallel=L.PRANGE_ONLY, fastmath=L.FAST)
    def start_pass(n_blocks, t_next, dt, P, B):
        for blk in prange(n_blocks):
            start_block(np.int64(blk), t_next, dt, P, B)

    @njit(parallel=L.PRANGE_ONLY, fastmath=L.FAST)
    def near_walls_pass(n_blocks, P, W, R, S):
        for blk in prange(n_blocks):
            near_walls_block(np.int64(blk), P, W, R, S)

    def tick(name, t0):
        t1 = time.perf_counter()
        clock[name] = clock.get(name, 0.0) + t1 - t0
        return t1

    def start_forces(t, k0, dt, step0, P, C, W, B, R, A, S, bs, fp, last):
        if layout.implicit:
            raise NotImplementedError("pass_times: the implicit lubrication solve is not timed")
        n_blocks = (P.x.shape[0] + BLOCK - 1) // BLOCK
        if near_walls_block is not None:
            near_walls_pass(n_blocks, P, W, R, S)
        pair_pass(n_blocks, step0, 0.0, P, C, R, A.err, S, bs, fp)
        particle_pass(n_blocks, np.int64(0), last, t + k0 * dt, 0.0, P, C, W, B, R, A.err, S, bs,
                      fp, 0.25 * R.skin * R.skin)
        S.wall_part[:] = 0.0
        if layout.audit:
            S.audit_part[:] = 0.0

    def advance(n_steps, step, begin, t, k0, dt, step0, P, C, W, B, R, A, S, bs, fp):
        if layout.implicit:
            raise NotImplementedError("pass_times: the implicit lubrication solve is not timed")
        t0 = time.perf_counter()
        n_blocks = (P.x.shape[0] + BLOCK - 1) // BLOCK
        half_skin2 = 0.25 * R.skin * R.skin
        err, stop, rebuild = A.err, S.stop, S.rebuild
        if near_walls_block is not None:
            near_walls_pass(n_blocks, P, W, R, S)
        t0 = tick("list lifetime: near walls", t0)
        if begin:
            start_pass(n_blocks, t + (k0 + 1) * dt, dt, P, B)
            t0 = tick("start", t0)
            if L.moved_beyond(P.x, P.x_ref, half_skin2):
                rebuild[0] = 1
                return step
        while step < n_steps:
            pair_pass(n_blocks, step0 + step, dt, P, C, R, err, S, bs, fp)
            t0 = tick("pair pass", t0)
            last = step == n_steps - 1 or stop[0] != 0
            t_end, t_pose = t + (k0 + step + 1) * dt, t + (k0 + step + 2) * dt
            if TRANSLATING:
                L.place_walls(W.table, t_end)
            if MESHES:
                L.place_meshes(W.table, t_end)
                if L.mesh_travel(W, t_end) > 0.5 * R.skin:
                    rebuild[0] = 1
            particle_pass(n_blocks, step, last, t_pose, dt, P, C, W, B, R, err, S, bs, fp,
                          half_skin2)
            t0 = tick("particle pass", t0)
            reductions(t_end, dt, P, B, W, A.dissipation, S.wall_part, S.audit_part, n_blocks)
            t0 = tick("reductions (serial)", t0)
            step += 1
            if err[0] != 0 or stop[0] != 0 or (rebuild[0] != 0 and not last):
                break
        return step

    return advance, start_forces


def timed_rebuild(clock):
    """engine.loop's rebuild with build_verlet's serial front (bounding box, size levels, cell
    binning) timed apart: they are run again on the same positions first (pure functions)."""
    from millsim.engine import neighbours as nb
    from millsim.engine.loop import runner as L

    untimed = nb.rebuilt_contacts

    def rebuild(p, old, reach, dim, box_lo, box_len, periodic):
        t0 = time.perf_counter()
        lo, ext = nb._extent(p.x, box_lo, box_len)
        t1 = time.perf_counter()
        level, nlev = nb._size_levels(p.radius)
        t2 = time.perf_counter()
        nb._bin_levels(p.x, p.radius, level, nlev, reach, lo, ext, box_len, dim,
                       max(8 * p.x.shape[0], 1000))
        t3 = time.perf_counter()
        contacts = untimed(p, old, reach, dim, box_lo, box_len, periodic)
        t4 = time.perf_counter()
        for name, s in (("rebuild: bounding box", t1 - t0), ("rebuild: size levels", t2 - t1),
                        ("rebuild: cell binning", t3 - t2)):
            clock[name] = clock.get(name, 0.0) + s
        # the front again inside build_verlet: the rest is the scans, merge and reverse index
        clock["rebuild: scans, merge, reverse index"] = (
            clock.get("rebuild: scans, merge, reverse index", 0.0) + (t4 - t3) - (t3 - t0))
        clock["rebuild: count"] = clock.get("rebuild: count", 0) + 1
        return contacts

    L.rebuilt_contacts = rebuild


def timed_scratch(clock):
    from millsim.engine.loop import runner as L

    untimed = L.ChunkRunner._scratch

    def scratch(self, C, shared, P, R):
        t0 = time.perf_counter()
        S = untimed(self, C, shared, P, R)
        clock["list lifetime: scratch arrays"] = (
            clock.get("list lifetime: scratch arrays", 0.0) + time.perf_counter() - t0)
        return S

    L.ChunkRunner._scratch = scratch


def _warm_rebuild_front(sim):
    """Call the rebuild's front once, so that no row times its loading from the disk cache."""
    from millsim.engine import neighbours as nb

    p, R = sim.particles, sim._bundles()[1]
    lo, ext = nb._extent(p.x, R.box_lo, R.box_len)
    level, nlev = nb._size_levels(p.radius)
    nb._bin_levels(p.x, p.radius, level, nlev, R.skin + R.reach, lo, ext, R.box_len, R.dim,
                   max(8 * p.x.shape[0], 1000))


def usage():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_minflt, r.ru_nvcsw, r.ru_nivcsw


def run_rows(physics, n, steps, thread_counts):
    import numba

    from millsim.engine import simulation as engine_simulation
    from millsim.engine.loop import runner as L

    rebuild_s = scaling.time_list_rebuilds()

    def drop_events(s):
        s.pop_events()

    def fresh(threads):
        """The system as built, 50 steps run: every row starts from the same state."""
        numba.set_num_threads(threads)
        sim, info = scaling.BUILDERS[physics](n, 1.0, 0.1, 1000.0)
        sim.run(50, chunk=50, threads=threads, on_events=drop_events)
        return sim, info

    sim, info = fresh(thread_counts[0])
    engine_runner = engine_simulation.chunk_runner(sim.spec, sim.law, sim.breakage, sim.fluid)
    parts, layout = L.chunk_parts(sim.spec, sim.law, sim.breakage, sim.fluid)
    clock = {}
    python_runner = L.ChunkRunner(*timed_parts(parts, sim.spec, layout, clock),
                                  engine_runner.collect, layout, engine_runner.rolling,
                                  engine_runner.periodic, engine_runner.near_walls,
                                  engine_runner.colour)
    engine_rebuild = L.rebuilt_contacts
    timed_rebuild(clock)
    passes_rebuild = L.rebuilt_contacts
    timed_scratch(clock)
    _warm_rebuild_front(sim)
    rows = []
    for row_index, threads in enumerate(thread_counts):
        L.rebuilt_contacts = engine_rebuild  # the engine's own rebuild for the build and its loop
        if row_index:
            sim, info = fresh(threads)
        numba.set_num_threads(threads)
        sim.run(20, chunk=20, threads=threads, on_events=drop_events)
        w0, k0, u0, load0 = sim.wall_seconds, int(sim.counters[0]), usage(), os.getloadavg()
        rebuild_s[0] = 0.0
        sim.run(steps, chunk=steps, threads=threads, on_events=drop_events)
        u1 = usage()
        loop_s, rebuilds, loop_rebuild_s = sim.wall_seconds - w0, int(sim.counters[0]) - k0, \
            rebuild_s[0]
        # the same number of steps, each pass called from Python
        L.rebuilt_contacts = passes_rebuild
        swap = _swap_runner(engine_simulation, sim, python_runner)
        try:
            sim.run(5, chunk=5, threads=threads, on_events=drop_events)  # compile the wrappers
            clock.clear()
            w1 = sim.wall_seconds
            sim.run(steps, chunk=steps, threads=threads, on_events=drop_events)
            passes_s = sim.wall_seconds - w1
        finally:
            swap()
        row = dict(physics=physics, n_particles=sim.n_particles, threads=threads, steps=steps,
                   loop_s=loop_s, particle_steps_per_s=sim.n_particles * steps / loop_s,
                   list_rebuilds=rebuilds, rebuild_s=loop_rebuild_s,
                   minor_faults=u1[0] - u0[0], voluntary_switches=u1[1] - u0[1],
                   involuntary_switches=u1[2] - u0[2], passes_s=passes_s,
                   passes={k: v for k, v in clock.items()}, loadavg=[load0, os.getloadavg()],
                   threading_layer=numba.threading_layer(), **info)
        rows.append(row)
        print(json.dumps(row), flush=True)
    return rows


def _swap_runner(engine_simulation, sim, runner):
    """Make ``sim`` use ``runner`` until the returned undo is called."""
    original = engine_simulation.chunk_runner
    engine_simulation.chunk_runner = lambda *args: runner

    def undo():
        engine_simulation.chunk_runner = original

    return undo


def table(rows):
    lines = []
    for physics in dict.fromkeys(r["physics"] for r in rows):
        mine = [r for r in rows if r["physics"] == physics]
        one = mine[0]
        names = sorted({k for r in mine for k in r["passes"] if k != "rebuild: count"},
                       key=lambda k: -one["passes"].get(k, 0.0))
        lines.append(f"\n{physics} ({one['n_particles']} particles, {one['steps']} steps)")
        head = f"{'':44s}" + "".join(f"{r['threads']:>10d}T" for r in mine)
        lines.append(head)
        lines.append(f"{'loop (engine) [s]':44s}" + "".join(f"{r['loop_s']:11.3f}" for r in mine))
        lines.append(f"{'  speed-up':44s}" + "".join(
            f"{one['loop_s'] / r['loop_s']:11.2f}" for r in mine))
        lines.append(f"{'  of which rebuilds [s]':44s}" + "".join(
            f"{r['rebuild_s']:11.3f}" for r in mine))
        lines.append(f"{'  minor page faults':44s}" + "".join(
            f"{r['minor_faults']:11d}" for r in mine))
        lines.append(f"{'passes from Python, sum [s]':44s}" + "".join(
            f"{r['passes_s']:11.3f}" for r in mine))
        for k in names:
            lines.append(f"{'  ' + k:44s}" + "".join(
                f"{r['passes'].get(k, 0.0):11.4f}" for r in mine))
            lines.append(f"{'    speed-up':44s}" + "".join(
                f"{one['passes'].get(k, 0.0) / max(r['passes'].get(k, 1e-12), 1e-12):11.2f}"
                for r in mine))
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--physics", nargs="+", default=list(scaling.PHYSICS),
                    choices=scaling.PHYSICS)
    ap.add_argument("--n", type=int, default=100000)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2, 4, 8, 16])
    ap.add_argument("--json", default=str(HERE / "out" / "pass_times.json"))
    args = ap.parse_args(argv)
    rows = []
    for physics in args.physics:
        rows += run_rows(physics, args.n, args.steps, args.threads)
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(dict(
        benchmark="pass_times", command="python bench/pass_times.py " + " ".join(
            sys.argv[1:] if argv is None else argv),
        cpu_count=os.cpu_count(), env={k: v for k, v in os.environ.items()
                                       if k.startswith(("OMP_", "GOMP_", "MALLOC_", "NUMBA_"))},
        rows=rows), indent=1))
    print(table(rows))


if __name__ == "__main__":
    main()
