"""The agitator power recorded so far by a stirred-mill case that has not finished, read from its
checkpoint (a long full-LS1 run stopped for lack of time keeps what its last checkpoint holds).

    python bench/ls1_checkpoint_series.py CASE.nc.ckpt [--window-from REV] [--json FILE]

Prints the step and revolution the checkpoint was taken at and the mean agitator power of each
half revolution recorded (bench/ls1_study.py's revolution means, halved; the last half may be
incomplete); with ``--window-from REV`` also the mean over the records from that revolution on
with its 95 % interval (8 block means, as the case file's) and the window's drift
(bench/ls1_study.py's). Only the code that wrote the checkpoint reads it (millsim.io refuses
other code): run it from that tree, e.g. ``PYTHONPATH=<that tree>/src python
bench/ls1_checkpoint_series.py ...``.
"""

import argparse
import json
import pickle
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ls1_study import revolution_means, window_stats  # noqa: E402


def checkpoint_state(path):
    """(case, steps so far, run parameters) from a checkpoint written by this code: its own key
    stands in for the run's (a stopped run's reader has no config), so millsim.io's
    read_checkpoint compares only the software and engine hash with this process's."""
    from millsim.io import read_checkpoint

    with open(path, "rb") as fh:
        key = pickle.load(fh)
    try:
        saved = read_checkpoint(path, key)
    except ValueError as exc:
        raise SystemExit(f"{path}: {exc}") from None
    return saved["case"], saved["steps_total"], key.get("parameters", {})


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("checkpoint")
    ap.add_argument("--window-from", type=float, metavar="REV",
                    help="also the mean power and its drift from this revolution on")
    ap.add_argument("--json")
    args = ap.parse_args()
    case, steps, params = checkpoint_state(args.checkpoint)
    power = np.asarray(case.recorded("agitator_power"))
    time = np.asarray(case.recorded_times())
    rpm = float(params["rpm"])
    revolutions = time * rpm / 60.0
    means = revolution_means(time, power, rpm, parts=2, partial=True)
    out = dict(checkpoint=args.checkpoint, steps=int(steps), time_s=float(case.sim.time),
               revolutions=float(case.sim.time * rpm / 60.0), records=int(len(power)),
               eta=float(params["eta"]), rpm=rpm, half_revolution_mean_power_w=means,
               last_half_complete=bool(revolutions[-1] * 2.0 >= len(means)))
    if args.window_from is not None:
        mean, half_width, change, change_ci = window_stats(time, power,
                                                           args.window_from * 60.0 / rpm)
        out["window"] = dict(from_revolution=args.window_from, mean_power_w=mean,
                             mean_power_ci_w=half_width, drift_w=change, drift_ci_w=change_ci)
    print(json.dumps(out, indent=1))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
