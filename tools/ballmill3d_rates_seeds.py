"""Breakage predicted from the stress log vs counted in the test mill of
tests/test_ballmill3d_rates.py, per seed (docs/ballmill3d.md): python tools/ballmill3d_rates_seeds.py 1 2 3

Also the prediction of the same logged sequences without damage (gamma -> inf), to show how much
damage decides there."""
import dataclasses
import sys
import tempfile
import time
from pathlib import Path
import numpy as np
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import test_ballmill3d_rates as T
from millsim.scenes import ballmill3d_rates as rates
WEAK = Path(tempfile.mkdtemp()) / "weak.yaml"
text = T.MATERIALS.read_text()
for a, b in (("young_GPa: 52 ", "young_GPa: 0.052 "), ("young_GPa: 210 ", "young_GPa: 0.21 "),
             ("E_inf: {J_per_kg: 213.5}", "E_inf: {J_per_kg: 0.4}"), ("gamma: 5.0 ", "gamma: 1.0 ")):
    text = text.replace(a, b)
WEAK.write_text(text)
store = {}
orig = rates.compare
def spy(book, *a):
    store["book"] = book
    return orig(book, *a)
rates.compare = spy
tot_p = tot_c = 0.0
for seed in [int(s) for s in sys.argv[1:]] or (1, 2, 3):
    t0 = time.time()
    ds = T._run(str(WEAK), stress_log=True, seed=seed)
    p = ds["breakage_events_predicted"].values.sum(); c = ds["breakage_events_counted"].values.sum()
    book = store["book"]
    book.mat = dataclasses.replace(book.mat, gamma=1e6)
    nodmg = sum(l for _, l in book.compensators())
    tot_p += p; tot_c += c
    print(f"seed {seed}: predicted {p:.1f} counted {c:.0f} z {ds['breakage_prediction_z'].item():+.2f} "
          f"p {ds['breakage_prediction_p_value'].item():.3f} (without damage {nodmg:.1f}) "
          f"wall {time.time()-t0:.0f} s", flush=True)
print(f"pooled: predicted {tot_p:.1f} counted {tot_c:.0f} z {(tot_c-tot_p)/np.sqrt(tot_p):+.2f}")
