"""The parts of scene ``ballmill3d`` that need no run, each against a closed form or a count by
hand: where a liner path is read from, the lifter gap of a ring of rays, the refusal of a liner
off the drum's axis, the charge's ball and ore counts; the observables (the band profile's
solid volume, an arc across the top of the drum, the size classes, the selection function's
interval, the Hertz elastic energy of pairs and walls); the breakage predicted from a stress log
(the compensator of a sequence, z and p); and the case as built (parameter ranges, the step's
impact speed, the steps to a record)."""

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from millsim.engine import PhysicsSpec
from millsim.engine.mesh_io import box_mesh, liner_mesh, write_stl
from millsim.models.breakage import tavares, tavares_materials
from millsim.scenes import ballmill3d_charge as charge
from millsim.scenes import ballmill3d_observables as obs
from millsim.scenes import ballmill3d_rates as rates
from millsim.scenes import load_all
from millsim.scenes.base import REGISTRY

from one_particle import make_sim

SHIPPED = "examples/meshes/ballmill_liner.stl"
load_all()
SCENE = REGISTRY["ballmill3d"]


def test_a_relative_liner_path_is_read_from_the_working_directory_before_the_repository(
        tmp_path, monkeypatch):
    """The user's own file of the shipped liner's relative name wins; the repository's copy is
    the fallback only where the working directory has none; an absolute path is left alone."""
    monkeypatch.chdir(tmp_path)
    assert charge.resolve_liner(SHIPPED) == charge.REPO / SHIPPED  # none here: the shipped one
    (tmp_path / SHIPPED).parent.mkdir(parents=True)
    (tmp_path / SHIPPED).write_bytes(b"the user's liner")
    assert charge.resolve_liner(SHIPPED).resolve() == (tmp_path / SHIPPED).resolve()
    absent = tmp_path / "nowhere.stl"
    assert charge.resolve_liner(str(absent)) == absent


def test_the_lifter_gap_of_a_ring_of_rays():
    """Rays at equal angles; lifters block the rays nearer than halfway up them. A free run of k
    rays between two lifters is a chord 2 h sin(k pi / n) on the half-height circle h; a ring
    blocked all round (a ring narrower than the drum's halfway circle) has no gap; a smooth
    shell (no ray nearer than 1e-3 of it) has no lifters, an infinite gap."""
    n, shell, tip = 360, 0.05, 0.04
    half = 0.045
    dist = np.full(n, shell)
    dist[[0, 1, 2, 100, 101, 250]] = tip  # free runs of 97, 148 and 109 rays
    assert charge.lifter_gap(dist, shell, tip) == pytest.approx(2 * half * math.sin(97 * math.pi / n),
                                                                rel=1e-12)
    assert charge.lifter_gap(np.full(n, 0.042), shell, tip) == 0.0
    assert charge.lifter_gap(np.full(n, shell), shell, shell * (1 - 1e-4)) == math.inf


def _liner(path, shift_y=0.0, radius=0.05, length=0.03):
    v, f = liner_mesh(radius, length, segments=48, lifters=8, lifter_height=0.006,
                      lifter_width=0.006)
    v = np.column_stack([v[:, 0], v[:, 2] + shift_y, -v[:, 1]])
    write_stl(path, v, f)
    return v


def test_a_liner_off_the_drums_length_is_refused_with_its_true_extent(tmp_path):
    """The liner must run along y from 0 to drum_length: one shifted by half the length is
    refused, and the message gives the mesh's bounds per axis (as written to the file)."""
    values = dict(liner_scale=1.0, drum_diameter=0.1, drum_length=0.03)
    _liner(tmp_path / "ok.stl")
    charge.probe_liner(dict(values, liner=str(tmp_path / "ok.stl")))
    v = _liner(tmp_path / "shifted.stl", shift_y=0.015)
    with pytest.raises(ValueError, match="does not run along the drum's axis y") as info:
        charge.probe_liner(dict(values, liner=str(tmp_path / "shifted.stl")))
    lo, hi = v.min(axis=0), v.max(axis=0)
    for axis, a, b in zip("xyz", lo, hi):
        assert f"{axis} [{a:.4g}, {b:.4g}]" in str(info.value)


def test_the_charge_counts_follow_filling_packing_and_the_mass_ratio():
    """Bulk volume filling x pi D^2 L / 4 at solid fraction 0.6 (Napier-Munn et al. 1996), split
    so that ball mass = ball_ore_ratio x ore mass, counted by the mean volume of diameters uniform
    by number (E[d^3] by quadrature here)."""
    values = dict(drum_diameter=0.3, drum_length=0.2, filling=0.3, ball_ore_ratio=2.0,
                  ball_diameter_min=0.02, ball_diameter_max=0.04, ore_diameter_min=0.005,
                  ore_diameter_max=0.012)
    ore_rho, steel_rho = 2700.0, 7800.0
    got = charge.charge_counts(values, ore_rho, steel_rho)
    solid = 0.3 * math.pi * 0.3**2 / 4 * 0.2 * 0.6
    assert got.ball_volume + got.ore_volume == pytest.approx(solid, rel=1e-12)
    assert got.ball_volume * steel_rho == pytest.approx(2.0 * got.ore_volume * ore_rho, rel=1e-12)

    def mean_volume(lo, hi):
        d = lo + (hi - lo) * (np.arange(200_000) + 0.5) / 200_000  # midpoint rule
        return math.pi / 6 * float(np.mean(d**3))

    assert got.balls == round(got.ball_volume / mean_volume(0.02, 0.04))
    assert got.ore == round(got.ore_volume / mean_volume(0.005, 0.012))
    assert charge.mean_cube(0.02, 0.04) == pytest.approx(mean_volume(0.02, 0.04) * 6 / math.pi,
                                                         rel=1e-9)
    assert charge.mean_cube(0.03, 0.03) == pytest.approx(0.03**3, rel=1e-12)


# ---- observables --------------------------------------------------------------------------------
def test_the_band_profile_holds_the_solid_volume_of_the_band():
    """Sector volumes add up to the spheres' volume 4/3 pi r^3 whose centres lie in the band;
    particles nearer the axis do not count."""
    rng = np.random.default_rng(3)
    rho = np.concatenate([rng.uniform(0.081, 0.1, 300), rng.uniform(0.0, 0.079, 200)])
    theta = rng.uniform(-math.pi, math.pi, 500)
    x = np.column_stack([-rho * np.sin(theta), rng.uniform(0, 0.05, 500), -rho * np.cos(theta)])
    r = rng.uniform(1e-3, 3e-3, 500)
    profile = obs.band_profile(x, r, 0.1, 0.02)
    assert profile.sum() == pytest.approx(sum(4 / 3 * math.pi * r[:300] ** 3), rel=1e-12)


@pytest.mark.parametrize("densest", [0.4, 1.0])
def test_an_arc_across_the_top_of_the_drum_is_reported_whole(densest):
    """A charge arc from 2.6 to 3.9 rad (through the top, +-pi) comes back as one arc of the
    same width, its middle in [-pi, pi): (2.6 - 2 pi, 3.9 - 2 pi), within one sector, whether
    its densest sector lies before the top (3.0 rad) or after it (3.6 rad)."""
    bins = obs.ANGLE_BINS
    centres = -math.pi + (np.arange(bins) + 0.5) * 2 * math.pi / bins
    wrapped = np.mod(centres - 2.6, 2 * math.pi)
    profile = np.where(wrapped < 1.3, 1.0 - 0.1 * np.abs(wrapped - densest), 0.05)
    toe, shoulder = obs.toe_shoulder(profile)
    width = 2 * math.pi / bins
    assert toe == pytest.approx(2.6 - 2 * math.pi, abs=width)
    assert shoulder == pytest.approx(3.9 - 2 * math.pi, abs=width)


def test_size_classes_and_sieves_are_the_sqrt2_series():
    """Lower edges d_max / sqrt(2)^k down to the last at or above d_min; sieves from sqrt(2)
    d_max to four classes under d_min."""
    assert np.allclose(obs.size_classes(0.01, 0.0021), [0.01 / 2**0.5, 0.005, 0.01 / 2**1.5, 0.0025],
                       rtol=1e-12)
    assert np.allclose(obs.size_classes(0.01, 0.0025), [0.01 / 2**0.5, 0.005, 0.01 / 2**1.5, 0.0025],
                       rtol=1e-12)
    assert np.allclose(obs.sieves(0.01, 0.005), 0.01 * 2.0 ** (-0.5 * np.arange(-1, 7)), rtol=1e-12)


def test_the_selection_functions_interval_comes_from_block_rates():
    """The 95 % half-width: Student-t over the rates of equal time blocks (events in the block /
    its duration), divided by the class's mean count, all written out here."""
    rng = np.random.default_rng(8)
    t0, t1, blocks = 0.0, 2.0, 4
    times = np.sort(rng.uniform(t0, t1, 40))
    diam = np.full(40, 9e-3)
    rec_t = np.linspace(t0, t1, 21)
    counts = np.column_stack([np.full(21, 25.0)])
    rate, half = obs.selection_function(times, diam, [0.007], t0, t1, rec_t, counts, blocks=blocks)
    per_block = np.array([np.count_nonzero((times >= a) & (times < a + 0.5)) / 0.5
                          for a in (0.0, 0.5, 1.0, 1.5)])
    expected = stats.t.ppf(0.975, blocks - 1) * per_block.std(ddof=1) / math.sqrt(blocks) / 25.0
    assert rate[0] == pytest.approx(40 / 2.0 / 25.0, rel=1e-12)
    assert half[0] == pytest.approx(expected, rel=1e-9)


def test_elastic_energy_is_hertzs_for_pairs_planes_and_cylinders():
    """8/15 E* sqrt(R*) xi^(5/2) per contact (Johnson 1985), with E* = E / (2 (1 - nu^2)) for
    one material against itself, R* = r against a wall and r / 2 for two equal spheres; pressed
    into the floor, a cylinder's shell and each other at construction (no step)."""
    r, xi, young, poisson = 1e-3, 2e-5, 5e6, 0.3  # tests/one_particle.py's Hertz material
    walls = [dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="m"),
             dict(kind="cylinder_inner", point=(0, 0, 0), axis=(0, 1, 0), radius=0.01,
                  material="m")]
    x = [(0.0, 0.0, r - xi),  # on the floor
         (0.003, 0.0, 0.004), (0.003, 0.0, 0.004 + 2 * r - xi),  # a pair
         (0.0, 0.002, 0.01 - r + 0.5 * xi)]  # against the shell, above the floor's reach
    sim = make_sim((PhysicsSpec(dim=3, walls=True), "hertz_mindlin"), x, walls=walls)
    e_star = young / (2 * (1 - poisson**2))
    expected = 8 / 15 * e_star * (math.sqrt(r) * xi**2.5 + math.sqrt(r / 2) * xi**2.5
                                  + math.sqrt(r) * (0.5 * xi) ** 2.5)
    assert obs.elastic_energy(sim) == pytest.approx(expected, rel=1e-6)


def test_elastic_energy_against_a_mesh_is_hertzs_at_the_nearest_facet(tmp_path):
    """A sphere pressed xi into the top face of a block (a mesh wall, closed STL) stores
    8/15 E* sqrt(r) xi^(5/2); one clear of it nothing."""
    r, xi, young, poisson = 1e-3, 3e-5, 5e6, 0.3
    path = tmp_path / "block.stl"
    write_stl(path, *box_mesh((-0.01, -0.01, -0.02), (0.01, 0.01, 0.0)))
    sim = make_sim((PhysicsSpec(dim=3, walls=True, mesh_walls=True), "hertz_mindlin"),
                   [(0.002, 0.001, r - xi), (-0.005, 0.0, r + 1e-4)],
                   walls=[dict(kind="mesh", file=str(path), material="m")])
    e_star = young / (2 * (1 - poisson**2))
    assert obs.elastic_energy(sim) == pytest.approx(8 / 15 * e_star * math.sqrt(r) * xi**2.5,
                                                    rel=1e-6)


# ---- breakage predicted from the stress log ----------------------------------------------------
MATERIALS = charge.REPO / "config" / "materials.yaml"


def _mill(diameters, body, specific_energy_now, log):
    """What StressBook reads of a Simulation: ore particles (material 0) of copper ore's density,
    the energy each has absorbed in its contact now [J] and the drained stress log."""
    r = 0.5 * np.asarray(diameters)
    mass = 2930.0 * 4 / 3 * math.pi * r**3
    particles = SimpleNamespace(radius=r, material=np.zeros(len(r), int), body=np.asarray(body),
                                inv_mass=1 / mass)
    breakage = SimpleNamespace(e_frac=np.ones(len(r)), e_acc=np.asarray(specific_energy_now) * mass,
                               take_stress_log=lambda: log)
    return SimpleNamespace(particles=particles, particle_ids=np.arange(len(r)), breakage=breakage)


def test_the_compensator_counts_the_events_in_progress_at_both_ends():
    """One event each, so no damage enters and S = 1 - F(E), F eq 1's fracture energy
    distribution: a particle in an event at the end (30 J/kg so far) has Lambda = -ln(1 -
    F(30)); one in an event at the start (20 J/kg by then) that ends with 50 J/kg has ln(1 -
    F(20)) - ln(1 - F(50)); a member of a rigid body is not booked."""
    mat = tavares_materials.load_materials(MATERIALS)["copper_ore"]
    d = 0.006
    book = rates.StressBook(mat, 0, d_min=0.001)
    sim = _mill([d, d, d], body=[-1, 0, -1], specific_energy_now=[0.0, 0.0, 20.0], log=[])
    book.register(sim)
    book.open(sim)
    ended = SimpleNamespace(particle_id=2, specific_energy=50.0, broke=False)
    book.close(_mill([d, d, d], [-1, 0, -1], [30.0, 0.0, 0.0], [ended]))
    survive = {e: 1 - float(tavares.fracture_energy_cdf(mat, d, np.array([e]))[0])
               for e in (20.0, 30.0, 50.0)}
    got = dict(zip((0, 2), (lam for _, lam in book.compensators())))
    assert len(book.compensators()) == 2
    assert got[0] == pytest.approx(-math.log(survive[30.0]), rel=1e-9)
    assert got[2] == pytest.approx(math.log(survive[20.0]) - math.log(survive[50.0]), rel=1e-9)


class _Book:
    def __init__(self, lam):
        self.lam = lam

    def compensators(self):
        return self.lam


def test_the_z_score_and_p_value_of_a_small_prediction():
    """z = (counted - predicted) / sqrt(predicted), p two-sided of the normal law, for a
    prediction below one event; nothing predicted gives NaN for both, not a division by zero.
    Events before t_w and classes are counted as the selection function's."""
    lower = [0.004, 0.002]
    predicted, counted, z, p = rates.compare(_Book([(0.005, 0.3), (0.0045, 0.2), (0.003, 0.1)]),
                                             [0.5, 1.5, 2.0], [0.005, 0.005, 0.003], 1.0, lower)
    assert predicted == pytest.approx([0.5, 0.1], rel=1e-12)
    assert counted.tolist() == [1.0, 1.0]
    assert z == pytest.approx((2 - 0.6) / math.sqrt(0.6), rel=1e-12)
    assert p == pytest.approx(2 * stats.norm.sf((2 - 0.6) / math.sqrt(0.6)), rel=1e-9)
    _, _, z, p = rates.compare(_Book([]), [], [], 1.0, lower)
    assert math.isnan(z) and math.isnan(p)
    # a class nothing broke in is counted 0, the last one too
    _, counted, _, _ = rates.compare(_Book([(0.005, 0.3)]), [1.5], [0.005], 1.0, lower)
    assert counted.tolist() == [1.0, 0.0]


# ---- the case as built ---------------------------------------------------------------------------
def test_one_spectrum_bin_is_allowed_and_the_overlap_guard_ends_at_five_radii():
    """The ranges the parameter table states: spectra_bins >= 1; max_overlap in (0, 5]."""
    params = {p.name: p for p in SCENE.params}
    assert params["spectra_bins"].parse(1) == 1
    assert params["max_overlap"].parse(5.0) == 5.0
    for name, value in (("spectra_bins", 0), ("max_overlap", 5.5)):
        with pytest.raises(ValueError, match=f"^{name}: .*outside the allowed range"):
            params[name].parse(value)


def test_the_step_is_planned_for_the_shell_speed_plus_a_fall_across_the_drum():
    """The Hertz step's impact speed: the shell's surface speed omega D / 2 plus a free fall
    across the drum sqrt(2 g D), omega = n_over_nc sqrt(2 g / (D - d)) (Napier-Munn et al.
    1996); and a record comes after round(interval / dt) steps, the rest of one after it."""
    small = dict(drum_diameter=0.1, drum_length=0.03, ball_diameter_min=0.012,
                 ball_diameter_max=0.012, ore_diameter_min=0.006, ore_diameter_max=0.006,
                 filling=0.25, liner="", n_over_nc=0.75, records_per_revolution=20)
    case = SCENE.build(SCENE.resolve(small))
    omega = 0.75 * math.sqrt(2 * 9.81 / (0.1 - 0.012))
    assert case.sim.policy.impact_speed == pytest.approx(omega * 0.05 + math.sqrt(2 * 9.81 * 0.1),
                                                         rel=1e-12)
    interval = 2 * math.pi / omega / 20
    dt = case.sim.dt
    case.last = SimpleNamespace(time=case.sim.time)
    assert case.record_steps() == round(interval / dt)
    case.last = SimpleNamespace(time=case.sim.time - 0.75 * interval)
    assert case.record_steps() == round(0.25 * interval / dt)
