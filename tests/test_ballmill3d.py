"""Scene ``ballmill3d`` (3D ball mill, STL liner or cylinder, Tavares breakage): the energy
balance and the drive's power on short runs, toe and shoulder and the selection function on
synthetic data, the liner probe against its geometry, and the refusals of bad input.

The runs use a materials file whose Young's moduli are 1000x below the shipped ones and whose
ore has E_inf = 0.2 J/kg (a test material: the step grows ~16x and particles break within a
fraction of a revolution; one feed size, the top one, so that every feed particle may break
with d_min = 0.21 of it); the physics checked (balances, P = T omega) holds for any stiffness.
"""

import math
from pathlib import Path

import numpy as np
import pytest

from millsim.engine.mesh_io import liner_mesh, write_stl
from millsim.scenes import ballmill3d_observables as obs
from millsim.scenes import load_all
from millsim.scenes.base import REGISTRY, RunContext

load_all()
SCENE = REGISTRY["ballmill3d"]
MATERIALS = Path(__file__).resolve().parents[1] / "config" / "materials.yaml"
SMALL = dict(drum_diameter=0.1, drum_length=0.03, ball_diameter_min=0.012, ball_diameter_max=0.012,
             ore_diameter_min=0.006, ore_diameter_max=0.006, filling=0.25, ball_ore_ratio=2.0,
             d_min_ratio=0.21, pour_time=0.04, settle_time=0.05, revolutions=0.45,
             transient_revolutions=0.2, records_per_revolution=20)


@pytest.fixture(scope="module")
def soft_materials(tmp_path_factory):
    text = MATERIALS.read_text()
    for stiff, soft in (("young_GPa: 52 ", "young_GPa: 0.052 "), ("young_GPa: 210 ", "young_GPa: 0.21 "),
                        ("E_inf: {J_per_kg: 213.5}", "E_inf: {J_per_kg: 0.2}")):
        assert stiff in text
        text = text.replace(stiff, soft)
    path = tmp_path_factory.mktemp("materials") / "soft.yaml"
    path.write_text(text)
    return str(path)


def _liner(path, radius=0.05, length=0.03, lifters=8, height=0.006, width=0.006):
    """A liner along y from 0 to length (tools/make_liner_stl.py's rotation)."""
    v, f = liner_mesh(radius, length, segments=96, lifters=lifters, lifter_height=height,
                      lifter_width=width)
    v = np.column_stack([v[:, 0], v[:, 2], -v[:, 1]])
    write_stl(path, v, f)
    return v, f


@pytest.fixture(scope="module")
def milled(soft_materials):
    values = SCENE.resolve(dict(SMALL, liner="", materials_file=soft_materials, breakage=True))
    ds, provenance = SCENE.run(values, RunContext())
    return values, ds, provenance


def test_drive_work_equals_dissipation_plus_energy_change_with_breakage(milled):
    """Work of shell and end walls = audited dissipation + energy removed at the replacements +
    change of kinetic, potential and elastic energy, within 2 % over the measured interval,
    while particles break (the replacements' energy is booked)."""
    _, ds, _ = milled
    assert int(ds.breakage_events) > 0
    assert abs(float(ds.energy_balance_error)) < 0.02


def test_power_is_torque_times_omega_and_the_drive_lifts_the_charge(milled):
    """P = T omega (every turning wall's torque is taken where its surface speed is), the
    critical speed is sqrt(2 g / (D - d)), and the drive supplies power (P > 0, T > 0) and
    holds the charge on the rising half of the drum (its arc against the shell, toe to
    shoulder, centred at a positive angle below pi)."""
    values, ds, _ = milled
    toe, shoulder = float(ds.toe_angle), float(ds.shoulder_angle)
    assert toe < shoulder and 0 < 0.5 * (toe + shoulder) < math.pi
    omega_c = math.sqrt(2 * 9.81 / (values["drum_diameter"] - values["ball_diameter_max"]))
    assert float(ds.critical_speed) == pytest.approx(omega_c, rel=1e-12)
    assert float(ds.omega) == pytest.approx(values["n_over_nc"] * omega_c, rel=1e-12)
    assert float(ds.power) > 0 and float(ds.torque) > 0
    assert float(ds.power) == pytest.approx(float(ds.torque) * float(ds.omega), rel=1e-6)
    series = ds["power_series"].values, ds["torque_series"].values
    assert np.allclose(series[0], series[1] * float(ds.omega), rtol=1e-6, atol=1e-12)


def test_the_step_follows_the_particles_present_and_records_keep_their_time(milled):
    """Until something breaks, the mill steps at the feed's step (as without breakage: the
    progeny's smaller step is not paid in advance); the progeny shrink it (their Hertz contact
    is shorter: t ~ r at one impact speed); the records stay a 20th of a revolution apart in
    time and the run ends after 0.45 revolutions, to within one step per record."""
    values, ds, provenance = milled
    feed = SCENE.build(values).sim.dt  # the case before its charge is poured and anything broke
    assert int(ds.breakage_events) > 0
    assert provenance["dt"] < feed / 1.5  # the smallest progeny 1.26 mm against the 6 mm feed
    omega = values["n_over_nc"] * math.sqrt(2 * 9.81 / (values["drum_diameter"]
                                                        - values["ball_diameter_max"]))
    interval = 2 * math.pi / omega / values["records_per_revolution"]
    t = ds.time.values
    assert len(t) == round(values["revolutions"] * values["records_per_revolution"])
    assert np.abs(np.diff(t, prepend=0.0) - interval).max() <= feed / 2 * (1 + 1e-9)
    assert t[-1] == pytest.approx(values["revolutions"] * 2 * math.pi / omega, abs=len(t) * feed)


def test_ore_mass_is_conserved_in_the_product_distribution(milled):
    """Resolved ore + fines = the initial ore at every record: the whole ore passes the top
    sieve (sqrt 2 x the feed's largest size), and the passing never exceeds 1."""
    _, ds, _ = milled
    pf = ds["passing_fraction"].values
    assert np.allclose(pf[:, 0], 1.0, rtol=0, atol=1e-9)
    assert (pf <= 1 + 1e-9).all() and (np.diff(pf, axis=1) <= 1e-12).all()
    assert float(ds.fines_mass) > 0


def test_spectra_hold_the_audited_contact_dissipation(milled):
    """Collision energy spectra (engine.spectra) over the measured interval: the energies of the
    collisions that ended plus the change of the open contacts' equal the energy audit's contact
    dissipation within 1 % (issue 52; the audit is the engine's, the spectra a separate
    per-contact book). Every contact type of a mill with breakage occurs, the binned rates
    never exceed the collision rates, and the energies per second stay below the drive power
    (the contacts cannot dissipate more than the drive gives, plus the charge's energy change)."""
    _, ds, _ = milled
    assert abs(float(ds.spectra_audit_error)) < 0.01
    assert list(ds.contact_type.values) == ["ball-ball", "ball-ore", "ore-ore", "ball-liner",
                                            "ore-liner"]
    assert (ds.collision_rate.values > 0).all()
    binned = ds.impact_rate_normal.sum("energy_bin").values + ds.collision_rate_below_range.values
    assert (binned <= ds.collision_rate.values * (1 + 1e-12)).all()
    edges = ds.energy_edge.values
    assert np.allclose(np.diff(np.log(edges)), np.log(edges[1] / edges[0]))
    dissipated = float(ds.collision_energy_normal.sum() + ds.collision_energy_tangential.sum())
    assert 0 < dissipated < 1.5 * float(ds.power)


def _arc(theta_toe, theta_shoulder, n=20000, rho=0.095, seed=0):
    rng = np.random.default_rng(seed)
    theta = rng.uniform(theta_toe, theta_shoulder, n)
    y = rng.uniform(0, 0.05, n)
    return np.column_stack([-rho * np.sin(theta), y, -rho * np.cos(theta)])


@pytest.mark.parametrize("toe, shoulder", [(-0.7, 2.0), (-1.3, 0.4), (0.2, 2.9)])
def test_toe_and_shoulder_of_a_synthetic_charge(toe, shoulder):
    """Particles spread evenly over a known arc of the outer band (plus a sparse cascade and
    an inner core that do not count) give its edges back to within one 5-degree sector."""
    x = _arc(toe, shoulder)
    cascade = _arc(shoulder, toe + 2 * math.pi, n=800, seed=1)  # 1/10 of the density
    core = _arc(-math.pi, math.pi, n=5000, rho=0.04, seed=2)
    pts = np.vstack([x, cascade, core])
    profile = obs.band_profile(pts, np.full(len(pts), 1e-3), 0.1, 0.02)
    got = obs.toe_shoulder(profile)
    width = 2 * math.pi / obs.ANGLE_BINS
    assert got[0] == pytest.approx(toe, abs=width) and got[1] == pytest.approx(shoulder, abs=width)
    assert all(math.isnan(a) for a in obs.toe_shoulder(np.ones(obs.ANGLE_BINS)))  # centrifuged


def test_selection_function_of_a_synthetic_event_list():
    """S_i = events of class i in [t0, t1] / (t1 - t0) / mean count of class i, counted here by
    hand; events outside the interval do not count, an empty class gives NaN."""
    lower = 0.01 * 2.0 ** (-0.5 * np.arange(1, 4))  # classes [7.07, 10], [5, 7.07], [3.54, 5] mm
    t0, t1 = 1.0, 3.0
    rng = np.random.default_rng(4)
    times = np.concatenate([rng.uniform(t0, t1, 30), rng.uniform(t0, t1, 12), [0.5, 3.5]])
    diam = np.concatenate([np.full(30, 9e-3), np.full(12, 6e-3), [9e-3, 9e-3]])
    rec_t = np.linspace(0, 4, 41)
    counts = np.column_stack([np.where(rec_t < 2, 10, 20), np.full(41, 4), np.zeros(41)])
    rate, half = obs.selection_function(times, diam, lower, t0, t1, rec_t, counts, blocks=4)
    use = (rec_t >= t0) & (rec_t <= t1)
    assert rate[0] == pytest.approx(30 / 2.0 / counts[use, 0].mean(), rel=1e-12)
    assert rate[1] == pytest.approx(12 / 2.0 / 4.0, rel=1e-12)
    assert math.isnan(rate[2]) and math.isnan(half[2]) and half[0] > 0
    assert obs.class_counts([9e-3, 7.2e-3, 6e-3, 1e-3, 12e-3], lower).tolist() == [3, 1, 0]


def test_lifter_gap_measured_by_rays_matches_the_liner_geometry(tmp_path):
    """The free chord between the lifters at half their height, from rays, against the liner's
    construction: n lifters of width w leave 2 r sin((2 pi / n - 2 asin(w / 2 r)) / 2) at radius
    r, to within the rays' angular step."""
    from millsim.scenes.ballmill3d_charge import LINER_RAYS, probe_liner

    path = tmp_path / "liner.stl"
    n, h, w = 8, 0.006, 0.006
    _liner(path, lifters=n, height=h, width=w)
    probe = probe_liner(dict(liner=str(path), liner_scale=1.0, drum_diameter=0.1, drum_length=0.03))
    assert probe.shell_radius == pytest.approx(0.05, rel=2e-3)
    assert probe.tip_radius == pytest.approx(0.05 - h, rel=2e-3)
    r = 0.05 - 0.5 * h
    expected = 2 * r * math.sin(0.5 * (2 * math.pi / n - 2 * math.asin(0.5 * w / r)))
    assert probe.lifter_gap == pytest.approx(expected, abs=2 * r * 2 * math.pi / LINER_RAYS)


def test_the_default_liner_path_builds():
    """The shipped liner (default) with the default charge: checked and built (no run)."""
    values = SCENE.resolve({"breakage": False})
    case = SCENE.build(values)
    assert case.sim.spec.mesh_walls and sum(p.count for p in case.pours) > 100


def test_liner_mill_power_and_energy_balance_without_breakage(tmp_path, soft_materials):
    """With a liner and no breakage: P = T omega and the energy balance within 2 %."""
    path = tmp_path / "liner.stl"
    _liner(path)
    values = SCENE.resolve(dict(SMALL, liner=str(path), materials_file=soft_materials,
                                breakage=False, revolutions=0.4))
    ds, _ = SCENE.run(values, RunContext())
    assert float(ds.power) > 0
    assert float(ds.power) == pytest.approx(float(ds.torque) * float(ds.omega), rel=1e-6)
    assert abs(float(ds.energy_balance_error)) < 0.02
    assert int(ds.breakage_events) == 0


def test_liner_mill_with_breakage_closes_the_energy_balance(tmp_path, soft_materials):
    """The target case: liner and Tavares breakage together (mesh slots keep the model's
    contact state, engine/loop/wall_pass.py), with the spectra's liner contacts."""
    path = tmp_path / "liner.stl"
    _liner(path)
    values = SCENE.resolve(dict(SMALL, liner=str(path), materials_file=soft_materials,
                                breakage=True))
    ds, _ = SCENE.run(values, RunContext())
    assert int(ds.breakage_events) > 0
    assert abs(float(ds.energy_balance_error)) < 0.02
    assert float(ds.power) == pytest.approx(float(ds.torque) * float(ds.omega), rel=1e-6)
    assert abs(float(ds.spectra_audit_error)) < 0.01
    assert float(ds.collision_rate.sel(contact_type="ore-liner")) > 0


# ---- bad input: one line naming the key or the file ----------------------------------------------
def _refused(match, **overrides):
    with pytest.raises((ValueError, FileNotFoundError), match=match) as info:
        SCENE.resolve(overrides)
    assert "\n" not in str(info.value)


def test_open_or_inverted_liner_is_refused_naming_the_file(tmp_path):
    v, f = liner_mesh(0.1, 0.05, segments=32)
    v = np.column_stack([v[:, 0], v[:, 2], -v[:, 1]])
    write_stl(tmp_path / "open.stl", v, f[:-4])
    write_stl(tmp_path / "inverted.stl", v, f[:, ::-1])
    _refused(r"open\.stl.*(open|boundary)", liner=str(tmp_path / "open.stl"))
    _refused(r"inverted\.stl.*invert", liner=str(tmp_path / "inverted.stl"))
    _refused(r"nothere\.stl", liner=str(tmp_path / "nothere.stl"))


def test_balls_larger_than_the_lifter_gap_are_refused(tmp_path):
    path = tmp_path / "tight.stl"
    _liner(path, lifters=16, height=0.008, width=0.008)
    common = dict(liner=str(path), drum_diameter=0.1, drum_length=0.03, ore_diameter_min=0.003,
                  ore_diameter_max=0.004)
    _refused(r"^ball_diameter_max: .*larger than the gap between the lifters .*tight\.stl",
             ball_diameter_min=0.015, ball_diameter_max=0.015, **common)
    SCENE.resolve(dict(common, ball_diameter_min=0.008, ball_diameter_max=0.008))


def test_a_filling_the_drum_cannot_hold_is_refused():
    _refused(r"^filling: 0.99 .*more than the drum holds", filling=0.99)


def test_an_ore_missing_from_the_materials_file_is_refused():
    _refused(r"^ore_material: 'unobtainium' not in .*materials\.yaml", ore_material="unobtainium",
             liner="")
    _refused(r"^ore_material: 'steel' never breaks", ore_material="steel", liner="")
