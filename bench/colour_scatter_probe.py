"""Probe: a deterministic direct scatter by colouring the contact graph (issue 13, item 2).

    python bench/colour_scatter_probe.py STATE.csv [--steps 2000] [--repeats 3] [--threads 1]
                                         [--json FILE]

Stand-alone, on the engine's own Hertz-Mindlin law, the engine's neighbour list and the box's
settled state (``bench/engine_throughput.py`` leaves it in ``<workdir>/millsim_box_state.csv``).
Ways to turn the half list's contacts into particle forces, each followed by the same
velocity-Verlet step with gravity (no walls: the few hundred microseconds timed barely move the
bed):

- ``records``: the engine's scheme. The pair pass writes a record per slot; the particle pass sums
  a particle's own records, then those where it is the partner, in a fixed order. The same
  numbers on any thread count.
- ``row_scatter``: LIGGGHTS' half-list scatter, rows in order, each contact added straight into
  both particles' sums. One thread only (two threads would race on the sums).
- ``colour_scatter``: the slots greedily edge-coloured at the list build so that no two slots of a
  colour share a particle, stored in colour order; each colour's slots run in parallel, adding
  straight into both particles' sums. Each particle's sum is taken in colour order whatever the
  thread count, and every thread count runs the same compiled function: the same numbers on any
  thread count, without the records.
- ``colour_index``: the same, the springs left in the list's slot order (reached through each
  place's slot index) instead of copied into colour order.
- ``colour_touching_first``: ``colour_scatter`` with the slots of each colour reordered, those
  touching at the start first, so that the branch between touching and apart slots is taken the
  same way for long runs (the slots of a colour share no particle: the sums are unchanged).
- ``colour_packed``: ``colour_scatter`` with each particle's data (position, velocity, spin,
  radius, inverse mass and inertia) in one 128-byte row and its force and torque sums in one
  64-byte row, both aligned to cache lines: three lines per particle of a contact, where the
  separate arrays touch up to nine.

Variants alternate within each repeat; compile time excluded. Prints particle-steps/s per variant
(median of the repeats), the colouring's size, and how far the variants' states are apart after
the timed steps (rounding: the sums are taken in other orders). Not part of the engine.
"""

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

import numba
import numpy as np
from numba import njit, prange

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from millsim.engine.jit_options import FAST, PRANGE_ONLY  # noqa: E402
from millsim.scenes import packing  # noqa: E402
from millsim.scenes.base import get_scene  # noqa: E402

G = -9.81


def build_case(state_csv):
    values = get_scene("packing").resolve({"container": "box", "init_file": state_csv, "dt": 1e-6,
                                           "skin": 2e-4, "convention": "unclipped",
                                           "spinup_steps": 0})
    sim = packing.build(values)
    sim.set_time_step(values["dt"])
    sim.run(10, chunk=10)  # builds the neighbour list and the springs
    return sim


@njit(cache=True)
def colour_slots(start, nbr, n):
    """Greedy edge colouring of the half list in row order; returns each slot's colour."""
    used = np.zeros(n, np.uint64)
    colour = np.empty(nbr.shape[0], np.int64)
    for i in range(n):
        for k in range(start[i], start[i + 1]):
            j = nbr[k]
            taken = used[i] | used[j]
            c = 0
            while (taken >> np.uint64(c)) & np.uint64(1):
                c += 1
            if c >= 64:
                raise ValueError("more than 64 colours")
            colour[k] = c
            used[i] |= np.uint64(1) << np.uint64(c)
            used[j] |= np.uint64(1) << np.uint64(c)
    return colour


def make_kernels(force, clip):
    @njit(inline="always", fastmath=FAST)
    def pair(i, j, k, x, v, w, radius, inv_mass, pp, state, dt):
        d0 = x[i, 0] - x[j, 0]
        d1 = x[i, 1] - x[j, 1]
        d2 = x[i, 2] - x[j, 2]
        rsum = radius[i] + radius[j]
        dist2 = d0 * d0 + d1 * d1 + d2 * d2
        if dist2 >= rsum * rsum:
            state[k, 0] = 0.0
            state[k, 1] = 0.0
            state[k, 2] = 0.0
            return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        dist = math.sqrt(dist2)
        inv = 1.0 / dist
        n0, n1, n2 = d0 * inv, d1 * inv, d2 * inv
        xi = rsum - dist
        ri, rj = radius[i], radius[j]
        ai = ri - 0.5 * xi
        aj = rj - 0.5 * xi
        s0 = ai * w[i, 0] + aj * w[j, 0]
        s1 = ai * w[i, 1] + aj * w[j, 1]
        s2 = ai * w[i, 2] + aj * w[j, 2]
        vr0 = v[i, 0] - v[j, 0] - (s1 * n2 - s2 * n1)
        vr1 = v[i, 1] - v[j, 1] - (s2 * n0 - s0 * n2)
        vr2 = v[i, 2] - v[j, 2] - (s0 * n1 - s1 * n0)
        m_eff = 1.0 / (inv_mass[i] + inv_mass[j])
        fn, f0, f1, f2, fn_el = force(pp, xi, n0, n1, n2, vr0, vr1, vr2, m_eff, ri * rj / rsum,
                                      clip, state, k, dt)
        return (True, fn * n0 + f0, fn * n1 + f1, fn * n2 + f2, n1 * f2 - n2 * f1,
                n2 * f0 - n0 * f2, n0 * f1 - n1 * f0, xi)

    @njit(inline="always", fastmath=FAST)
    def integrate(i, dt, x, v, w, inv_mass, inv_inertia, F0, F1, F2, T0, T1, T2):
        # kick with this step's forces, then drift (semi-implicit Euler: the same in all variants)
        v[i, 0] += dt * F0 * inv_mass[i]
        v[i, 1] += dt * F1 * inv_mass[i]
        v[i, 2] += dt * (F2 * inv_mass[i] + G)
        w[i, 0] += dt * T0 * inv_inertia[i]
        w[i, 1] += dt * T1 * inv_inertia[i]
        w[i, 2] += dt * T2 * inv_inertia[i]
        x[i, 0] += dt * v[i, 0]
        x[i, 1] += dt * v[i, 1]
        x[i, 2] += dt * v[i, 2]

    @njit(parallel=PRANGE_ONLY, fastmath=FAST)
    def records(steps, dt, x, v, w, radius, inv_mass, inv_inertia, pp, start, nbr, state,
                rev_start, rev_slot, out, rows):
        n = x.shape[0]
        n_rows = rows.shape[0] - 1
        for _ in range(steps):
            for b in prange(n_rows):
                for i in range(rows[b], rows[b + 1]):
                    for k in range(start[i], start[i + 1]):
                        o = out[k]
                        c, o[0], o[1], o[2], o[3], o[4], o[5], o[6] = pair(
                            i, nbr[k], k, x, v, w, radius, inv_mass, pp, state, dt)
            for b in prange((n + 255) // 256):
                for i in range(b * 256, min(n, (b + 1) * 256)):
                    F0 = F1 = F2 = C0 = C1 = C2 = 0.0
                    ri = radius[i]
                    for k in range(start[i], start[i + 1]):
                        o = out[k]
                        F0 += o[0]
                        F1 += o[1]
                        F2 += o[2]
                        arm = ri - 0.5 * o[6]
                        C0 += arm * o[3]
                        C1 += arm * o[4]
                        C2 += arm * o[5]
                    for q in range(rev_start[i], rev_start[i + 1]):
                        o = out[rev_slot[q]]
                        F0 -= o[0]
                        F1 -= o[1]
                        F2 -= o[2]
                        arm = ri - 0.5 * o[6]
                        C0 += arm * o[3]
                        C1 += arm * o[4]
                        C2 += arm * o[5]
                    integrate(i, dt, x, v, w, inv_mass, inv_inertia, F0, F1, F2, -C0, -C1, -C2)

    @njit(inline="always", fastmath=FAST)
    def scatter(i, j, k, x, v, w, radius, inv_mass, pp, state, dt, F, T):
        touch, g0, g1, g2, c0, c1, c2, xi = pair(i, j, k, x, v, w, radius, inv_mass, pp, state, dt)
        if touch:
            F[i, 0] += g0
            F[i, 1] += g1
            F[i, 2] += g2
            F[j, 0] -= g0
            F[j, 1] -= g1
            F[j, 2] -= g2
            ai = radius[i] - 0.5 * xi
            aj = radius[j] - 0.5 * xi
            T[i, 0] -= ai * c0
            T[i, 1] -= ai * c1
            T[i, 2] -= ai * c2
            T[j, 0] -= aj * c0
            T[j, 1] -= aj * c1
            T[j, 2] -= aj * c2

    @njit(inline="always", fastmath=FAST)
    def finish_block(b, dt, x, v, w, inv_mass, inv_inertia, F, T):
        for i in range(b * 256, min(x.shape[0], (b + 1) * 256)):
            integrate(i, dt, x, v, w, inv_mass, inv_inertia, F[i, 0], F[i, 1], F[i, 2], T[i, 0],
                      T[i, 1], T[i, 2])
            F[i, 0] = F[i, 1] = F[i, 2] = 0.0
            T[i, 0] = T[i, 1] = T[i, 2] = 0.0

    @njit(fastmath=FAST)
    def row_scatter(steps, dt, x, v, w, radius, inv_mass, inv_inertia, pp, start, nbr, state, F,
                    T):
        n = x.shape[0]
        for _ in range(steps):
            for i in range(n):
                # i's sums in registers over its row, as LIGGGHTS keeps them
                G0 = G1 = G2 = U0 = U1 = U2 = 0.0
                for k in range(start[i], start[i + 1]):
                    j = nbr[k]
                    touch, g0, g1, g2, c0, c1, c2, xi = pair(i, j, k, x, v, w, radius, inv_mass,
                                                             pp, state, dt)
                    if touch:
                        G0 += g0
                        G1 += g1
                        G2 += g2
                        F[j, 0] -= g0
                        F[j, 1] -= g1
                        F[j, 2] -= g2
                        ai = radius[i] - 0.5 * xi
                        aj = radius[j] - 0.5 * xi
                        U0 -= ai * c0
                        U1 -= ai * c1
                        U2 -= ai * c2
                        T[j, 0] -= aj * c0
                        T[j, 1] -= aj * c1
                        T[j, 2] -= aj * c2
                F[i, 0] += G0
                F[i, 1] += G1
                F[i, 2] += G2
                T[i, 0] += U0
                T[i, 1] += U1
                T[i, 2] += U2
            for b in range((n + 255) // 256):
                finish_block(b, dt, x, v, w, inv_mass, inv_inertia, F, T)

    @njit(parallel=PRANGE_ONLY, fastmath=FAST)
    def colour_scatter(steps, dt, x, v, w, radius, inv_mass, inv_inertia, pp, ci, cj, cstart,
                       state, F, T):
        n = x.shape[0]
        chunk = 256
        for _ in range(steps):
            for c in range(cstart.shape[0] - 1):
                lo, hi = cstart[c], cstart[c + 1]
                for b in prange((hi - lo + chunk - 1) // chunk):
                    for k in range(lo + b * chunk, min(hi, lo + (b + 1) * chunk)):
                        scatter(ci[k], cj[k], k, x, v, w, radius, inv_mass, pp, state, dt, F, T)
            for b in prange((n + 255) // 256):
                finish_block(b, dt, x, v, w, inv_mass, inv_inertia, F, T)

    @njit(parallel=PRANGE_ONLY, fastmath=FAST)
    def colour_index(steps, dt, x, v, w, radius, inv_mass, inv_inertia, pp, ci, cj, cslot,
                     cstart, state, F, T):
        # as colour_scatter, the springs left in row order (reached through the slot's index)
        n = x.shape[0]
        chunk = 256
        for _ in range(steps):
            for c in range(cstart.shape[0] - 1):
                lo, hi = cstart[c], cstart[c + 1]
                for b in prange((hi - lo + chunk - 1) // chunk):
                    for q in range(lo + b * chunk, min(hi, lo + (b + 1) * chunk)):
                        scatter(ci[q], cj[q], cslot[q], x, v, w, radius, inv_mass, pp, state, dt,
                                F, T)
            for b in prange((n + 255) // 256):
                finish_block(b, dt, x, v, w, inv_mass, inv_inertia, F, T)

    @njit(inline="always", fastmath=FAST)
    def packed_scatter(i, j, k, H, pp, state, dt, FT):
        # H[i]: x 0-2, v 3-5, w 6-8, radius 9, 1/mass 10, 1/inertia 11 (128 bytes, line aligned)
        d0 = H[i, 0] - H[j, 0]
        d1 = H[i, 1] - H[j, 1]
        d2 = H[i, 2] - H[j, 2]
        rsum = H[i, 9] + H[j, 9]
        dist2 = d0 * d0 + d1 * d1 + d2 * d2
        if dist2 >= rsum * rsum:
            state[k, 0] = 0.0
            state[k, 1] = 0.0
            state[k, 2] = 0.0
            return
        dist = math.sqrt(dist2)
        inv = 1.0 / dist
        n0, n1, n2 = d0 * inv, d1 * inv, d2 * inv
        xi = rsum - dist
        ri, rj = H[i, 9], H[j, 9]
        ai = ri - 0.5 * xi
        aj = rj - 0.5 * xi
        s0 = ai * H[i, 6] + aj * H[j, 6]
        s1 = ai * H[i, 7] + aj * H[j, 7]
        s2 = ai * H[i, 8] + aj * H[j, 8]
        vr0 = H[i, 3] - H[j, 3] - (s1 * n2 - s2 * n1)
        vr1 = H[i, 4] - H[j, 4] - (s2 * n0 - s0 * n2)
        vr2 = H[i, 5] - H[j, 5] - (s0 * n1 - s1 * n0)
        m_eff = 1.0 / (H[i, 10] + H[j, 10])
        fn, f0, f1, f2, fn_el = force(pp, xi, n0, n1, n2, vr0, vr1, vr2, m_eff, ri * rj / rsum,
                                      clip, state, k, dt)
        g0 = fn * n0 + f0
        g1 = fn * n1 + f1
        g2 = fn * n2 + f2
        c0 = n1 * f2 - n2 * f1
        c1 = n2 * f0 - n0 * f2
        c2 = n0 * f1 - n1 * f0
        FT[i, 0] += g0
        FT[i, 1] += g1
        FT[i, 2] += g2
        FT[j, 0] -= g0
        FT[j, 1] -= g1
        FT[j, 2] -= g2
        FT[i, 3] -= ai * c0
        FT[i, 4] -= ai * c1
        FT[i, 5] -= ai * c2
        FT[j, 3] -= aj * c0
        FT[j, 4] -= aj * c1
        FT[j, 5] -= aj * c2

    @njit(parallel=PRANGE_ONLY, fastmath=FAST)
    def colour_packed(steps, dt, H, pp, ci, cj, cstart, state, FT):
        # colour_scatter with each particle's data in one 128-byte row and its sums in one
        # 64-byte row: two cache lines to read and one to write per particle of a contact
        n = H.shape[0]
        chunk = 256
        for _ in range(steps):
            for c in range(cstart.shape[0] - 1):
                lo, hi = cstart[c], cstart[c + 1]
                for b in prange((hi - lo + chunk - 1) // chunk):
                    for k in range(lo + b * chunk, min(hi, lo + (b + 1) * chunk)):
                        packed_scatter(ci[k], cj[k], k, H, pp, state, dt, FT)
            for b in prange((n + 255) // 256):
                for i in range(b * 256, min(n, (b + 1) * 256)):
                    H[i, 3] += dt * FT[i, 0] * H[i, 10]
                    H[i, 4] += dt * FT[i, 1] * H[i, 10]
                    H[i, 5] += dt * (FT[i, 2] * H[i, 10] + G)
                    H[i, 6] += dt * FT[i, 3] * H[i, 11]
                    H[i, 7] += dt * FT[i, 4] * H[i, 11]
                    H[i, 8] += dt * FT[i, 5] * H[i, 11]
                    H[i, 0] += dt * H[i, 3]
                    H[i, 1] += dt * H[i, 4]
                    H[i, 2] += dt * H[i, 5]
                    for a in range(6):
                        FT[i, a] = 0.0

    return records, row_scatter, colour_scatter, colour_index, colour_packed


def aligned_rows(n, width):
    """An (n, width) float64 array whose rows start on 64-byte boundaries (width a multiple of 8)."""
    raw = np.zeros(n * width + 8)
    skip = (-raw.ctypes.data % 64) // 8
    return raw[skip:skip + n * width].reshape(n, width)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("state_csv")
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--json")
    args = ap.parse_args()

    sim = build_case(args.state_csv)
    P, C = sim.particles, sim.contacts
    n = P.x.shape[0]
    if len(np.unique(P.material)) != 1:
        raise SystemExit("the probe takes one material")
    pp = np.ascontiguousarray(sim.pair_params[0, 0])
    records, row_scatter, colour_scatter, colour_index, colour_packed = make_kernels(
        sim.law.force, sim.spec.clip_normal)
    start, nbr = C.start, C.nbr
    state0 = np.ascontiguousarray(C.state[:, :3])
    colour = colour_slots(start, nbr, n)
    order = np.lexsort((np.arange(len(nbr)), colour))  # colour, then the slot's place (row order)
    owner = np.repeat(np.arange(n), np.diff(start))
    ci, cj = owner[order].astype(np.int64), nbr[order].astype(np.int64)
    # colour_touching_first: within each colour the slots touching at the start first (a colour's
    # slots share no particle, so their order within it changes no sum)
    apart = np.sum((P.x[owner] - P.x[nbr]) ** 2, axis=1) >= (P.radius[owner] + P.radius[nbr]) ** 2
    order_t = np.lexsort((np.arange(len(nbr)), apart, colour))
    ci_t, cj_t = owner[order_t].astype(np.int64), nbr[order_t].astype(np.int64)
    cstart = np.searchsorted(colour[order], np.arange(colour.max() + 2)).astype(np.int64)
    n_threads = args.threads
    counts = np.diff(start)
    cum = np.concatenate([[0], np.cumsum(counts)])
    n_rows = max(1, (n + 255) // 256)
    rows = np.searchsorted(cum, np.linspace(0, cum[-1], n_rows + 1)).astype(np.int64)
    rows[0], rows[-1] = 0, n

    def fresh():
        return (P.x.copy(), P.v.copy(), P.w.copy())

    def run(name, steps):
        x, v, w = fresh()
        F, T = np.zeros((n, 3)), np.zeros((n, 3))
        if name == "records":
            st = state0.copy()
            out = np.zeros((len(nbr), 8))
            args_ = (steps, sim.dt, x, v, w, P.radius, P.inv_mass, P.inv_inertia, pp, start, nbr,
                     st, C.rev_start, C.rev_slot, out, rows)
            fn = records
        elif name == "row_scatter":
            st = state0.copy()
            args_ = (steps, sim.dt, x, v, w, P.radius, P.inv_mass, P.inv_inertia, pp, start, nbr,
                     st, F, T)
            fn = row_scatter
        elif name == "colour_index":
            st = state0.copy()
            args_ = (steps, sim.dt, x, v, w, P.radius, P.inv_mass, P.inv_inertia, pp, ci, cj,
                     order.astype(np.int64), cstart, st, F, T)
            fn = colour_index
        elif name == "colour_touching_first":
            st = state0[order_t].copy()
            args_ = (steps, sim.dt, x, v, w, P.radius, P.inv_mass, P.inv_inertia, pp, ci_t, cj_t,
                     cstart, st, F, T)
            fn = colour_scatter
        elif name == "colour_packed":
            st = state0[order].copy()
            H = aligned_rows(n, 16)
            H[:, 0:3], H[:, 3:6], H[:, 6:9] = x, v, w
            H[:, 9], H[:, 10], H[:, 11] = P.radius, P.inv_mass, P.inv_inertia
            args_ = (steps, sim.dt, H, pp, ci, cj, cstart, st, aligned_rows(n, 8))
            fn = colour_packed
        else:
            st = state0[order].copy()
            args_ = (steps, sim.dt, x, v, w, P.radius, P.inv_mass, P.inv_inertia, pp, ci, cj,
                     cstart, st, F, T)
            fn = colour_scatter
        t0 = time.perf_counter()
        fn(*args_)
        if name == "colour_packed":
            H = args_[2]
            x, v, w = H[:, 0:3].copy(), H[:, 3:6].copy(), H[:, 6:9].copy()
        return time.perf_counter() - t0, (x, v, w)

    numba.set_num_threads(n_threads)
    names = ["records", "colour_scatter", "colour_touching_first", "colour_index",
             "colour_packed"] + (
        ["row_scatter"] if n_threads == 1 else [])
    for name in names:
        run(name, 2)  # compile
    rates = {name: [] for name in names}
    finals = {}
    for _ in range(args.repeats):
        for name in names:
            s, finals[name] = run(name, args.steps)
            rates[name].append(n * args.steps / s)
    numba.set_num_threads(2 if numba.config.NUMBA_NUM_THREADS >= 2 else 1)
    _, other_threads = run("colour_scatter", args.steps)
    numba.set_num_threads(n_threads)
    touching = int(np.sum(C.state[:, :3].any(axis=1)))
    result = {
        "n": n, "slots": int(len(nbr)), "slots_per_particle": len(nbr) / n,
        "touching_slots_at_start": touching, "colours": int(colour.max() + 1),
        "slots_per_colour": [int(c) for c in np.diff(cstart)], "threads": n_threads,
        "steps": args.steps, "rates": rates,
        "median": {k: statistics.median(r) for k, r in rates.items()},
        "colour_scatter_same_on_2_threads": all(
            np.array_equal(a, b) for a, b in zip(finals["colour_scatter"], other_threads)),
        "max_abs_diff_vs_records": {
            k: [float(np.max(np.abs(a - b))) for a, b in zip(finals[k], finals["records"])]
            for k in names if k != "records"},
    }
    med = result["median"]
    for k in names:
        print(f"{k:15s} {med[k]:.3e} particle-steps/s  ({med[k] / med['records']:.3f} x records)  "
              f"runs {', '.join(f'{r:.3e}' for r in rates[k])}")
    print(f"colours {result['colours']}, slots per particle {result['slots_per_particle']:.2f}; "
          f"colour scatter same on 1 and 2 threads: {result['colour_scatter_same_on_2_threads']}; "
          f"|x, v, w| apart from records: {result['max_abs_diff_vs_records']}")
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
