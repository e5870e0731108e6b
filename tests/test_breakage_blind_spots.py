"""Blind spots of the pure-Python Tavares modules (issue 47, sampled mutants of seed 51).

Each test stands for one class of mechanical mutant that survived every other test of
src/millsim/models/breakage (tavares, tavares_predictions, tavares_materials, progeny_families,
progeny_placement, replacement). Expected values come from closed forms (Tavares et al. 2021
eqs 1-13 as written in docs/tavares.md), conservation laws (progeny mass = parent mass) or a
computation written here, never from the code under test.
"""

import math

import numpy as np
import pytest
from scipy import special

from millsim.models.breakage import progeny_families as pf
from millsim.models.breakage import tavares as tv

# a made-up breakable material: round numbers so every closed form below is easy to write
ORE = tv.TavaresMaterial(
    name="ore", density=2500.0, young=50e9, poisson=0.25, E_inf=200.0, d0=0.01, phi=1.0,
    sigma=0.8, Emax_over_E50=10.0, gamma=5.0, A=60.0, b_prime=0.03,
    alpha_n=tuple(a for a, _ in tv.TABLE1_AVERAGE), beta_n=tuple(b for _, b in tv.TABLE1_AVERAGE))


# ---- tavares: the truncated family's smallest size, the ends of the quantile function ---------

def test_truncated_family_needs_four_classes_down_to_half_the_parent():
    """docs/tavares.md section 8: with policy "truncate" a parent breaks only if at least 4
    classes (down to 2^(-4/4) = 1/2 of it) stay at or above d_min. Classes that fit:
    floor(4 log2(d/d_min)) (the 2^(1/4) series), capped at K = 9."""
    d_min = 1e-3
    for k in range(1, 12):
        d = d_min * 2.0 ** (k / 4.0) * (1 + 1e-12)  # exactly k classes fit (k-th lands on d_min)
        want = min(k, 9) if k >= 4 else 0
        assert pf.family_classes_for(ORE, d, d_min, "truncate") == want, k
        assert pf.is_breakable(ORE, d, d_min, "truncate") is (k >= 4)
    # the standard policy needs the whole family: 0.21 d >= d_min, i.e. 9 classes
    assert pf.family_classes_for(ORE, d_min * 2 ** (9 / 4) * (1 + 1e-12), d_min) == 9
    assert pf.family_classes_for(ORE, d_min * 2 ** (8 / 4), d_min) == 0


def test_fracture_energy_quantile_at_the_ends_of_the_unit_interval():
    """Inverse of eqs 1-2, E = E* Emax/(Emax + E*) with E* = E50 exp(sigma z): u is clipped to
    [1e-16, 1 - 1e-16], so u = 0 and u = 1 (and beyond) still give a finite E in (0, Emax), the
    same as the clipped ends."""
    E50, Emax, s = 100.0, 400.0, 0.8
    z_top = special.ndtri(1.0 - 1e-16)  # about 8.2 standard deviations
    es_top = E50 * math.exp(s * z_top)
    top = es_top * Emax / (Emax + es_top)
    for u in (1.0, 1.5):
        e = float(tv.truncated_lognormal_ppf(u, E50, Emax, s))
        assert math.isfinite(e) and 0.0 < e < Emax
        assert e == pytest.approx(top, rel=1e-12)
    es_low = E50 * math.exp(s * special.ndtri(1e-16))
    for u in (0.0, -0.5):
        assert float(tv.truncated_lognormal_ppf(u, E50, Emax, s)) == pytest.approx(
            es_low * Emax / (Emax + es_low), rel=1e-12)



# ---- progeny_placement: candidate points, the frame of the load, the bias, the relaxation -------

def test_candidate_points_are_the_centre_a_unit_sphere_and_a_uniform_ball():
    """docs/tavares.md section 9: 769 fixed points, the centre, 384 directions on the unit sphere
    and 384 points inside. Uniform in the ball means a fraction q^3 of them within radius q (the
    cube-root radii of a uniform variable); the directions cover the sphere (none farther than
    the ~10 degree spacing of 384 points, sqrt(4 pi / 384) rad, from a random direction)."""
    from millsim.models.breakage import progeny_placement as pp

    ball = pp._BALL
    assert ball.shape == (769, 3)
    assert np.all(ball[0] == 0.0)
    np.testing.assert_allclose(np.linalg.norm(ball[1:385], axis=1), 1.0, rtol=1e-12)
    radius = np.linalg.norm(ball[385:], axis=1)
    assert radius.max() < 1.0
    for q in (0.3, 0.5, 0.7, 0.9):
        assert np.mean(radius < q) == pytest.approx(q**3, abs=2.0 / 384)
    rng = np.random.default_rng(7)
    v = rng.normal(size=(3000, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    nearest = np.arccos(np.clip((v @ ball[1:385].T).max(axis=1), -1.0, 1.0))  # angle [rad]
    assert nearest.max() < math.sqrt(4 * math.pi / 384)


@pytest.mark.parametrize("direction", [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (-1, 1, 0),
                                       (1, 1, 1), (0.3, -2.0, 0.5), (0, 0, -4)])
def test_frame_is_right_handed_orthonormal_with_the_load_first(direction):
    """_frame(s, spin): rows (s/|s|, e1, e2) orthonormal and right-handed for any load direction
    (also along x, along a diagonal, or not of unit length); spin turns e1, e2 about s by 2 pi
    spin, so a quarter turn takes e1 to e2 and a whole turn changes nothing."""
    from millsim.models.breakage import progeny_placement as pp

    s = np.asarray(direction, float) / np.linalg.norm(direction)
    for spin in (0.0, 0.3, 0.25, 0.9):
        f = pp._frame(direction, spin)
        assert np.all(np.isfinite(f))
        np.testing.assert_allclose(f @ f.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(f) == pytest.approx(1.0, abs=1e-12)
        np.testing.assert_allclose(f[0], s, atol=1e-12)
    f0, f4, f1 = pp._frame(direction, 0.0), pp._frame(direction, 0.25), pp._frame(direction, 1.0)
    np.testing.assert_allclose(f4[1], f0[2], atol=1e-12)
    np.testing.assert_allclose(f4[2], -f0[1], atol=1e-12)
    np.testing.assert_allclose(f1, f0, atol=1e-12)
    t = 2 * math.pi * 0.3
    np.testing.assert_allclose(pp._frame(direction, 0.3)[1],
                               math.cos(t) * f0[1] + math.sin(t) * f0[2], atol=1e-12)


def test_a_lone_fine_sits_on_the_load_axis_and_a_lone_coarse_piece_across_it():
    """The placement bias (docs/tavares.md section 9): a fragment below 0.3 R leans towards the
    load axis, so alone it goes as far along it as it fits, |c| = 1 - r (up to the spacing of the
    candidate directions, z = 1 - 1/384 at the pole); one above 0.3 R keeps off the axis (the
    centre, which has no axial offset, is a candidate)."""
    from millsim.models.breakage import progeny_placement as pp

    c = pp.place_fragments([0.1])[0]
    assert abs(c[0]) == pytest.approx(0.9 * (1 - 1 / 384), rel=1e-9)
    c = pp.place_fragments([0.45])[0]
    assert c[0] == 0.0


def test_two_half_size_fragments_end_touching_along_a_diameter():
    """Two spheres of radius R/2 fit in a sphere of radius R only end to end through its centre:
    the relaxation must reach |c1 - c2| = R with both still inside (|c| + r <= R)."""
    from millsim.models.breakage import progeny_placement as pp

    c = pp.place_fragments([0.5, 0.5])
    assert np.linalg.norm(c[0] - c[1]) == pytest.approx(1.0, abs=1e-4)
    assert np.all(np.linalg.norm(c, axis=1) + 0.5 <= 1.0 + 1e-12)


def test_fines_placed_one_after_another_do_not_overlap_without_relaxation():
    """Two fragments of R/4 both lean to the load axis; the second must take the free end of it
    (the least overlap with the first), not the occupied one: 2 r = 0.5 <= their distance."""
    from millsim.models.breakage import progeny_placement as pp

    c = pp.place_fragments([0.25, 0.25], relax=0)
    assert np.linalg.norm(c[0] - c[1]) >= 0.5


# ---- progeny_families: exact fills, what may break ---------------------------------------------

@pytest.mark.parametrize("counts", [
    {4: 8},  # eight spheres of d/2: (1/2)^3 x 8 = 1
    {4: 1, 8: 56},  # one d/2 and 56 of d/4: 1/8 + 56/64 = 1
    {4: 3, 8: 40},  # 3/8 + 40/64 = 1
])
def test_a_family_that_fills_its_parent_exactly_keeps_every_size(counts):
    """Class k holds fragments of diameter 2^(-k/4) d (Tavares et al. 2021, Table 2); counts whose
    volumes add up to the parent's exactly leave no room for a dummy sphere, and closing the
    mass must then change no fragment (sum d^3 = 1 already)."""
    edges = tv.SIEVE_RATIO ** -np.arange(10.0)
    n = np.zeros(9, dtype=np.int64)
    for k, c in counts.items():
        n[k - 1] = c
    want = np.repeat([2.0 ** (-k / 4) for k in range(1, 10)], n)
    assert float(np.sum(want**3)) == pytest.approx(1.0, abs=1e-15)
    cls, d, nd, _ = pf._close_family(n, edges)
    assert nd == 0
    np.testing.assert_allclose(np.sort(d)[::-1], want, rtol=1e-12)
    assert float(np.sum(d**3)) == pytest.approx(1.0, rel=1e-12)


def test_a_material_that_never_breaks_is_never_breakable():
    """is_breakable: only a breakable material may break, whatever its size (steel balls of any
    size stay whole); a breakable one needs its whole family (0.21 d) at or above d_min."""
    steel = tv.TavaresMaterial(name="steel", density=7800.0, young=210e9, poisson=0.3)
    for d in (1e-3, 0.05, 1.0):
        assert pf.is_breakable(steel, d, 0.0) is False
        assert pf.is_breakable(steel, d, 1e-4) is False
    assert pf.is_breakable(ORE, 0.05, 0.05 * 2 ** (-9 / 4) * (1 - 1e-9)) is True
    assert pf.is_breakable(ORE, 0.05, 0.05 * 2 ** (-9 / 4) * 1.001) is False


# ---- replacement: fresh handlers, sieve edges, fracture energies -------------------------------

def test_a_fresh_handler_has_replaced_nothing():
    """Before its first call a TavaresReplacement has broken no particle and kept no tags."""
    from millsim.models.breakage.replacement import TavaresReplacement

    h = TavaresReplacement({"ore": ORE}, d_min=1e-3)
    assert len(h.last_broken) == 0 and h.last_broken.dtype == np.int64
    assert h.last_parent_tags == {} and h.events == [] and h.records == []
    assert h.fines_mass == 0.0


def test_a_sphere_the_size_of_a_sieve_is_retained_on_it():
    """product_passing ("keep"): a sphere passes a sieve only if smaller than it; one of exactly
    the sieve's size, or smaller only by round-off (1e-12), is retained (Table 2 convention of
    Tavares et al. 2021: a fragment of size x_k is retained on x_k); 1e-6 smaller passes."""
    from millsim.models.breakage.replacement import product_passing

    s = 2.0e-3
    sizes = np.array([s, s * (1 - 1e-12), s * (1 - 1e-6), 0.5 * s, 3 * s])
    masses = np.array([1.0, 2.0, 4.0, 8.0, 16.0])
    got = product_passing(sizes, masses, np.full(5, np.inf), ORE, [s, 4 * s], unbreakable="keep")
    np.testing.assert_allclose(got, [4.0 + 8.0, 31.0], rtol=0, atol=0)


def _fake_sim(material_names, material_index, radius):
    """The little of a Simulation that assign_fracture_energies reads and writes."""
    from types import SimpleNamespace

    n = len(radius)
    return SimpleNamespace(
        particles=SimpleNamespace(material=np.asarray(material_index), radius=np.asarray(radius)),
        table=SimpleNamespace(materials=[SimpleNamespace(name=m) for m in material_names]),
        breakage=SimpleNamespace(e_frac=np.zeros(n), break_at_end=np.zeros(n, bool)))


def test_fresh_fracture_energies_follow_eqs_1_to_3_for_the_particle_size():
    """assign_fracture_energies: a breakable particle of diameter d = 2 r gets E drawn from the
    truncated lognormal of eqs 1-3 at that d (Kolmogorov-Smirnov against the closed-form CDF
    written here); a material that never breaks, or one the handler does not know, gets
    E = inf. The size decides break_at_end: resolved-unbreakable sizes (0.21 d < d_min) break
    only at the end of an event."""
    from scipy import stats

    from millsim.models.breakage.replacement import TavaresReplacement

    steel = tv.TavaresMaterial(name="steel", density=7800.0, young=210e9, poisson=0.3)
    r = 0.01
    n = 400
    sim = _fake_sim(["ore", "steel", "glass"], [0] * n + [1, 2], [r] * n + [r, r])
    h = TavaresReplacement({"ore": ORE, "steel": steel}, d_min=1e-3, seed=11)
    h.assign_fracture_energies(sim, np.arange(n + 2))
    e = sim.breakage.e_frac
    assert np.all(np.isinf(e[n:]))
    assert not sim.breakage.break_at_end[:n].any()  # 0.21 x 20 mm > 1 mm: breaks at first reach

    d = 2 * r
    k_p = ORE.young / (1 - ORE.poisson**2)
    k_s = 210e9 / (1 - 0.3**2)
    e50 = k_s / (k_p + k_s) * ORE.E_inf * (1 + ORE.d0 / d)  # eq 3, phi = 1, stress-vs-steel basis
    emax = ORE.Emax_over_E50 * e50

    def cdf(E):  # eqs 1-2
        E = np.asarray(E, float)
        return special.ndtr(np.log(E * emax / (emax - E) / e50) / ORE.sigma)

    assert np.all((e[:n] > 0) & (e[:n] < emax))
    assert stats.kstest(e[:n], cdf).pvalue > 1e-3

    sim = _fake_sim(["ore"], [0], [r])
    TavaresReplacement({"ore": ORE}, d_min=0.5 * d).assign_fracture_energies(sim, [0])
    assert sim.breakage.break_at_end[0] and np.isfinite(sim.breakage.e_frac[0])




def test_a_fragment_the_size_of_a_sieve_is_retained_on_it():
    """FamilyTable.passing: a sphere passes x only if smaller than x (Tavares et al. 2021, Table 2:
    a fragment of size x_k is retained on x_k), dummies pass every x >= x_min. A table written
    by hand: eight spheres of d/2 (sum d^3 = 1), or two of d/2 and 48 dummies of d/4."""
    table = pf.FamilyTable(
        t10=3.0, edges=np.array([1.0]), target=np.array([1.0]), counts=np.zeros((2, 1), int),
        dummy_counts=np.array([0, 48]), diameters=(np.full(8, 0.5), np.full(2, 0.5)),
        dummy_diameter=np.array([0.25, 0.25]), fractions=np.zeros((2, 2)),
        probabilities=np.array([0.25, 0.75]))
    got = table.family_passing([0.25, 0.5, 0.5 * (1 + 1e-12)])
    np.testing.assert_allclose(got, [[0.0, 0.0, 1.0], [0.75, 0.75, 1.0]], rtol=1e-15)
    np.testing.assert_allclose(table.passing([0.5, 0.6]), [0.75 * 75.0, 100.0], rtol=1e-15)


@pytest.mark.parametrize("n_classes", [2, 3])
def test_families_of_few_classes_build_and_conserve_mass(n_classes):
    """Every family_classes the materials file allows ([2, 20]) builds a table whose families
    each fill the parent exactly, sum d^3 + n_dummy d_dummy^3 = 1, with probabilities summing
    to 1, and whose mean reproduces eq 10's class fractions (fit_error is round-off)."""
    table = pf.generate_families(3.5, tv.TABLE1_AVERAGE, n_classes=n_classes)
    assert len(table.edges) == n_classes + 1
    assert table.probabilities.sum() == pytest.approx(1.0, rel=1e-12)
    for d, nd, dd in zip(table.diameters, table.dummy_counts, table.dummy_diameter):
        assert float(np.sum(d**3) + nd * dd**3) == pytest.approx(1.0, rel=1e-12)
    edges = 2.0 ** (-np.arange(n_classes + 1) / 4)
    p = tv.cumulative_passing(3.5, edges, tv.TABLE1_AVERAGE) / 100  # eq 10 at the class edges
    np.testing.assert_allclose(table.fitted, [*(p[:-1] - p[1:]), p[-1]], atol=1e-6)


def test_one_class_is_refused_where_it_would_make_a_broken_particle_its_own_copy():
    """family_classes = 1 cannot close a family holding the class-1 fragment (2^(-3/4) = 0.595 of
    the volume; the rest, 0.405, is less than one dummy sphere of x_min = 0.841, also 0.595), so
    the only family would be one dummy the parent's size: a broken particle an unbreakable copy
    of itself. The family builder refuses it (the materials file too: tests/test_materials_file.py)."""
    with pytest.raises(ValueError, match="n_classes must be at least 2, got 1"):
        pf.generate_families(3.5, tv.TABLE1_AVERAGE, n_classes=1)


def test_a_target_outside_the_families_hull_gets_the_closest_mixture():
    """Issue 47, seed 53 (`progeny_families:210`): when no mixture of the candidate families
    meets the target exactly (the linear programme is infeasible), ``_fit_probabilities`` falls
    back to the closest mixture. Four families of three classes and a target coarser than any:
    the closest mixture, found here by SLSQP with the sum as an exact constraint, is family 0
    alone (its distance 0.14, by hand: 0.3^2 + 0.2^2 + 0.1^2). The fallback holds the sum by a
    penalty, so it may miss by a little: within 1e-3 in the sum and in each class."""
    from scipy import optimize

    F = np.array([[0.5, 0.3, 0.2], [0.2, 0.5, 0.3], [0.1, 0.2, 0.7], [0.4, 0.4, 0.2]])
    target = np.array([0.8, 0.1, 0.1])
    exact = optimize.minimize(lambda q: ((q @ F - target) ** 2).sum(), np.full(4, 0.25),
                              bounds=[(0.0, None)] * 4, method="SLSQP", options=dict(ftol=1e-15),
                              constraints=[{"type": "eq", "fun": lambda q: q.sum() - 1.0}]).x
    np.testing.assert_allclose(exact, [1.0, 0.0, 0.0, 0.0], atol=1e-8)
    assert ((exact @ F - target) ** 2).sum() == pytest.approx(0.14, rel=1e-9)
    p = pf._fit_probabilities(F, target)
    assert (p >= 0).all()
    assert p.sum() == pytest.approx(1.0, abs=1e-3)
    np.testing.assert_allclose(p @ F, exact @ F, atol=1e-3)
    np.testing.assert_allclose(p, exact, atol=1e-3)
