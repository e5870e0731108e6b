"""Tavares breakage (Tavares et al. 2021) at mesh walls: a triangle contact is a stressing
contact exactly as an analytic wall's.

- A sphere thrown at a flat meshed plate (over a triangle's interior, a shared edge, a vertex of
  six triangles) against the same throw at the analytic plane: the same loading work, damage,
  breakage step and direction, also over repeated impacts (an analytic ceiling sends it back, so
  the mesh contact's slot ends and a new one begins).
- Many throws at an energy near the median fracture energy, at random places on the plate: the
  broken fraction on the mesh lies within the binomial interval of the analytic plane's.
- Progeny created reaching into a mesh triangle feel only overlap beyond their creation state, as
  at an analytic wall; a real replacement on the plate gives its progeny the analytic plane's
  reference overlaps and motion.

The analytic runs share the variant of tests/test_tavares_engine.py; the mesh runs compile one
more (the same with mesh_walls).
"""

import numpy as np
import pytest
from scipy import stats
from test_mesh_walls import plate
from test_tavares_engine import K_ORE, K_STEEL, ORE, SPEC, STEEL

from millsim.engine import Guards, PhysicsSpec, Simulation, StepPolicy
from millsim.models import Interaction, Material, MaterialTable, TavaresModel

MESH_SPEC = PhysicsSpec(dim=3, walls=True, mesh_walls=True, gravity=False)
R = 2.75e-3
CELL = 4 * R  # the plate's top: 2 x 2 cells of two triangles each, diagonals along x = y
# over a triangle's interior, a shared edge (a cell's diagonal) and a vertex of six triangles
PLACES = {"interior": (3 * R, 1 * R), "shared_edge": (2 * R, 2 * R), "vertex": (0.0, 0.0)}
FLOOR = dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="steel")


def floor(meshed):
    """The plate's top at z = 0: a meshed slab (2 x 2 cells) or the analytic plane."""
    if not meshed:
        return FLOOR
    vertices, faces = plate(2, CELL, 2 * R)
    return dict(kind="mesh", vertices=vertices, faces=faces, material="steel")


def throw(meshed, table, material, xy, v0, e_frac, ceiling=None, smallest_radius=None):
    """One sphere of ``material`` thrown down at v0 onto the floor from 1.05 R above it (no
    gravity); ``ceiling``: the height of an analytic steel plane facing down; the time step
    for progeny down to ``smallest_radius``."""
    walls = [floor(meshed)]
    if ceiling is not None:
        walls.append(dict(kind="plane", point=(0, 0, ceiling), normal=(0, 0, -1),
                          material="steel"))
    sim = Simulation(MESH_SPEC if meshed else SPEC, table, x=[[xy[0], xy[1], 1.05 * R]],
                     radius=[R], material=material, v=[[0, 0, -v0]], gravity=(0, 0, 0),
                     step=StepPolicy(impact_speed=v0, smallest_radius=smallest_radius),
                     walls=walls, breakage=TavaresModel({material: (5.0, 0.0)}))
    sim.breakage.e_frac[0] = e_frac
    return sim


def run_recording(sim, steps):
    """Runs ``steps``; every breakage decision is recorded and the particle kept whole (it stands
    in for the replacement)."""
    rows = []

    def record(s):
        for row in s.pop_events():
            rows.append(row)
            s.breakage.e_frac[row.particle] = np.inf

    sim.run(steps, chunk=500, on_events=record)
    return rows


def ore_table(restitution=0.5):
    return MaterialTable([ORE, STEEL], {"*": Interaction(restitution=restitution, friction=0.5)})


SHARE = K_STEEL / (K_ORE + K_STEEL)  # eq 4: the ore's share of the loading work on steel


@pytest.mark.parametrize("place", PLACES)
def test_a_throw_breaks_on_the_meshed_plate_as_on_the_analytic_plane(place):
    """Same step, particle, absorbed energy and direction. Tolerance 1e-12: a face contact's
    overlap and normal are the analytic plane's to the bit (a horizontal triangle's normal is
    exactly (0, 0, 1)); the overlap one step before the contact is taken back from the drift
    (exact for velocity Verlet up to rounding of positions, 1e-19 m against a step's approach of
    1e-7 m); measured 6e-15."""
    v0 = 2.0
    specific = 0.5 * v0**2 * SHARE
    rows = [run_recording(throw(meshed, ore_table(), "ore", PLACES[place], v0, 0.5 * specific),
                          2000) for meshed in (False, True)]
    assert len(rows[0]) == 1 and len(rows[1]) == 1
    (pa, ea, sa, da), (pm, em, sm, dm) = rows[0][0], rows[1][0]
    assert (pm, sm) == (pa, sa)
    assert 0.5 * specific <= ea < 0.6 * specific  # it broke at the fracture energy's step
    assert em == pytest.approx(ea, rel=1e-12)
    assert dm == pytest.approx(da, abs=1e-12)


@pytest.mark.parametrize("place", PLACES)
def test_repeated_impacts_damage_as_on_the_analytic_plane(place):
    """Unbroken, the sphere bounces between the floor and an analytic ceiling 0.1 R above its
    reach, three times on each: every floor contact ends (its mesh slot is freed) and a new one
    begins. After each of the six events (each damages it, eqs 5-6, by the event's own energy:
    the rebound at e = 0.9 slows it) the fracture energy is the analytic plane's."""
    v0 = 2.0
    e_frac = 0.5 * v0**2 * SHARE / 0.6
    seen = []
    for meshed in (False, True):
        sim = throw(meshed, ore_table(0.9), "ore", PLACES[place], v0, e_frac, ceiling=2.1 * R)
        history = []
        while len(history) < 6:  # the energy of each event, read at its end (e_frac changes)
            before = sim.breakage.e_frac[0]
            assert not run_recording(sim, 50)
            if sim.breakage.e_frac[0] != before:
                history.append(sim.breakage.e_frac[0])
            assert sim.step < 20000
        seen.append(np.array(history))
    assert seen[1] == pytest.approx(seen[0], rel=1e-12)
    assert seen[0][-1] < 0.9 * e_frac  # six events damaged it markedly: the test can tell


def test_the_broken_fraction_on_the_mesh_lies_in_the_analytic_planes_binomial_interval():
    """40 copper-ore spheres, each with its own fracture energy drawn from the model's
    distribution (Tavares et al. 2021, eqs 1-3), thrown at random places of the plate at the
    speed whose absorbed energy is the median fracture energy: the number broken on the mesh
    lies in the 99 % binomial interval of the analytic plane's fraction."""
    from millsim.models.breakage.replacement import TavaresReplacement
    from millsim.models.breakage.tavares import sample_fracture_energy
    from millsim.models.breakage.tavares_materials import load_materials

    mats = load_materials(truncation="single_particle")
    ore, steel = mats["copper_ore"], mats["steel"]
    table = MaterialTable([Material("copper_ore", ore.density, ore.young, ore.poisson),
                           Material("steel", steel.density, steel.young, steel.poisson)],
                          {"*": Interaction(restitution=0.39, friction=0.5)})
    median = float(sample_fracture_energy(ore, 2 * R, np.array([0.5]))[0])
    v0 = np.sqrt(2.0 * median * (ore.k + steel.k) / steel.k)
    rng = np.random.default_rng(11)
    n = 40
    broken = np.zeros((2, n), bool)
    for k in range(n):
        xy = rng.uniform(-0.95 * CELL, 0.95 * CELL, 2)  # over the plate
        for meshed in (False, True):
            sim = throw(meshed, table, "copper_ore", xy, v0, np.inf)
            TavaresReplacement({"copper_ore": ore}, d_min=0.1 * R, seed=k)\
                .assign_fracture_energies(sim, [0])
            sim.breakage.break_at_end[0] = False  # first reach, whatever the size
            broken[int(meshed), k] = bool(run_recording(sim, 1000))
    k_plane, k_mesh = broken.sum(1)
    assert 0.2 * n < k_plane < 0.8 * n  # near the median: the test can tell
    lo, hi = stats.binom.interval(0.99, n, k_plane / n)
    assert lo <= k_mesh <= hi
    # (and with the same draws the very same spheres break)
    assert (broken[0] == broken[1]).all()


@pytest.mark.parametrize("place", PLACES)
def test_progeny_reaching_into_a_mesh_feel_only_extra_overlap(place):
    """As tests/test_tavares_engine.py's analytic wall: a particle created half a radius into the
    plate stays put, and pushed 1 % of a radius further in it is pushed back out."""
    r = 1e-3
    xy = np.array(PLACES[place]) * r / R
    sim = Simulation(MESH_SPEC, ore_table(), x=[[xy[0], xy[1], 0.5 * r]], radius=[r],
                     material="ore", gravity=(0, 0, 0), breakage=TavaresModel({"ore": (5.0, 0.0)}),
                     guards=Guards(max_overlap=0.9), walls=[floor(True)])
    sim.breakage.mark_creation_overlaps([0])
    sim.run(100, chunk=100)
    assert np.abs(sim.particles.v).max() == 0.0
    sim.particles.x[0, 2] -= 0.01 * r
    sim.run(1, chunk=1)
    assert sim.particles.v[0, 2] > 0


def test_progeny_of_a_replacement_on_the_mesh_start_as_on_the_analytic_plane():
    """A 5.5 mm copper-ore sphere thrown at 8 m/s breaks on the plate near its largest overlap
    (TavaresReplacement, same seed; this draw puts a progeny sphere 1.2 % of its radius into the
    plate): the progeny touching the plate get the analytic plane's creation overlap as their
    reference (that is r - z, checked here), and to step 3700 (~260 after the replacement) they move
    as on the analytic plane. Without the reference the one reaching into the plate is pushed
    off it by its creation overlap."""
    from millsim.models.breakage.replacement import TavaresReplacement
    from millsim.models.breakage.tavares_engine import REF
    from millsim.models.breakage.tavares_materials import load_materials

    mats = load_materials(truncation="single_particle")
    ore, steel = mats["copper_ore"], mats["steel"]
    table = MaterialTable([Material("copper_ore", ore.density, ore.young, ore.poisson),
                           Material("steel", steel.density, steel.young, steel.poisson)],
                          {"*": Interaction(restitution=0.39, friction=0.5)})
    v0 = 8.0
    out = []
    for meshed in (False, True):
        replace = TavaresReplacement({"copper_ore": ore}, d_min=0.05 * R, seed=3)
        sim = throw(meshed, table, "copper_ore", PLACES["interior"], v0, 24.0,  # J/kg (of ~26)
                    smallest_radius=0.025 * R)
        seen = {}

        def on_events(s, meshed=meshed, replace=replace, seen=seen):
            replace(s)
            if "ke" not in seen:  # the progeny as created
                hist = s.mesh_hist if meshed else s.wall_hist
                seen["ref"] = hist[:, :, s.layout.spring + REF].max(axis=1)
                seen["ke"] = s.kinetic_energy()
                seen["z"] = s.particles.x[:, 2] - s.particles.radius

        sim.run(3700, chunk=500, on_events=on_events)  # it breaks at step ~3400 (dt 6e-9 s)
        assert "ke" in seen
        out.append((sim.n_particles, seen["ref"], sim.particles.x.copy(), sim.kinetic_energy(),
                    seen["ke"], seen["z"]))
    (n_a, ref_a, x_a, ke_a, ke0_a, z), (n_m, ref_m, x_m, ke_m, ke0_m, _) = out
    assert n_m == n_a > 1
    touching = z < 0  # reaching into the plane z = 0 by -z
    assert touching.any()  # the test can tell
    assert ref_a == pytest.approx(np.where(touching, -z, 0.0), rel=1e-12, abs=0.0)
    assert ref_m == pytest.approx(ref_a, rel=1e-12, abs=0.0)
    assert ke0_m == pytest.approx(ke0_a, rel=1e-12)
    assert ke_m == pytest.approx(ke_a, rel=1e-6)
    assert np.abs(x_m - x_a).max() < 1e-9 * R
