"""Does a scene's trajectory depend on how its steps are cut into chunks? (found 2026-11-27)

Runs the quick stirred-mill slice (dry, 2500 rpm) for STEPS steps twice, in chunks of A and of
B steps, one thread, and prints whether positions, velocities and spins are bit-identical and
their largest differences. The engine's own contract test (tests/test_engine_contract.py,
a wall-bounded pile) is chunk-independent; a scene with a moving body is not. Likely cause (not
verified by a fix): the simulation time is accumulated per chunk (t += n dt) and the body pose
is taken at t + k dt, so the time of one step differs in its last bit between chunkings.

    python bench/chunking_check.py [--steps 600 --a 600 --b 50]
"""
import argparse

import numpy as np

from millsim.scenes.base import get_scene
from millsim.scenes.stirred_mill import build


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--a", type=int, default=600)
    ap.add_argument("--b", type=int, default=50)
    args = ap.parse_args(argv)
    values = get_scene("stirred_mill").resolve({"eta": 0.0, "scale": 0.45, "slice": True,
                                                "initial_swirl": 0.1, "rpm": 2500})
    states = []
    for chunk in (args.a, args.b):
        sim = build(values)[0]
        sim.run(args.steps, chunk=chunk, threads=1)
        p = sim.particles
        states.append((p.x.copy(), p.v.copy(), p.w.copy(), sim.time))
    for name, a, b in zip(("x", "v", "w"), *states):
        print(f"{name}: identical {np.array_equal(a, b)}, largest difference {np.abs(a - b).max():.3g}")
    print(f"time after {args.steps} steps: {states[0][3]!r} (chunks of {args.a}), "
          f"{states[1][3]!r} (chunks of {args.b})")


if __name__ == "__main__":
    main()
