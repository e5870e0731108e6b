"""Scene bed_impact (seed 002 section 4.2): geometry, ball, mass conservation, case outputs.

One spec variant is compiled (the scene's own: 3D Hertz-Mindlin, walls, gravity, Tavares,
rolling friction); the engine-level cases use it too.
"""

import math

import numpy as np
import pytest

from millsim.breakage.replacement import TavaresReplacement
from millsim.breakage.tavares import global_min_size, load_materials
from millsim.engine import Simulation
from millsim.scenes import bed_impact as bed
from millsim.scenes.base import RunContext, get_scene

D = 5.5e-3


@pytest.mark.parametrize("rings, n", [(0, 1), (1, 7), (2, 19), (3, 37), (4, 61)])
def test_monolayer_counts_and_hexagonal_spacing(rings, n):
    s = 1.02 * D
    xy = bed.hex_layer(rings, s)
    assert len(xy) == n
    assert np.allclose(xy[0], 0.0)  # the central particle first
    if n > 1:
        d = np.linalg.norm(xy[:, None] - xy[None], axis=2)
        np.fill_diagonal(d, np.inf)
        assert d.min(1) == pytest.approx(np.full(n, s))  # nearest neighbours one spacing away
        # every inner site has six nearest neighbours
        inner = np.linalg.norm(xy, axis=1) < (rings - 1) * s + 1e-9
        assert ((np.abs(d - s) < 1e-9).sum(1)[inner] == 6).all()
        # the outer ring is a hexagon of circumradius rings * s
        assert np.linalg.norm(xy, axis=1).max() == pytest.approx(rings * s)


def test_multilayer_bed_stacks_in_hollows_without_overlap():
    x = bed.bed_positions(3, 3, D, 1.02)
    layer = np.round((x[:, 2] - x[:, 2].min()) / D, 3)
    levels = np.unique(layer)
    assert len(levels) == 3
    counts = [int((layer == z).sum()) for z in levels]
    assert counts[0] == counts[2] == 37 and 0 < counts[1] < 37
    d = np.linalg.norm(x[:, None] - x[None], axis=2)
    np.fill_diagonal(d, np.inf)
    assert d.min() >= D * (1 - 1e-12)  # nothing overlaps before settling
    assert x[:, 2].min() == pytest.approx(D / 2)  # the first layer rests on the anvil


def test_total_mass_and_ball():
    mats = load_materials(truncation="bed")
    ore = mats["copper_ore"]
    for rings, n in [(0, 1), (1, 7), (4, 61)]:
        m = bed.sphere_mass(ore.density, np.full(len(bed.hex_layer(rings, D)), D)).sum()
        assert m == pytest.approx(n * ore.density * math.pi / 6 * D**3)
    rho = bed.ball_density(2.78, 0.088)
    assert bed.sphere_mass(rho, 0.088) == pytest.approx(2.78)
    assert rho == pytest.approx(7791.1, abs=0.1)  # Table 5 steel: 7800 (0.1 % heavier)
    v = bed.ball_speed(3.05, 2.78)
    assert 0.5 * 2.78 * v**2 == pytest.approx(3.05)
    assert v == pytest.approx(1.4813, abs=1e-4)
    # the seed's speed range 1.0-2.5 m/s
    assert bed.ball_speed(0.5 * 2.78 * 1.0**2, 2.78) == pytest.approx(1.0)


def test_bad_parameters_refused():
    scene = get_scene("bed_impact")
    with pytest.raises(ValueError, match="material"):
        scene.resolve({"material": "granite"})
    with pytest.raises(ValueError, match="impact_energy"):
        scene.resolve({"impact_energy": "0"})
    with pytest.raises(ValueError, match="rings"):
        scene.resolve({"rings": "0", "layers": "3"})


def test_mass_conserved_through_breakage_with_fines():
    """A 7-particle copper-ore bed crushed by the ball: every replacement keeps resolved + fines
    equal to the initial bed mass (dummy class as unresolved fines, so that both terms count)."""
    scene = get_scene("bed_impact")
    values = scene.resolve({"rings": 1})
    mats = load_materials(values["materials_file"], truncation="bed")
    table = bed.material_table(values, mats)
    ore = mats["copper_ore"]
    x = bed.bed_positions(1, 1, D, values["spacing"])
    rb = 0.044
    x_all = np.vstack([[0, 0, D + 1e-5 + rb], x])
    d_min = global_min_size(D)
    sim = Simulation(bed.SPEC, table, x=x_all, radius=np.r_[rb, np.full(7, D / 2)],
                     material=["steel"] + ["copper_ore"] * 7, v=[[0, 0, -1.5]] + [[0, 0, 0]] * 7,
                     walls=[dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="steel")],
                     breakage={"copper_ore": (ore.gamma, 0.0)}, smallest_radius=d_min / 2,
                     impact_speed=1.5, max_overlap=2.0, v_max=1e3, skin=0.1 * D)
    replace = TavaresReplacement({"copper_ore": ore}, d_min=d_min, seed=4, dummy_as="fines")
    replace.assign_fracture_energies(sim, np.arange(1, 8))
    sim.particles.e_frac[1:] *= 0.05  # weak particles: breakage within a few microseconds
    m0 = replace.resolved_mass(sim)
    tracker = bed._Tracker(replace, ore, 8, values)
    sim.run(6000, chunk=500, on_fracture=tracker)
    assert len(replace.events) >= 1 and replace.fines_mass > 0
    assert replace.resolved_mass(sim) + replace.fines_mass == pytest.approx(m0, rel=1e-12)
    assert len(tracker.origin) == sim.n_particles
    assert tracker.origin[0] == -1  # the ball stays particle 0
    assert (tracker.origin[1:] >= 0).all() and (tracker.origin[1:] < 7).all()


def test_tiny_case_writes_outputs(tmp_path):
    """A single particle (0 rings) hit at 3.05 J: the case file has the outputs, SI units and
    provenance, and its mass books close."""
    from millsim.cli import main
    from millsim.io import case_parameters, read_case

    out = tmp_path / "case.nc"
    # d_min = 0.2 d: the particle may break once, its fragments not; the smallest fragment is
    # then 4x larger than at 1/20 and so is the time step (the test stays short)
    rc = main(["run", "bed_impact", "--set", "rings=0", "--set", "settle_time=0",
               "--set", "d_min_ratio=0.2",
               "--set", "record_interval=5e-5", "--out", str(out), "--quiet"])
    assert rc == 0
    ds = read_case(out)
    assert ds.attrs["scene"] == "bed_impact"
    assert case_parameters(ds)["rings"] == 0
    for name in ("broken_mass", "broken_fraction", "capture_radius", "passing_fraction",
                 "ball_z", "ball_vz", "n_particles", "event_time", "bed_mass",
                 "mass_balance_error", "ball_energy"):
        assert name in ds and "units" in ds[name].attrs
    m0 = float(ds["bed_mass"])
    assert m0 == pytest.approx(2930 * math.pi / 6 * D**3)
    assert abs(float(ds["mass_balance_error"])) < 1e-12 * m0 + 1e-18
    assert float(ds["impact_speed"]) == pytest.approx(1.4813, abs=1e-4)
    assert 0.0 <= float(ds["broken_fraction"]) <= 1.0 + 1e-12
    passing = ds["passing_fraction"].values
    assert (np.diff(passing) <= 1e-12).all()  # cumulative: non-increasing with smaller sieves
    # the ball came down, and the run ended with it rebounding
    assert float(ds["ball_vz"][0]) < 0 and float(ds["ball_vz"][-1]) > 0
