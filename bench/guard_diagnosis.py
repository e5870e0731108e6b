"""Why a case stopped on a guard: rerun it from its checkpoint (``millsim run ... --out X.nc``
leaves ``X.nc.ckpt``) to the failing step, then list the largest overlaps with the partners'
kind (free particle or body sphere), positions and speeds, so that a pinch by a kinematic body
can be told from a head-on impact or a step too large.

    python bench/guard_diagnosis.py X.nc.ckpt [--top 12]

The checkpoint must come from the same code (it is a pickle of the running case); another is
refused with the difference named. The chunk loop is the driver's (scenes/driver.py ``drive``),
without its recording and saving, so that the state at the stop stays at hand.
"""

import argparse
import pickle

import numpy as np


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("checkpoint")
    ap.add_argument("--top", type=int, default=12)
    args = ap.parse_args(argv)
    from millsim.engine import SimulationError
    from millsim.io import read_checkpoint

    with open(args.checkpoint, "rb") as fh:
        header = pickle.load(fh)
    # the reader refuses a checkpoint of other code; scene and parameters are the file's own
    key = {"scene": header["scene"], "parameters": header["parameters"]}
    case = read_checkpoint(args.checkpoint, key)["case"]
    sim = case.sim
    print(f"resumed at step {sim.step} (t = {sim.time:.6g} s)")
    try:
        while not case.done():
            n = case.chunk()
            sim.run(n, chunk=n)
            case.after_chunk()
        print("ran to the end without a guard")
    except SimulationError as exc:
        print(f"stopped: {exc}")
    p, free = sim.particles, sim.free
    pi, pj, overlap = sim.contact_pairs()
    relative = overlap / np.minimum(p.radius[pi], p.radius[pj])
    kind = np.where(free, "free", "body")
    for k in np.argsort(relative)[::-1][:args.top]:
        a, b = pi[k], pj[k]
        print(f"{a:>7} ({kind[a]}) - {b:>7} ({kind[b]}): overlap {relative[k]:.3f} r; "
              f"x_a {np.array2string(p.x[a], precision=4)}, |v| {np.linalg.norm(p.v[a]):.3g} / "
              f"{np.linalg.norm(p.v[b]):.3g} m/s")
    print(f"{len(relative)} contacts: {int((relative > 0.5).sum())} above 0.5 r, "
          f"{int((relative > 0.3).sum())} above 0.3 r")


if __name__ == "__main__":
    main()
