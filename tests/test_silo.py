"""Scene ``silo``: a poured, settled charge discharged through the orifice of a flat bottom.

What can be checked exactly on a small silo (Beverloo's correlation needs a larger one; the
comparison is in docs/results/silo.md): no sphere is lost or created (every poured sphere is
either discharged or still in the silo), nothing leaves before the gate opens, the discharge is
monotone and steady enough to fit, and impossible geometries are refused with one line.
"""

import math

import numpy as np
import pytest

from millsim.scenes import load_all
from millsim.scenes.base import get_scene

SMALL = dict(n=300, silo_radius=0.009, orifice_diameter=0.010, pour_height=0.025,
             settle_time=0.15, discharge_time=0.2)


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    load_all()
    scene = get_scene("silo")
    ds, _ = scene.run(scene.resolve(SMALL))
    return ds


def test_every_poured_sphere_is_discharged_or_still_in_the_silo(case):
    ds, n = case, SMALL["n"]
    mass = 2500.0 * 4.0 / 3.0 * math.pi * 1e-3**3
    discharged = float(ds.discharged_mass[-1])
    assert discharged / mass == pytest.approx(round(discharged / mass), abs=1e-9)
    assert round(discharged / mass) + int(ds.particles_left) == n
    assert float(ds.discharged_fraction) == pytest.approx(discharged / (n * mass), rel=1e-12)


def test_discharge_starts_at_the_opening_and_only_grows(case):
    m = case.discharged_mass.values
    assert m[0] == 0.0
    assert (m[1:] >= m[:-1]).all()
    assert float(case.discharged_fraction) > 0.3  # it flows
    assert float(case.flow_rate_ci_lo) > 0.0
    assert int(case.steady_records) >= 3


@pytest.mark.parametrize("override,message", [
    (dict(orifice_diameter=0.02), "orifice_diameter: must be below the silo diameter"),
    (dict(orifice_diameter=0.0015), "orifice_diameter: 0.0015 m does not pass a sphere"),
    (dict(pour_height=0.004), "pour_height: must exceed 6 radii"),
])
def test_impossible_silos_refused(override, message):
    load_all()
    with pytest.raises(ValueError, match=message):
        get_scene("silo").resolve(dict(SMALL, **override))


def test_the_narrowest_and_widest_possible_orifices_are_accepted():
    """The limits are geometric: an orifice a hair wider than a sphere passes it, one a hair
    narrower than the silo is still a silo (issue 47, seed 56 `silo:63`: refusing below 3 radii
    instead of 2 passed every test, whose refused orifice was below both)."""
    load_all()
    scene = get_scene("silo")
    r = scene.resolve(dict(SMALL))["radius"]
    for d in (2.0 * r * (1 + 1e-6), 2.0 * SMALL["silo_radius"] * (1 - 1e-6)):
        assert scene.resolve(dict(SMALL, orifice_diameter=d))["orifice_diameter"] == d


def test_a_pour_height_a_hair_above_six_radii_is_accepted():
    """6 radii is the stated limit (the refusal's message), so 6 (1 + 1e-6) radii is accepted
    (issue 47, seed 57 `silo:66`: refusing below 9 radii passed the refusal test, whose height
    was below both)."""
    load_all()
    scene = get_scene("silo")
    h = 6.0 * scene.resolve(dict(SMALL))["radius"] * (1 + 1e-6)
    assert scene.resolve(dict(SMALL, pour_height=h))["pour_height"] == h


def test_the_silo_plans_its_step_and_guard_for_twice_the_fall_from_the_pour():
    """A grain let go at the pour's top lands at sqrt(2 g h); the scene plans the step (the
    Hertz contact time at the impact speed) and the speed guard (ten times that) for twice the
    fall's speed."""
    from millsim.scenes.silo import SiloCase

    load_all()
    case = SiloCase(get_scene("silo").resolve(dict(SMALL)))
    fall = math.sqrt(2.0 * 9.81 * SMALL["pour_height"])
    assert case.sim.dt_report.impact_speed == pytest.approx(2.0 * fall, rel=1e-12)
    assert case.sim.guards.v_max == pytest.approx(20.0 * fall, rel=1e-12)
    # with neither dt nor dt_factor given, the step is the engine's recommended one (factor 1)
    assert case.sim.dt == case.sim.dt_report.recommended


def test_the_silo_reports_progress_in_zero_to_one_and_one_when_it_stops():
    """progress() gives the fraction done in [0, 1] (scenes/driver.py); the discharge stops once
    nine tenths of the charge have left, so that point, and any later one, reads 1."""
    from millsim.scenes.silo import SiloCase

    load_all()
    case = SiloCase(get_scene("silo").resolve(dict(SMALL)))
    total = case.mass * SMALL["n"]
    seen = [case.progress()[0]]  # pouring
    case.stage = "settle"
    seen.append(case.progress()[0])
    case.stage = "discharge"
    for out in np.linspace(0.0, 1.0, 21):
        case.discharged = out * total
        seen.append(case.progress()[0])
    assert all(0.0 <= f <= 1.0 for f in seen)
    assert seen == sorted(seen)
    case.discharged = 0.9 * total
    assert case.progress()[0] == 1.0
