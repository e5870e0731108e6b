"""Colour sums (PhysicsSpec.force_sum = "colour"): the colouring, the same numbers on any thread
count, the same physics as the slot records, and what the option refuses."""


import numba
import numpy as np
import pytest

from millsim.engine import PhysicsSpec, Simulation, StepPolicy
from millsim.engine.loop import BLOCK, colour_slots, touching_slots
from millsim.models import Interaction, Material, MaterialTable
from millsim.models.lubrication import Lubrication

from helpers import dense_bed


def _table(law="hertz_mindlin", **inter):
    return MaterialTable([Material("m", 2500.0, 5e6, 0.3)], {"*": Interaction(**inter)}, law)


def _pressed_gas(force_sum, law="hertz_mindlin", seed=7):
    """A periodic box of touching and nearly touching spheres of three sizes, spinning, without
    gravity: rolling friction (Hertz-Mindlin) and the normal-force sums compiled in."""
    rng = np.random.default_rng(seed)
    side = 7
    g = np.stack(np.meshgrid(*[np.arange(side)] * 3, indexing="ij"), -1).reshape(-1, 3)
    box = side * 2.0e-3
    x = (g + 0.5) * 2.0e-3 + rng.uniform(-5e-5, 5e-5, g.shape)  # overlaps below 0.25 r
    radius = rng.choice([0.95e-3, 1.0e-3, 1.05e-3], len(x))
    rolling = law == "hertz_mindlin"
    spec = PhysicsSpec(dim=3, gravity=False, periodic=True, rolling_friction=rolling,
                       normal_force_sum=True, force_sum=force_sum)
    stiffness = {} if rolling else dict(normal_stiffness=2e3)  # linear law: k_n [N/m]
    table = _table(law, restitution=0.5, friction=0.4, rolling_friction=0.1 if rolling else 0.0,
                   **stiffness)
    return Simulation(spec, table, x=x, radius=radius, material="m", v=rng.normal(0, 0.1, x.shape),
                      w=rng.normal(0, 100.0, x.shape), box=(np.zeros(3), np.full(3, box)),
                      step=StepPolicy(dt=1e-6))


@pytest.mark.parametrize("bed", ["walls", "periodic"])
def test_colouring_is_proper_and_complete(bed):
    sim = dense_bed(2600, force_sum="records") if bed == "walls" else _pressed_gas("records")
    sim.run(1)
    start, nbr = sim.contacts.start, sim.contacts.nbr
    p = sim.particles
    row_of = np.repeat(np.arange(len(start) - 1), np.diff(start))
    touching = touching_slots(start, nbr, p.x, p.radius, sim.box_len)
    # against numpy's minimum image along periodic axes
    d = p.x[row_of] - p.x[nbr]
    periodic = sim.box_len > 0
    d[:, periodic] -= sim.box_len[periodic] * np.round(d[:, periodic] / sim.box_len[periodic])
    overlap = (d ** 2).sum(axis=1) < (p.radius[row_of] + p.radius[nbr]) ** 2
    assert np.array_equal(touching, overlap) and 0 < touching.sum() < len(nbr)
    if bed == "periodic":  # pairs touching across the box's faces are among them
        raw = ((p.x[row_of] - p.x[nbr]) ** 2).sum(axis=1)
        assert (touching & (raw > (p.radius[row_of] + p.radius[nbr]) ** 2)).any()
    first, slot, owner, partner = colour_slots(start, nbr, touching)
    assert first[0] == 0 and first[-1] == len(nbr) and (np.diff(first) > 0).all()
    assert np.array_equal(np.sort(slot), np.arange(len(nbr)))  # every slot once
    assert np.array_equal(owner, row_of[slot]) and np.array_equal(partner, nbr[slot])
    for c in range(len(first) - 1):  # no particle twice in a colour
        ends = np.concatenate([owner[first[c]:first[c + 1]], partner[first[c]:first[c + 1]]])
        assert len(np.unique(ends)) == len(ends), c
        # in each block of BLOCK places: the colour's next slots, touching first, each in
        # slot order
        group = slot[first[c]:first[c + 1]]
        for lo in range(0, len(group), BLOCK):
            block = group[lo:lo + BLOCK]
            flags = touching[block]
            assert np.array_equal(np.sort(block), np.sort(group)[lo:lo + BLOCK]), c
            assert (np.diff(flags.astype(int)) <= 0).all(), c
            assert (np.diff(block[flags]) > 0).all() and (np.diff(block[~flags]) > 0).all(), c
    # greedy colouring needs at most (deg i + deg j - 1) colours over any slot
    degree = np.bincount(np.concatenate([row_of, nbr]), minlength=len(start) - 1)
    assert len(first) - 1 <= 2 * degree.max() - 1


def test_colour_sums_same_numbers_on_one_and_two_threads():
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("needs 2 threads")
    runs = []
    for threads in (1, 2):
        sim = dense_bed(2600, force_sum="colour")  # above the serial threshold: 2 threads run in parallel
        sim.run(400, chunk=200, threads=threads)
        assert sim.counters[0] > 0  # the list was rebuilt: springs went back and forth
        runs.append((sim.particles.x.copy(), sim.particles.w.copy(), sim.contacts.state.copy(),
                     [sim.impulse(wall=k) for k in range(len(sim.walls))]))
    for a, b in zip(*runs):
        np.testing.assert_array_equal(a, b)


def _agree(a, b, steps):
    for sim in (a, b):
        sim.run(steps, chunk=steps)
    pa, pb = a.particles, b.particles
    moved = np.abs(pa.x - a._x_start).max()
    # the same contacts summed in another order: rounding apart, far below the motion
    assert np.abs(pa.x - pb.x).max() < 1e-9 * moved
    assert np.abs(pa.v - pb.v).max() < 1e-9 * np.abs(pa.v).max()
    assert np.abs(pa.w - pb.w).max() < 1e-9 * np.abs(pa.w).max()
    assert np.array_equal(a.contacts.nbr, b.contacts.nbr)
    assert np.abs(a.contacts.state - b.contacts.state).max() < 1e-9 * np.abs(a.contacts.state).max()
    return pa, pb


def test_colour_sums_agree_with_records_in_a_bed_with_walls():
    a, b = dense_bed(2600, force_sum="records"), dense_bed(2600, force_sum="colour")
    for sim in (a, b):
        sim._x_start = sim.particles.x.copy()
    _agree(a, b, 200)
    impulses = [(a.impulse(wall=k), b.impulse(wall=k)) for k in range(len(a.walls))]
    for ia, ib in impulses:
        assert np.abs(np.asarray(ia) - np.asarray(ib)).max() < 1e-9 * np.abs(ia).max()


@pytest.mark.parametrize("law", ["hertz_mindlin", "linear_history"])
def test_colour_sums_agree_with_records_with_rolling_friction_and_force_sums(law):
    a, b = _pressed_gas("records", law), _pressed_gas("colour", law)
    for sim in (a, b):
        sim._x_start = sim.particles.x.copy()
    pa, pb = _agree(a, b, 300)
    assert (pa.fn_sum > 0).sum() > len(pa.fn_sum) // 4  # many particles in contact
    assert np.abs(pa.fn_sum - pb.fn_sum).max() < 1e-9 * pa.fn_sum.max()


def test_colour_sums_conserve_momentum():
    """Each contact adds the same force into both bodies with opposite signs: the total momentum
    of a periodic box without gravity stays what it was (to rounding)."""
    sim = _pressed_gas("colour")
    m = sim.masses()
    p0 = (m[:, None] * sim.particles.v).sum(0)
    scale = (m[:, None] * np.abs(sim.particles.v)).sum()
    sim.run(2000, chunk=1000)
    assert sim.counters[0] > 0
    p1 = (m[:, None] * sim.particles.v).sum(0)
    assert np.abs(p1 - p0).max() < 1e-12 * scale


def test_colour_sums_refuse_what_reads_slot_records():
    with pytest.raises(ValueError, match="force_sum: 'colour' keeps no slot records"):
        PhysicsSpec(energy_audit=True, force_sum="colour")
    with pytest.raises(ValueError, match="force_sum: must be one of"):
        PhysicsSpec(force_sum="scatter")
    spec = PhysicsSpec(dim=3, gravity=False, force_sum="colour")
    with pytest.raises(ValueError, match="which the fluid model reads"):
        Simulation(spec, _table(), x=[[0, 0, 0]], radius=[1e-3], material="m",
                   fluid=Lubrication(eta=0.1))
