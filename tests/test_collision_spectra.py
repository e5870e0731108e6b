"""Collision energy spectra (issue 52, item 3; engine.spectra): each collision's dissipated normal
and tangential energy, counted per contact type in log-spaced bins when the contact ends.

References: closed forms of a head-on and a sliding oblique collision (the momentum the spheres
exchanged, measured from their velocities), the energy audit (closed + open collisions add up to
its contact terms) and the kinetic energy lost. Every case runs the one compiled variant of this
file (a far mesh plate keeps the wall bundle's type where a case needs no mesh).
"""

import math
import re
from pathlib import Path

import numpy as np
import pytest

import millsim.engine.simulation as simulation
from millsim.engine import PhysicsSpec, Simulation, StepPolicy
from millsim.engine.mesh_io import box_mesh
from millsim.engine.spectra import SpectraBins
from millsim.models import Interaction, Material, MaterialTable
from millsim.util import checkpoint

ORE, STEEL = 0, 1
SPEC = PhysicsSpec(dim=3, gravity=False, walls=True, mesh_walls=True, energy_audit=True,
                   collision_spectra=True)
BINS = SpectraBins(lo=1e-12, hi=1e-2, n=30)  # three bins a decade
R = 1e-3


def table(restitution=0.5, friction=0.0, stiffness=1e6):
    return MaterialTable([Material("ore", 2700.0), Material("steel", 7800.0)],
                         {"*": Interaction(restitution=restitution, friction=friction,
                                           normal_stiffness=stiffness)}, "linear_history")


def mesh_plate(lo, hi, material):
    vertices, faces = box_mesh(lo, hi)
    return dict(kind="mesh", vertices=vertices, faces=faces, material=material)


FAR_PLATE = mesh_plate((-0.01, -0.01, -1.002), (0.01, 0.01, -1.0), "steel")


def build(x, material, v, walls=(FAR_PLATE,), dt=2e-8, bins=BINS, **interaction):
    return Simulation(SPEC, table(**interaction), x=np.asarray(x, float),
                      radius=np.full(len(x), R), material=material, v=np.asarray(v, float),
                      walls=list(walls), step=StepPolicy(dt=dt), spectra=bins)


def bin_of(energy):
    """The bin holding ``energy`` by the edges, with the energy well inside it (so that a
    numerical result a few 1e-3 off cannot cross an edge)."""
    edges = BINS.edges
    k = int(np.searchsorted(edges, energy))
    assert 1 <= k <= BINS.n and edges[k - 1] * 1.02 < energy < edges[k] / 1.02
    return k


def reduced_mass(sim, i, j):
    m = sim.masses()
    return m[i] * m[j] / (m[i] + m[j])


def test_head_on_pair_is_one_collision_in_the_bin_of_its_analytic_loss():
    e, v = 0.5, 0.5
    sim = build([[0, 0, 0], [2.005e-3, 0, 0]], ["ore", "steel"], [[v, 0, 0], [-v, 0, 0]])
    sim.run(2000)  # they touch at step ~250 for ~450 steps
    s = sim.collision_spectra()
    mu = reduced_mass(sim, 0, 1)
    analytic = (1.0 - e * e) * mu * (2 * v) ** 2 / 2
    expected = np.zeros((2, 2, BINS.n + 2), np.int64)
    expected[ORE, STEEL, bin_of(analytic)] = 1
    assert (s.pair_normal == expected).all()
    expected[ORE, STEEL] = 0
    expected[ORE, STEEL, 0] = 1  # no friction: nothing tangential, the underflow bin
    assert (s.pair_tangential == expected).all()
    assert s.wall_normal.sum() == 0 and s.wall_tangential.sum() == 0
    assert s.pair_energy[ORE, STEEL, 0] == pytest.approx(analytic, rel=2e-3)
    assert s.pair_energy[ORE, STEEL, 1] == 0.0
    # the kinetic energy lost (to the audit's own time discretisation, 4e-5 here), and the
    # audit, which integrates the same powers
    lost = 0.5 * (sim.masses()[0] + sim.masses()[1]) * v * v - sim.kinetic_energy()
    assert s.pair_energy[ORE, STEEL, 0] == pytest.approx(lost, rel=2e-4)
    assert s.pair_energy[ORE, STEEL, 0] == pytest.approx(
        sim.energy_audit()["contact_normal_damping"], rel=1e-12)
    assert s.open_normal == 0.0 and s.open_tangential == 0.0


@pytest.mark.parametrize("hi_over_loss, expected_bin", [(0.5, 5), (1.5, 4)])
def test_the_highest_bins_a_collision_can_reach(hi_over_loss, expected_bin):
    """Four bins from loss/100 to hi: the head-on pair's loss (1 - e^2) mu (2 v)^2 / 2, from the
    spheres' densities, lands in the overflow bin (5) when hi is half of it and in the last
    regular bin (4) when hi is 1.5 times it."""
    e, v = 0.5, 0.5
    m_ore, m_steel = (rho * 4.0 / 3.0 * math.pi * R ** 3 for rho in (2700.0, 7800.0))
    loss = (1.0 - e * e) * m_ore * m_steel / (m_ore + m_steel) * (2 * v) ** 2 / 2
    bins = SpectraBins(lo=loss / 100.0, hi=hi_over_loss * loss, n=4)
    sim = build([[0, 0, 0], [2.005e-3, 0, 0]], ["ore", "steel"], [[v, 0, 0], [-v, 0, 0]],
                bins=bins)
    sim.run(2000)
    s = sim.collision_spectra()
    expected = np.zeros((2, 2, bins.n + 2), np.int64)
    expected[ORE, STEEL, expected_bin] = 1
    assert (s.pair_normal == expected).all()


def test_oblique_sliding_pair_loses_the_closed_form_tangential_energy():
    """Gross sliding throughout: the slip speed falls linearly with the normal impulse J, at
    (7/2)(1/m1 + 1/m2) mu per unit J for solid spheres, so friction dissipates
    mu u0 J - (7/4) mu^2 (1/m1 + 1/m2) J^2 (u0: the initial slip speed). A stiff contact (1 us),
    so that the normal turns little while the spheres slide past each other (1e-3 rad)."""
    vn, vt, friction = 0.3, 1.0, 0.3
    sim = build([[0, 0, 0], [2.0005e-3, 0, 0]], ["steel", "ore"], [[vn, vt, 0], [-vn, -vt, 0]],
                dt=2e-9, friction=friction, stiffness=1e8)
    sim.run(2000)  # they touch at step ~420 for ~450 steps
    s = sim.collision_spectra()
    m = sim.masses()
    mu = reduced_mass(sim, 0, 1)
    jn = mu * (2 * vn + sim.particles.v[1, 0] - sim.particles.v[0, 0])  # the normal impulse
    inv = 1.0 / m[0] + 1.0 / m[1]
    u0 = 2 * vt
    assert u0 - 3.5 * inv * friction * jn > 0.3 * u0  # still sliding at the end
    tangential = friction * u0 * jn - 1.75 * friction ** 2 * inv * jn ** 2
    assert s.pair_collisions[ORE, STEEL] == 1 and s.pair_collisions.sum() == 1
    assert s.pair_energy[ORE, STEEL, 1] == pytest.approx(tangential, rel=2e-3)
    assert s.pair_tangential[ORE, STEEL, bin_of(tangential)] == 1
    print("tangential against the closed form, relative:",
          s.pair_energy[ORE, STEEL, 1] / tangential - 1)
    lost = 0.5 * (m[0] + m[1]) * (vn * vn + vt * vt) - sim.kinetic_energy()
    assert s.pair_energy[ORE, STEEL].sum() == pytest.approx(lost, rel=2e-4)
    # The audit splits the friction's power at the centres' slip and at the spins' share of the
    # surface slip: the latter is the power the torques put into spin, so its term is minus the
    # spin energy the spheres gained from rest, and the normal damping and the centre-slip term
    # are the translational energy lost (measured 3e-6 and 1e-6 off: the audit's quadrature).
    audit, p = sim.energy_audit(), sim.particles
    spin = 0.5 * (0.4 * m * p.radius ** 2 * (p.w ** 2).sum(1)).sum()
    translation = 0.5 * (m[0] + m[1]) * (vn * vn + vt * vt) - 0.5 * (m * (p.v ** 2).sum(1)).sum()
    assert spin > 0.05 * lost
    assert audit["contact_tangential_rotation"] == pytest.approx(-spin, rel=1e-4)
    assert (audit["contact_normal_damping"] + audit["contact_tangential_translation"]
            == pytest.approx(translation, rel=1e-4))


def test_bounces_on_a_plane_and_on_a_meshed_plate_go_to_the_wall_table():
    """An ore sphere falls on a steel plane and a steel sphere rises into an ore mesh plate above
    it, head-on at v: one collision each, of types (ore, steel) and (steel, ore), each in the bin
    of (1 - e^2) m v^2 / 2."""
    e, v = 0.5, 0.5
    walls = [dict(kind="plane", point=(0, 0, 0), normal=(0, 0, 1), material="steel"),
             mesh_plate((0.01, -0.01, 0.005), (0.03, 0.01, 0.007), "ore")]
    sim = build([[0, 0, 1.005e-3], [0.02, 0, 0.005 - 1.005e-3]], ["ore", "steel"],
                [[0, 0, -v], [0, 0, v]], walls=walls)
    sim.run(3000)  # they touch at step ~250, the steel sphere for ~900 steps
    s = sim.collision_spectra()
    m = sim.masses()
    assert s.pair_normal.sum() == 0
    expected = np.zeros((2, 2, BINS.n + 2), np.int64)
    for i, (a, b) in enumerate([(ORE, STEEL), (STEEL, ORE)]):
        analytic = (1.0 - e * e) * m[i] * v * v / 2
        expected[a, b, bin_of(analytic)] = 1
        assert s.wall_energy[a, b, 0] == pytest.approx(analytic, rel=2e-3)
    assert (s.wall_normal == expected).all()
    assert s.wall_tangential[:, :, 0].sum() == 2 and s.wall_tangential.sum() == 2


def gas(seed=3, n=300, side=0.02):
    """Spheres of both materials in a box of steel planes, the floor turning about its normal,
    under an ore mesh lid, with random velocities: many pair, wall and mesh collisions."""
    rng = np.random.default_rng(seed)
    g = np.stack(np.meshgrid(*[np.arange(7)] * 3, indexing="ij"), -1).reshape(-1, 3)[:n]
    x = (g + 0.5) * side / 7 + rng.uniform(-2e-4, 2e-4, (n, 3))
    walls = [dict(kind="plane", point=(side / 2, side / 2, 0), normal=(0, 0, 1), omega=60.0,
                  material="steel")]
    walls += [dict(kind="plane", point=p, normal=nv, material="steel") for p, nv in
              [((0, 0, 0), (1, 0, 0)), ((side, 0, 0), (-1, 0, 0)), ((0, 0, 0), (0, 1, 0)),
               ((0, side, 0), (0, -1, 0))]]
    walls.append(mesh_plate((-0.005, -0.005, side), (side + 0.005, side + 0.005, side + 0.003),
                            "ore"))
    material = np.where(rng.random(n) < 0.5, "ore", "steel")
    return build(x, material, rng.normal(0, 0.6, (n, 3)), walls=walls, dt=2e-6,
                 restitution=0.7, friction=0.3, stiffness=1e4)


def closed_and_open(sim):
    s = sim.collision_spectra()
    closed = s.pair_energy.sum(axis=(0, 1)) + s.wall_energy.sum(axis=(0, 1))
    return s, closed + np.array([s.open_normal, s.open_tangential])


def audited(sim):
    audit = sim.energy_audit()
    return np.array([audit["contact_normal_damping"], audit["contact_tangential_translation"]
                     + audit["contact_tangential_rotation"]])


def check_bins_hold_their_energies(s):
    """Per type, the binned energy lies between the lower and upper edges of its counts' bins
    (underflow: between 0 and lo; overflow: at least hi)."""
    lower = np.concatenate([[0.0], BINS.edges])
    upper = np.concatenate([BINS.edges, [np.finfo(float).max]])  # 0 x inf would be NaN
    for counts, energy in ((s.pair_normal, s.pair_energy[..., 0]),
                           (s.pair_tangential, s.pair_energy[..., 1]),
                           (s.wall_normal, s.wall_energy[..., 0]),
                           (s.wall_tangential, s.wall_energy[..., 1])):
        assert ((counts * lower).sum(-1) <= energy * (1 + 1e-12)).all()
        assert (energy <= (counts * upper).sum(-1) * (1 + 1e-12)).all()


def test_gas_spectra_add_up_to_the_audit_and_types_are_as_declared():
    sim = gas()
    sim.run(3000, chunk=1000)
    # particles removed in contact: their open collisions are counted at the removal
    i, j, _ = sim.contact_pairs()
    assert len(i) > 0
    removed = np.zeros(sim.n_particles, bool)
    removed[i[:3]] = True
    before = sim.collision_spectra().pair_collisions.sum()
    sim.remove_particles(removed)
    assert sim.collision_spectra().pair_collisions.sum() >= before + 3
    sim.run(2000, chunk=1000)
    # a wall taken away and put back: its contacts' collisions end there
    sim.disable_wall(1)
    sim.enable_wall(1)
    sim.run(2000, chunk=1000)
    s, total = closed_and_open(sim)
    audit = audited(sim)
    assert s.pair_collisions.sum() > 200 and s.wall_collisions[:, STEEL].sum() > 20
    assert s.wall_collisions[:, ORE].sum() > 5  # the mesh lid
    assert s.open_normal > 0.0  # contacts still open at the end
    print("closed + open vs audit, relative:", (total - audit) / audit)
    np.testing.assert_allclose(total, audit, rtol=1e-12)
    # types: pairs (a, b) with a <= b only; walls by the wall's material
    assert s.pair_normal[STEEL, ORE].sum() == 0 and s.pair_energy[STEEL, ORE].sum() == 0
    assert (s.pair_normal[ORE, STEEL].sum() > 0 and s.pair_normal[ORE, ORE].sum() > 0
            and s.pair_normal[STEEL, STEEL].sum() > 0)
    assert (s.pair_normal.sum(-1) == s.pair_tangential.sum(-1)).all()
    check_bins_hold_their_energies(s)


def run_gas(threads):
    sim = gas()
    sim.run(2000, chunk=700, threads=threads)
    return sim.collision_spectra()


def same(a, b):
    for name in ("pair_normal", "pair_tangential", "wall_normal", "wall_tangential",
                 "pair_energy", "wall_energy"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert (a.open_normal, a.open_tangential) == (b.open_normal, b.open_tangential)


def test_same_spectra_on_one_and_two_threads(monkeypatch):
    import numba

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("needs 2 threads")
    monkeypatch.setattr(simulation, "SERIAL_BELOW", 0)  # 300 particles: 2 blocks in parallel
    same(run_gas(1), run_gas(2))


def test_resume_from_a_checkpoint_gives_the_same_spectra(tmp_path):
    sim = gas()
    sim.run(1500, chunk=500)
    path = tmp_path / "sim.ckpt"
    checkpoint.write(path, {}, sim)
    sim.run(1500, chunk=500)
    resumed = checkpoint.read(path, lambda header: None)
    resumed.run(1500, chunk=500)
    same(sim.collision_spectra(), resumed.collision_spectra())
    assert sim.collision_spectra().pair_collisions.sum() > 0


def test_the_default_bins_are_the_documented_ones():
    """docs/engine.md states the bins a Simulation gets when none are given."""
    text = (Path(__file__).resolve().parents[1] / "docs" / "engine.md").read_text()
    lo, hi, n = re.search(r"spectra=SpectraBins\(lo=([^,]+), hi=([^,]+), n=(\d+)\)\)`\s*"
                          r"\(J; the default\)", text).groups()
    documented = SpectraBins(float(lo), float(hi), int(n))
    assert SpectraBins() == documented
    sim = Simulation(SPEC, table(), x=np.zeros((1, 3)), radius=[R], material="ore",
                     walls=[FAR_PLATE])
    assert sim.spectra_bins == documented
    assert sim.collision_spectra().pair_normal.shape == (2, 2, int(n) + 2)


def test_refusals_name_the_key():
    with pytest.raises(ValueError, match="^collision_spectra: needs energy_audit"):
        PhysicsSpec(collision_spectra=True)
    with pytest.raises(ValueError, match="^spectra: lo"):
        SpectraBins(lo=0.0)
    with pytest.raises(ValueError, match="^spectra: hi"):
        SpectraBins(lo=1.0, hi=0.5)
    with pytest.raises(ValueError, match="^spectra: n"):
        SpectraBins(n=0)
    assert math.isclose(SpectraBins(1e-3, 1e1, 4).edges[1], 1e-2)
    with pytest.raises(ValueError, match="^spectra: needs PhysicsSpec"):
        Simulation(PhysicsSpec(gravity=False), table(), x=np.zeros((1, 3)), radius=[R],
                   material="ore", spectra=BINS)
