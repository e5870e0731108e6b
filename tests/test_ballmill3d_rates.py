"""Scene ``ballmill3d`` with ``stress_log``: the breakage predicted from each ore particle's logged
stressing events by the Tavares model's probability (eqs 1-3) and damage (eqs 5-6) against the
breakage counted in the mill (issue 52 item 3; scenes/ballmill3d_rates.py, docs/ballmill3d.md).

The run is tests/test_ballmill3d.py's small mill (contacts 1000x softer, one 6 mm feed size that
may break, its progeny too small to) with a test ore whose damage dominates: E_inf = 0.4 J/kg and
gamma = 1 (copper ore has 5), so that most feed particles break within 0.45 revolution and most
of them only because earlier events weakened them (the same sequences without damage predict ~2 of
~160): a loop that did not damage, or damaged differently from eqs 5-6, is told apart from the
model, and the counted breakage is a sample large enough for its interval.
"""


import numpy as np
import pytest
from test_ballmill3d import MATERIALS, SCENE
from test_ballmill3d import SMALL as MILL

from millsim.scenes.base import RunContext

# test_ballmill3d's small mill with the analytic shell, measured from its start, breakage on
SMALL = dict(MILL, transient_revolutions=0.0, liner="", breakage=True, seed=1)


@pytest.fixture(scope="module")
def weak_ore(tmp_path_factory):
    text = MATERIALS.read_text()
    for stiff, soft in (("young_GPa: 52 ", "young_GPa: 0.052 "), ("young_GPa: 210 ", "young_GPa: 0.21 "),
                        ("E_inf: {J_per_kg: 213.5}", "E_inf: {J_per_kg: 0.4}"),
                        ("gamma: 5.0 ", "gamma: 1.0 ")):  # (copper ore's alone)
        assert stiff in text
        text = text.replace(stiff, soft)
    path = tmp_path_factory.mktemp("materials") / "weak.yaml"
    path.write_text(text)
    return str(path)


def _run(materials, **over):
    values = SCENE.resolve(dict(SMALL, materials_file=materials, **over))
    return SCENE.run(values, RunContext())[0]


@pytest.fixture(scope="module")
def logged(weak_ore):
    return _run(weak_ore, stress_log=True)


def test_breakage_predicted_from_the_stress_log_matches_the_counted(logged):
    """Counted breakage events minus the summed compensators of the logged sequences is a
    martingale of mean zero and variance the predicted count (ballmill3d_rates): the counted
    total lies within the predicted one's 99 % interval (two-sided p > 0.01), per class and in
    all. The classes below the feed hold progeny too small to break: 0 predicted, 0 counted."""
    predicted = logged["breakage_events_predicted"].values
    counted = logged["breakage_events_counted"].values
    assert counted.sum() == logged["breakage_events"].item() >= 50
    assert logged["breakage_prediction_p_value"].item() > 0.01
    z = (counted.sum() - predicted.sum()) / np.sqrt(predicted.sum())
    assert logged["breakage_prediction_z"].item() == pytest.approx(z, rel=1e-12)
    assert predicted[1:].sum() == 0 and counted[1:].sum() == 0
    assert abs(z) < 2.576


def test_the_log_leaves_the_mill_as_it_was(weak_ore, logged):
    """The log stops the loop more often (to drain it) and compiles a variant of its own, but a
    stop ends a chunk at a step boundary like any other: the same run without it breaks the same
    particles at the same times and draws the same power, bit for bit."""
    plain = _run(weak_ore, stress_log=False)
    assert "breakage_events_predicted" not in plain
    for name in ("breakage_events_series", "power_series", "kinetic_energy", "passing_fraction",
                 "breakage_rate"):
        np.testing.assert_array_equal(plain[name].values, logged[name].values, err_msg=name)
