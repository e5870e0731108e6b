"""The 3D ball-mill study downstream of its case files (issue 52, item 4): the aggregate of
synthetic cases written to the scene's output contract, Morrell's references against the
formulas computed here independently, the figures, and the pipeline's targets (dry run).

No simulation: the scene's own runs are tests/test_ballmill3d.py's.
"""

import math

import numpy as np
import pytest
import xarray as xr
from matplotlib.figure import Figure

from millsim.analysis import ballmill3d as bm3
from millsim.analysis.aggregate import aggregate
from millsim.io import read_case, write_case, write_netcdf
from millsim.plots import plot

G = 9.81
D, L, BALL = 0.3, 0.15, 0.025  # drum diameter and length, ball diameter [m]
CONTACTS = ["ball-ball", "ball-ore", "ore-ore", "ball-liner", "ore-liner"]


# ---- synthetic cases -------------------------------------------------------------------------

def critical_speed():
    return math.sqrt(2 * G / (D - BALL))  # the ball radius subtracted, as the scene may do


def morrell_power_here(phi, J, diameter, length, rho):
    """Morrell's C-model net power (dry), written out from the module docstring's equations."""
    phi_c = 0.35 * (3.364 - J)
    tt = 2.5307 * (1.2796 - J) * (1 - math.exp(-19.42 * max(phi_c - phi, 0.0))) + math.pi / 2
    ts = math.pi / 2 - (tt - math.pi / 2) * ((0.3386 + 0.1041 * phi) + (1.54 - 2.5673 * phi) * J)
    rm = diameter / 2
    # rev/s; Morrell's n_c = 42.3/sqrt(D) rpm is sqrt(2 g / D) rounded (42.298 with g = 9.81)
    n = phi * math.sqrt(2 * G / diameter) / (2 * math.pi)
    ext = 2 * math.pi + ts - tt
    rmean = rm / 2 * (1 + math.sqrt(1 - 2 * math.pi * J / ext))
    tc = (2 * math.pi - tt + ts) / (2 * math.pi * n / 2)
    tf = math.sqrt(2 * rmean * (math.sin(ts) - math.sin(tt)) / G)
    ri = rm * math.sqrt(1 - 2 * math.pi * tc / (tf + tc) * J / ext)
    z = (1 - J) ** 0.4532
    return (math.pi * G * length * n * rm / (3 * (rm - z * ri))
            * (2 * rm ** 3 - 3 * z * rm ** 2 * ri + ri ** 3 * (3 * z - 2))
            * rho * (math.sin(ts) - math.sin(tt))
            + length * rho * (n * rm * math.pi / (rm - z * ri)) ** 3
            * ((rm - z * ri) ** 4 - ri ** 4 * (z - 1) ** 4))


def vertex(x, y):
    """Vertex of the parabola through three points (Lagrange form)."""
    (x0, x1, x2), (y0, y1, y2) = x, y
    num = (x1 - x0) ** 2 * (y1 - y2) - (x1 - x2) ** 2 * (y1 - y0)
    return x1 - 0.5 * num / ((x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0))


def case_power(n, filling, mass):
    """The synthetic power: 2.5 x Morrell's at J = 0.3, a parabola peaked at n/n_c = 0.8 else."""
    if filling == 0.3:
        phi = n * critical_speed() / math.sqrt(2 * G / D)
        return 2.5 * morrell_power_here(phi, filling, D, L, mass / (filling * math.pi * D**2 / 4 * L))
    return 100.0 - 400.0 * (n - 0.8) ** 2


def charge_mass(filling):
    return 4500.0 * filling * math.pi * D ** 2 / 4 * L


def synthetic_case(path, n, filling, spectra=True, bins=8, records=None):
    """A ballmill3d case file with every output of the contract; numbers made up from n, J."""
    rng = np.random.default_rng(int(100 * n + 10 * filling))
    records = records or int(3 + 10 * n)  # the records' count differs between speeds
    size = 0.01 / np.sqrt(2.0) ** np.arange(6)
    sieve = np.geomspace(1e-4, 1e-2, 9)
    t = np.linspace(0.0, 2.0, 21)
    mass = charge_mass(filling)
    unit, rad = {"units": "1"}, {"units": "rad"}
    coords = {
        "time": ("time", t, {"units": "s"}),
        "size_class": ("size_class", size, {"units": "m"}),
        "sieve": ("sieve", sieve, {"units": "m"}),
        "record_time": ("record_time", np.linspace(0.0, 1.0 / n, records), {"units": "s"}),
    }
    passing = np.sort(rng.random((records, sieve.size)), axis=1)
    data = {
        "power": ((), case_power(n, filling, mass), {"units": "W"}),
        "power_half_width": ((), 2.0, {"units": "W"}),
        "torque": ((), case_power(n, filling, mass) / (n * critical_speed()), {"units": "N m"}),
        "critical_speed": ((), critical_speed(), {"units": "rad s-1"}),
        "omega": ((), n * critical_speed(), {"units": "rad s-1"}),
        "toe_angle": ((), -0.7 + 0.1 * n, rad),
        "shoulder_angle": ((), 2.0 + 0.5 * n, rad),
        "charge_mass": ((), mass, {"units": "kg"}),
        "ball_mass": ((), 0.8 * mass, {"units": "kg"}),
        "ore_mass_initial": ((), 0.2 * mass, {"units": "kg"}),
        "fines_mass": ((), 0.001, {"units": "kg"}),
        "breakage_events": ((), 40.0, unit),
        "energy_balance_error": ((), 0.003 * n, unit),
        "simulated_time": ((), 2.0, {"units": "s"}),
        "breakage_rate": ("size_class", n * size / size[0], {"units": "s-1"}),
        "breakage_rate_half_width": ("size_class", 0.1 * n * size / size[0], {"units": "s-1"}),
        "passing_fraction": (("record_time", "sieve"), passing, unit),
        "kinetic_energy": ("time", rng.random(t.size), {"units": "J"}),
    }
    if spectra:
        edges = np.geomspace(1e-6, 1e-1, bins + 1)
        coords |= {"contact_type": ("contact_type", CONTACTS, {"units": "1"}),
                   "energy_edge": ("energy_edge", edges, {"units": "J"}),
                   "energy_bin": ("energy_bin", np.sqrt(edges[1:] * edges[:-1]), {"units": "J"})}
        rate = 1e3 * n * np.outer(np.arange(1, 6), (edges[1:] / edges[0]) ** -0.5)
        data |= {"impact_rate_normal": (("contact_type", "energy_bin"), rate, {"units": "s-1"}),
                 "impact_rate_tangential": (("contact_type", "energy_bin"), 0.3 * rate,
                                            {"units": "s-1"})}
    ds = xr.Dataset({k: xr.Variable(*v) for k, v in data.items()},
                    coords={k: xr.Variable(*v) for k, v in coords.items()})
    params = {"n_over_nc": n, "filling": filling, "ball_ore_ratio": 1.0, "drum_diameter": D,
              "drum_length": L, "liner": "", "ore_material": "copper_ore", "seed": 1}
    write_case(path, ds, {"scene": "ballmill3d", "parameters": params, "seed": 1, "dt": 1e-6,
                          "steps": 1000, "wall_time_s": 1.0})
    return path


SPEEDS, FILLINGS = (0.5, 0.65, 0.8, 0.95, 1.1), (0.3, 0.4)


def study(tmp, speeds=SPEEDS, fillings=FILLINGS, **kw):
    """The aggregate of a synthetic sweep (cases written out of order), as written to disk."""
    cases = [synthetic_case(tmp / f"c_{n}_{j}.nc", n, j, **kw)
             for n in reversed(speeds) for j in fillings]
    return write_netcdf(tmp / "ballmill3d.nc",
                        aggregate("ballmill3d", cases, ["n_over_nc", "filling"]))


@pytest.fixture
def agg(tmp_path):
    return read_case(study(tmp_path))


# ---- Morrell's relations ---------------------------------------------------------------------

def test_morrell_angles_at_a_hand_computed_point():
    # phi = 0.75, J = 0.3: phi_c = 0.35 x 3.064 = 1.0724; 1 - exp(-19.42 x 0.3224) = 0.998091
    toe = 2.5307 * 0.9796 * 0.998091 + math.pi / 2
    shoulder = math.pi / 2 - (toe - math.pi / 2) * (0.3386 + 0.078075 + (1.54 - 1.925475) * 0.3)
    got_toe, got_shoulder = bm3.morrell_angles(0.75, 0.3)
    assert got_toe == pytest.approx(toe, abs=1e-5)
    assert got_shoulder == pytest.approx(shoulder, abs=1e-5)
    # the scene's convention: from the bottom, positive with the rotation; the toe lies on the
    # falling side (38 degrees before the bottom), the shoulder 47 degrees above the horizontal
    # on the rising side
    toe_s, shoulder_s = bm3.morrell_toe_shoulder(0.75, 0.3)
    assert math.degrees(toe_s) == pytest.approx(math.degrees(toe) - 270.0, abs=1e-3)
    assert -45 < math.degrees(toe_s) < -30
    assert math.degrees(shoulder_s) == pytest.approx(math.degrees(shoulder) + 90.0, abs=1e-3)
    assert 130 < math.degrees(shoulder_s) < 145


def test_morrell_charge_centrifuges_above_phi_c():
    # above phi_c = 0.35 (3.364 - J) toe and shoulder meet at the top (pi/2 from the horizontal)
    toe, shoulder = bm3.morrell_angles([1.08, 1.2], 0.3)
    np.testing.assert_allclose([toe, shoulder], math.pi / 2, atol=1e-12)
    toe_s, shoulder_s = bm3.morrell_toe_shoulder(1.2, 0.3)
    assert (toe_s, shoulder_s) == pytest.approx((-math.pi, math.pi))


@pytest.mark.parametrize("phi, J", [(0.5, 0.2), (0.75, 0.3), (0.9, 0.4), (1.0, 0.35)])
def test_morrell_net_power_against_the_formula(phi, J):
    got = bm3.morrell_net_power(phi, J, 5.0, 7.0, 4500.0)
    assert got == pytest.approx(morrell_power_here(phi, J, 5.0, 7.0, 4500.0), rel=1e-9)


def test_morrell_power_is_industrial_sized_and_peaks_where_the_formula_does():
    # a 5 m x 7 m ball mill at 30 % filling and 75 % of critical draws megawatts (Morrell's
    # data: 1-6 MW for such mills), not watts or gigawatts: the units are SI throughout
    assert 1e6 < bm3.morrell_net_power(0.75, 0.3, 5.0, 7.0, 4500.0) < 6e6
    phi = np.linspace(0.5, 1.1, 601)
    for J in (0.2, 0.3, 0.4):
        here = [morrell_power_here(p, J, 0.3, 0.15, 4500.0) for p in phi]
        got = bm3.morrell_net_power(phi, J, 0.3, 0.15, 4500.0)
        assert phi[np.argmax(got)] == pytest.approx(phi[np.argmax(here)], abs=1e-3)
        # a maximum below the centrifuging speed, not at the end of the grid
        assert 0.8 < phi[np.argmax(got)] < 0.35 * (3.364 - J)


def test_peak_position_is_the_parabola_vertex_and_only_where_bracketed():
    x = [0.5, 0.6, 0.7, 0.85, 1.0]
    y = [1.0, 3.0, 4.0, 3.5, 1.0]
    assert bm3.peak_position(x, y) == pytest.approx(vertex(x[1:4], y[1:4]))
    assert bm3.peak_position(x[::-1], y[::-1]) == pytest.approx(vertex(x[1:4], y[1:4]))
    assert math.isnan(bm3.peak_position(x, [1, 2, 3, 4, 5]))  # rising to the end: not bracketed
    assert math.isnan(bm3.peak_position(x[:2], y[:2]))


# ---- the aggregate ---------------------------------------------------------------------------

def test_aggregate_stacks_speed_and_filling_with_morrell_beside(agg):
    assert agg["power"].dims == ("n_over_nc", "filling")
    assert list(agg["n_over_nc"].values) == list(SPEEDS)
    assert list(agg["filling"].values) == list(FILLINGS)
    # phi of Morrell: omega / sqrt(2 g / D) = n/n_c sqrt(D / (D - d_ball))
    np.testing.assert_allclose(agg["phi_morrell"].sel(filling=0.3),
                               np.array(SPEEDS) * math.sqrt(D / (D - BALL)), rtol=1e-12)
    for n in SPEEDS:
        phi = n * math.sqrt(D / (D - BALL))
        toe, shoulder = bm3.morrell_toe_shoulder(phi, 0.4)
        assert float(agg["toe_angle_morrell"].sel(n_over_nc=n, filling=0.4)) == pytest.approx(toe)
        assert float(agg["shoulder_angle_morrell"].sel(n_over_nc=n, filling=0.4)) == \
            pytest.approx(shoulder)
    # J = 0.3 was made 2.5 x Morrell's power at the case's bulk density: the least-squares
    # factor finds it, and the scaled model is the simulated power
    assert float(agg["power_reference_scale"].sel(filling=0.3)) == pytest.approx(2.5, rel=1e-9)
    np.testing.assert_allclose(agg["power_reference"].sel(filling=0.3),
                               agg["power"].sel(filling=0.3), rtol=1e-9)
    # J = 0.4 is a parabola peaked at 0.8: its vertex; J = 0.3 that of its three top points
    assert float(agg["power_peak_speed"].sel(filling=0.4)) == pytest.approx(0.8)
    p = agg["power"].sel(filling=0.3).values
    k = int(np.argmax(p))
    assert float(agg["power_peak_speed"].sel(filling=0.3)) == \
        pytest.approx(vertex(SPEEDS[k - 1:k + 2], p[k - 1:k + 2]))
    # the model's own maximum, in n/n_c of the study: Morrell's phi over sqrt(D / (D - d))
    phi = np.linspace(0.3, 1.2, 9001) * math.sqrt(D / (D - BALL))
    best = phi[np.argmax([morrell_power_here(f, 0.3, D, L, 4500.0) for f in phi])]
    assert float(agg["power_reference_peak_speed"].sel(filling=0.3)) == \
        pytest.approx(best / math.sqrt(D / (D - BALL)), abs=2e-3)


def test_aggregate_keeps_rates_spectra_and_first_and_last_size_records(tmp_path, agg):
    assert agg["breakage_rate"].dims == ("n_over_nc", "filling", "size_class")
    np.testing.assert_allclose(agg["breakage_rate"].sel(n_over_nc=0.65, filling=0.4),
                               0.65 / np.sqrt(2.0) ** np.arange(6))
    assert agg["impact_rate_normal"].dims == ("n_over_nc", "filling", "contact_type",
                                              "energy_bin")
    assert list(agg["contact_type"].values) == CONTACTS
    assert "record_time" not in agg.dims and "time" not in agg.dims
    case = read_case(tmp_path / "c_0.95_0.3.nc")
    np.testing.assert_array_equal(agg["passing_fraction_feed"].sel(n_over_nc=0.95, filling=0.3),
                                  case["passing_fraction"][0])
    np.testing.assert_array_equal(
        agg["passing_fraction_product"].sel(n_over_nc=0.95, filling=0.3),
        case["passing_fraction"][-1])
    assert float(agg["product_time"].sel(n_over_nc=0.95, filling=0.3)) == \
        pytest.approx(1 / 0.95)


def test_aggregate_refuses_spectra_of_different_bins(tmp_path):
    cases = [synthetic_case(tmp_path / "a.nc", 0.6, 0.3, bins=8),
             synthetic_case(tmp_path / "b.nc", 0.8, 0.3, bins=6)]
    with pytest.raises(ValueError, match="impact_rate_normal: the cases have different energy"):
        aggregate("ballmill3d", cases, ["n_over_nc", "filling"])


def test_aggregate_refuses_a_swept_drum_diameter(tmp_path):
    cases = [synthetic_case(tmp_path / f"{n}.nc", n, 0.3) for n in (0.6, 0.8)]
    ds = aggregate("ballmill3d", cases, ["n_over_nc", "filling"])
    del ds.attrs["param_drum_diameter"]
    with pytest.raises(ValueError, match="drum_diameter: not one value for the whole study"):
        bm3.summary(ds)


# ---- the figures -----------------------------------------------------------------------------

def _draw(kind, source, out):
    saved = []
    original = Figure.savefig

    def savefig(fig, *args, **kwargs):
        saved.append(fig)
        return original(fig, *args, **kwargs)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Figure, "savefig", savefig)
        plot(kind, source, out)
    assert out.stat().st_size > 0
    return saved[-1]


def _labels(fig):
    return " | ".join(f"{ax.get_xlabel()} / {ax.get_ylabel()}" for ax in fig.axes)


@pytest.mark.parametrize("kind, x, y", [
    ("ballmill3d_power", "rotation speed", "mean drive power [W]"),
    ("ballmill3d_charge_shape", "rotation speed", "angle from the vertical below the axis [deg]"),
    ("ballmill3d_spectra", "impact energy [J]", "impacts per second [s$^{-1}$]"),
    ("ballmill3d_breakage_rate", "lower edge of the size class [mm]", "breakage rate"),
])
def test_figures_render_with_their_axes_labels(tmp_path, kind, x, y):
    fig = _draw(kind, study(tmp_path), tmp_path / f"{kind}.png")
    text = _labels(fig)
    assert x in text and y in text, text


def test_power_figure_draws_the_scaled_reference_and_the_maximum(tmp_path):
    fig = _draw("ballmill3d_power", study(tmp_path), tmp_path / "p.png")
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert any("Morrell (1996) C-model x 2.5," in t for t in legend)
    assert any("simulated maximum at" in t and "0.800" in t for t in legend)


def test_spectra_figure_without_spectra_says_so(tmp_path):
    fig = _draw("ballmill3d_spectra", study(tmp_path, spectra=False), tmp_path / "s.png")
    assert any("no impact-energy spectra" in t.get_text() for ax in fig.axes for t in ax.texts)


# ---- the report's landing page ---------------------------------------------------------------

def test_report_decides_the_peak_and_the_energy_balance(tmp_path):
    from millsim.analysis import report

    summary = report.summarise(ballmill3d_path=study(tmp_path), docs=tmp_path)
    verdicts = {v["check"]: v for v in summary["verdicts"]}
    # J = 0.4 peaks at 0.8 (the parabola), J = 0.3 at its three top points' vertex: both inside
    assert verdicts["drive power peaks at 0.7-0.9 of critical, J = 0.4"]["passed"] is True
    assert verdicts["drive power peaks at 0.7-0.9 of critical, J = 0.3"]["passed"] is True
    # the largest residual is 0.003 x 1.1 (n/n_c = 1.1), within 2 %
    balance = verdicts["energy balance of every case"]
    assert balance["passed"] is True and "0.33 %" in balance["value"]
    # speeds up to 0.8 only: the parabola still rises at the end, no maximum claimed
    low = report.summarise(ballmill3d_path=study(tmp_path / "low", speeds=(0.5, 0.65, 0.8)),
                           docs=tmp_path)
    peak = [v for v in low["verdicts"] if v["check"].endswith("J = 0.4")][0]
    assert peak["passed"] is None and report._status(peak) == "n/a"


def test_breakage_figure_without_breakage_says_so(tmp_path):
    """Cases in which nothing broke (a short quick-study run) have no point for log axes: the
    figure says so instead of failing."""
    source = study(tmp_path)
    with xr.open_dataset(source) as ds:
        ds = ds.load()
    ds["breakage_rate"] = ds["breakage_rate"] * np.nan
    quiet = write_netcdf(tmp_path / "quiet.nc", ds)
    fig = _draw("ballmill3d_breakage_rate", quiet, tmp_path / "b.png")
    assert any("no breakage recorded" in t.get_text() for ax in fig.axes for t in ax.texts)
