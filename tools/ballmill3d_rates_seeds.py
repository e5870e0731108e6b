"""Breakage predicted from the stress log vs counted in the test mill of
tests/test_ballmill3d_rates.py, per seed (docs/ballmill3d.md).

    python tools/ballmill3d_rates_seeds.py 1 2 3

Also the prediction of the same logged sequences without damage (gamma -> inf), to show how much
damage decides there.
"""

import dataclasses
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import test_ballmill3d_rates as mill  # noqa: E402  (the test's mill and weak-ore edits)

from millsim.scenes import ballmill3d_rates as rates  # noqa: E402

WEAK_ORE_EDITS = (("young_GPa: 52 ", "young_GPa: 0.052 "), ("young_GPa: 210 ", "young_GPa: 0.21 "),
                  ("E_inf: {J_per_kg: 213.5}", "E_inf: {J_per_kg: 0.4}"),
                  ("gamma: 5.0 ", "gamma: 1.0 "))


def weak_materials_file():
    text = mill.MATERIALS.read_text()
    for old, new in WEAK_ORE_EDITS:
        text = text.replace(old, new)
    path = Path(tempfile.mkdtemp()) / "weak.yaml"
    path.write_text(text)
    return path


def main(seeds):
    weak = weak_materials_file()
    books = {}
    compare = rates.compare

    def keep_book(book, *args):
        books["last"] = book
        return compare(book, *args)

    rates.compare = keep_book
    total_predicted = total_counted = 0.0
    for seed in seeds:
        t0 = time.time()
        ds = mill._run(str(weak), stress_log=True, seed=seed)
        predicted = ds["breakage_events_predicted"].values.sum()
        counted = ds["breakage_events_counted"].values.sum()
        book = books["last"]
        book.mat = dataclasses.replace(book.mat, gamma=1e6)
        without_damage = sum(lam for _, lam in book.compensators())
        total_predicted += predicted
        total_counted += counted
        print(f"seed {seed}: predicted {predicted:.1f} counted {counted:.0f} "
              f"z {ds['breakage_prediction_z'].item():+.2f} "
              f"p {ds['breakage_prediction_p_value'].item():.3f} "
              f"(without damage {without_damage:.1f}) wall {time.time() - t0:.0f} s", flush=True)
    z = (total_counted - total_predicted) / np.sqrt(total_predicted)
    print(f"pooled: predicted {total_predicted:.1f} counted {total_counted:.0f} z {z:+.2f}")


if __name__ == "__main__":
    main([int(s) for s in sys.argv[1:]] or [1, 2, 3])
