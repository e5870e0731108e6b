"""Scene bed_impact (Tavares et al. 2021, section 4.2): geometry, ball, mass conservation, case
outputs.

One spec variant is compiled (the scene's own: 3D Hertz-Mindlin, walls, gravity, Tavares,
rolling friction); the engine-level cases use it too.
"""

import math

import numpy as np
import pytest

from millsim.engine import Guards, Simulation, StepPolicy
from millsim.models import TavaresModel
from millsim.models.breakage.progeny_families import global_min_size
from millsim.models.breakage.replacement import TavaresReplacement
from millsim.models.breakage.tavares_materials import load_materials
from millsim.scenes import bed_impact as bed
from millsim.scenes.base import get_scene

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


@pytest.mark.parametrize("rings", [2, 3])
def test_the_monolayer_lists_its_rings_in_turn(rings):
    """The centre, then the 6 k sites of ring k (k = 1..rings) before any site farther out: a
    site's ring is the hexagon of circumradius k s it lies on, max(|x|, |x/2| + sqrt(3)/2 |y|)
    / (sqrt(3)/2 s) rounded, from its position alone."""
    s = 1.02 * D
    xy = bed.hex_layer(rings, s)
    c = math.sqrt(3.0) / 2.0
    ring = np.rint(np.maximum(np.abs(xy[:, 1]) / c, np.abs(xy[:, 1]) / (2 * c)
                              + np.abs(xy[:, 0])) / s).astype(int)
    assert (np.diff(ring) >= 0).all()
    assert np.bincount(ring).tolist() == [1] + [6 * k for k in range(1, rings + 1)]


def test_a_record_books_the_bed_kinetic_and_ball_energy_of_the_state():
    """The drop's record at a state set by hand: bed kinetic energy 1/2 sum m v^2 over the bed
    (not the ball), the ball's energy 1/2 m v^2 + m g z."""
    scene = get_scene("bed_impact")
    case = scene.build(scene.resolve({"rings": 1, "layers": 1, "settle_time": 0}))
    sim = case.sim
    rng = np.random.default_rng(5)
    v = rng.normal(0.0, 2.0, (sim.n_particles, 3))
    sim.particles.v[:] = v
    case._observe()
    m = sim.masses()
    assert case.recorded("bed_kinetic_energy")[-1] == pytest.approx(
        0.5 * sum(m[k] * v[k] @ v[k] for k in range(1, sim.n_particles)), rel=1e-12)
    assert case.recorded("ball_energy")[-1] == pytest.approx(
        0.5 * m[0] * v[0] @ v[0] + m[0] * 9.81 * sim.particles.x[0, 2], rel=1e-12)


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
    # the paper's speed range 1.0-2.5 m/s
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
    # the scene's per-particle bookkeeping, as simulation tags the replacement hands on
    tags = {"origin": np.arange(8) - 1, "generation": np.zeros(8, dtype=int),
            "dummy": np.zeros(8, dtype=bool), "event_t10": np.zeros(8)}
    sim = Simulation(bed.SPEC, table, x=x_all, radius=np.r_[rb, np.full(7, D / 2)],
                     material=["steel"] + ["copper_ore"] * 7, v=[[0, 0, -1.5]] + [[0, 0, 0]] * 7,
                     walls=[dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="steel")],
                     breakage=TavaresModel({"copper_ore": (ore.gamma, 0.0)}),
                     step=StepPolicy(impact_speed=1.5, smallest_radius=d_min / 2),
                     guards=Guards(max_overlap=2.0, v_max=1e3), skin=0.1 * D, tags=tags)
    replace = TavaresReplacement({"copper_ore": ore}, d_min=d_min, seed=4, dummy_as="fines")
    replace.assign_fracture_energies(sim, np.arange(1, 8))
    sim.breakage.e_frac[1:] *= 0.05  # weak particles: breakage within a few microseconds
    m0 = replace.resolved_mass(sim)
    tracker = bed._Tracker(replace, ore)
    sim.run(6000, chunk=500, on_events=tracker)
    assert len(replace.events) >= 1 and replace.fines_mass > 0
    assert replace.resolved_mass(sim) + replace.fines_mass == pytest.approx(m0, rel=1e-12)
    origin = sim.tags["origin"]
    assert len(origin) == sim.n_particles
    assert origin[0] == -1  # the ball stays particle 0
    assert (origin[1:] >= 0).all() and (origin[1:] < 7).all()
    # generation 0 exactly for the bed particles still whole; one event row per breakage
    gen = sim.tags["generation"]
    assert gen[0] == 0 and (gen >= 0).all()
    np.testing.assert_array_equal(gen[1:] == 0, sim.particles.radius[1:] == D / 2)
    assert len(tracker.event_rows) == len(replace.events)


# Tavares et al. 2021, Table 4, copper ore: E_inf [J/kg] on the stress-vs-steel basis,
# d0 [m], phi, sigma; Table 5: density, Young's modulus, Poisson ratio of the ore and of steel;
# section 3.1: Emax/E50 = 100 in the bed validation.
ORE = dict(E_inf=213.5, d0=8.07e-3, phi=1.22, sigma=0.799, density=2930.0, young=52e9, poisson=0.25)
STEEL_K = 210e9 / (1 - 0.3**2)
EMAX_OVER_E50 = 100.0


def fracture_probability(E, d=D):
    """Eqs 1-3 coded here: P(E) = Phi(ln(E*/E50) / sigma), E* = E Emax / (Emax - E), absorbed
    basis E50 = ks / (kp + ks) E_inf [1 + (d0/d)^phi], kp = Y / (1 - nu^2)."""
    kp = ORE["young"] / (1 - ORE["poisson"] ** 2)
    E50 = STEEL_K / (kp + STEEL_K) * ORE["E_inf"] * (1 + (ORE["d0"] / d) ** ORE["phi"])
    Emax = EMAX_OVER_E50 * E50
    if E >= Emax:
        return 1.0
    return 0.5 * (1 + math.erf(math.log(E * Emax / (Emax - E) / E50) / (ORE["sigma"] * math.sqrt(2))))


def run_case(tmp_path, *sets):
    """One particle (0 rings) under the ball, through the command line. d_min = 0.2 d: the
    particle may break once, its fragments not; the smallest fragment is then 4x larger than at
    1/20 and so is the time step (the test stays short)."""
    from millsim.cli import main
    from millsim.io import read_case

    out = tmp_path / "case.nc"
    args = ["run", "bed_impact", "--set", "rings=0", "--set", "settle_time=0", "--set",
            "d_min_ratio=0.2", "--set", "record_interval=5e-5", "--out", str(out), "--quiet"]
    for item in sets:
        args += ["--set", item]
    assert main(args) == 0
    return read_case(out)


UNITS = {"broken_mass": "kg", "broken_fraction": "1", "capture_radius": "m", "bed_mass": "kg",
         "passing": "kg", "passing_fraction": "1", "ball_z": "m", "ball_vz": "m s-1",
         "n_particles": "1", "event_time": "s", "mass_balance_error": "kg", "ball_energy": "J",
         "ball_energy_initial": "J", "impact_speed": "m s-1", "fines_mass": "kg", "sieve": "m",
         "event_specific_energy": "J kg-1", "breakage_energy": "J"}


@pytest.mark.parametrize("dummy_as", ["spheres", "fines"])
def test_tiny_case_breaks_the_particle_far_above_its_fracture_energy(tmp_path, dummy_as):
    """3.05 J on one 5.5 mm copper-ore particle (0.26 g): far above any fracture energy it can
    draw, so it breaks with certainty. Every progeny class lies below parent / 2^(1/4) = 4.6 mm,
    so all the mass passes 4.75 mm: broken fraction 1, and the product passes 6.3 mm and 4.75 mm
    completely (mass closure), whether the dummy class stays as spheres or becomes fines."""
    ds = run_case(tmp_path, f"dummy_as={dummy_as}")
    from millsim.io import case_parameters

    assert ds.attrs["scene"] == "bed_impact" and case_parameters(ds)["rings"] == 0
    assert {name: ds[name].attrs["units"] for name in UNITS} == UNITS
    m0 = 2930 * math.pi / 6 * D**3
    assert float(ds["bed_mass"]) == pytest.approx(m0, rel=1e-12)
    assert abs(float(ds["mass_balance_error"])) < 1e-12 * m0
    assert float(ds["impact_speed"]) == pytest.approx(math.sqrt(2 * 3.05 / 2.78), rel=1e-12)
    # Unbroken, it would have to stop the ball: the loading work of its two contacts is at least
    # the ball's 3.05 J, and it takes ks / (kp + ks) = 0.81 of each (eq 4, both partners steel):
    # ~9600 J/kg, where eqs 1-3 give P > 1 - 1e-4. It breaks once (its progeny cannot).
    kp = ORE["young"] / (1 - ORE["poisson"] ** 2)
    assert fracture_probability(STEEL_K / (kp + STEEL_K) * 3.05 / m0) > 1 - 1e-4
    assert int(ds["breakage_events"]) == 1
    assert float(ds["broken_mass"]) == pytest.approx(m0, rel=1e-12)
    assert float(ds["broken_fraction"]) == pytest.approx(float(ds["broken_mass"]) / m0, rel=1e-12)
    assert float(ds["broken_fraction"]) == pytest.approx(1.0, rel=1e-12)
    passing = ds["passing_fraction"]
    assert passing.sieve.values[:2] == pytest.approx([6.3e-3, 4.75e-3])
    np.testing.assert_allclose(passing.values[:2], 1.0, rtol=1e-12)
    np.testing.assert_allclose(ds["passing"].values, passing.values * m0, rtol=1e-12)
    assert (np.diff(passing.values) <= 1e-12).all()  # cumulative: non-increasing with smaller sieves
    assert dummy_as == "spheres" or float(ds["fines_mass"]) > 0
    # the ball came down, and the run ended with it rebounding
    assert float(ds["ball_vz"][0]) < 0 and float(ds["ball_vz"][-1]) > 0


def test_tiny_case_leaves_the_particle_whole_far_below_its_fracture_energy(tmp_path):
    """1 mJ from 1 um above the particle: whatever it absorbed is at most what the ball lost
    (kinetic + potential, its own recorded energy; the anvil does no work), ~7 J/kg. Eqs 1-3 give
    P < 1e-4 even at twice that (to cover the record cadence): broken fraction 0 exactly, nothing
    passes 4.75 mm, everything still passes 6.3 mm."""
    ds = run_case(tmp_path, "impact_energy=0.001", "ball_gap=1e-6")
    m0 = 2930 * math.pi / 6 * D**3
    lost = float(ds["ball_energy_initial"]) - float(ds["ball_energy"].min())
    assert fracture_probability(2 * lost / m0) < 1e-4
    assert int(ds["breakage_events"]) == 0
    assert float(ds["broken_fraction"]) == 0.0 and float(ds["broken_mass"]) == 0.0
    np.testing.assert_allclose(ds["passing_fraction"].values, np.r_[1.0, np.zeros(15)], atol=1e-15)


def test_seed_summary_is_mean_and_sample_deviation_over_the_replicates():
    """analysis.bed_impact.summary over the seed dimension of a sparse aggregate: the mean over
    the seeds present (missing combinations are NaN), the sample standard deviation (n - 1) and
    the replicate count, against numbers written out here; one replicate has no deviation."""
    import xarray as xr

    from millsim.analysis.bed_impact import summary

    fraction = np.array([[0.2, 0.4, 0.9], [0.5, np.nan, np.nan]])  # (impact_energy, seed)
    ds = xr.Dataset({"broken_fraction": (("impact_energy", "seed"), fraction, {"units": "1"}),
                     "capture_radius": (("impact_energy", "seed"), 1e-3 * fraction, {"units": "m"})},
                    coords={"impact_energy": [1.0, 3.05], "seed": [1, 2, 3]})
    out = summary(ds)
    np.testing.assert_allclose(out["broken_fraction_mean"], [0.5, 0.5], rtol=1e-12)
    sd = math.sqrt(((0.2 - 0.5) ** 2 + (0.4 - 0.5) ** 2 + (0.9 - 0.5) ** 2) / 2)  # = 0.3606
    assert float(out["broken_fraction_std"][0]) == pytest.approx(sd, rel=1e-12)
    assert np.isnan(float(out["broken_fraction_std"][1]))
    assert list(out["replicates"].values) == [3, 1]
    np.testing.assert_allclose(out["capture_radius_mean"], [5e-4, 5e-4], rtol=1e-12)
    assert out["capture_radius_std"].attrs["units"] == "m"
    assert out["broken_fraction_mean"].attrs["units"] == "1"
