"""Implicit lubrication against explicit over a short window from the same start, as dt shrinks.

    python bench/lubrication_convergence.py [--eta 1] [--ms 2] [--seed 1]

The quick stirred-mill slice (config/config.yaml's geometry, 2500 rpm, mu = 0.3) from its start
state: the agitator work and the audited lubrication dissipation after ``--ms`` simulated
milliseconds, with the explicit scheme at its automatic step (the reference) and the implicit
scheme at the dry step dt and at dt/2, dt/4, dt/8. Within a few milliseconds the runs start
identically and have not yet decorrelated, so the differences are the schemes' discretisation,
not the flow's chaos (the net power of bench/lubrication_schemes.py is averaged over revolutions
whose trajectories have decorrelated).
"""

import argparse

from millsim.scenes import stirred_mill as sm
from millsim.scenes.base import get_scene

QUICK = dict(scale=0.45, slice=True, initial_swirl=0.1, rpm=2500, friction=0.3)


def build(eta, seed, scheme, dt=0.0):
    values = get_scene("stirred_mill").resolve(dict(QUICK, eta=eta, seed=seed, dt=dt,
                                                    lubrication_scheme=scheme))
    return sm.build(values)[0]


def window(eta, ms, seed, scheme, dt=0.0):
    sim = build(eta, seed, scheme, dt)
    steps = int(round(ms * 1e-3 / sim.dt))
    sim.run(steps, chunk=steps, threads=1)
    audit = sim.energy_audit()
    return (sim.dt, steps, sm.drive_state(sim)[1],
            audit["lubrication_normal"] + audit["lubrication_tangential"])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--eta", type=float, default=1.0)
    ap.add_argument("--ms", type=float, default=2.0)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    dt_e, n_e, work_e, diss_e = window(args.eta, args.ms, args.seed, "explicit")
    print(f"explicit dt {dt_e:.3g} s, {n_e} steps: work {work_e:.5g} J, lubrication dissipation "
          f"{diss_e:.5g} J", flush=True)
    dry = build(args.eta, args.seed, "implicit").dt  # the implicit scheme's (contacts') step
    for k in (1, 2, 4, 8):
        dt, n, work, diss = window(args.eta, args.ms, args.seed, "implicit", dry / k)
        print(f"implicit dt {dt:.3g} s (dry/{k}), {n} steps: work {(work - work_e) / work_e:+.2%}, "
              f"lubrication dissipation {(diss - diss_e) / diss_e:+.2%} against explicit",
              flush=True)


if __name__ == "__main__":
    main()
