"""Every registered figure, drawn from small synthetic inputs, keeps its text on the canvas: titles,
suptitles, axis and tick labels, legends and notes lie inside the figure after its own layout;
a legend drawn inside an axes stays inside it and covers no data marker, one drawn outside does
not overlap the axes. Plus the figure-specific honesty rules of issue 49 (cumulative passing on
log axes, chain counts with Poisson intervals, capture radius at the ring radii, open intervals
written as open, the refined friction marked). No simulation."""

import json
import math
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
import pytest
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.text import Text
from test_ballmill3d_study import study as ballmill3d_study
from test_plots import synthetic_case

from millsim.analysis.aggregate import aggregate
from millsim.analysis.stirred_mill import calibrate_friction, calibrate_viscosity, predict
from millsim.io import SnapshotWriter, write_netcdf
from millsim.plots import PLOTS, plot

ROOT = Path(__file__).resolve().parents[1]
SLACK = 1.0  # display pixels: anti-aliasing of an extent that touches the edge


# ---- synthetic inputs, one per registry input --------------------------------------------------

def ballmill(tmp, speeds=(0.25, 0.5, 0.75, 1.0, 1.25, 1.5)):
    """The quick study's six speeds (config/config.yaml)."""
    cases = [synthetic_case(tmp / f"bm_{s}.nc", s) for s in speeds]
    return write_netcdf(tmp / "ballmill.nc", aggregate("ballmill2d", cases, ["n_over_nc"]))


def forcechain(tmp, speeds=(0.13, 0.64, 1.21)):
    cases = [synthetic_case(tmp / f"fc_{s}.nc", s, fragmentation=False) for s in speeds]
    return write_netcdf(tmp / "forcechain.nc", aggregate("ballmill2d", cases, ["n_over_nc"]))


SIEVES = np.array([6.3, 4.75, 3.35, 2.36, 1.7, 1.18, 0.85, 0.6, 0.425, 0.3, 0.212, 0.15, 0.106,
                   0.075, 0.053, 0.038]) * 1e-3  # m, the scene's sieve series
PITCH = 1.02 * 5.5e-3  # m: spacing x particle diameter, the scene's defaults


def bed(tmp, paper=False):
    """A bed_breakage aggregate. Quick (config/config.yaml): one 7-particle monolayer at four
    energies, one seed. Paper-like: two materials, three configurations at 3.05 J, 3 seeds.
    Capture radii lie at or just beyond site radii of the hexagonal layer, as in the scene's
    runs (docs/results/bed_impact.md: 10.0 mm for the 9.72 mm site)."""
    from millsim.analysis.bed_impact import summary

    energies = np.array([0.1, 0.3, 1.0, 3.05])
    mats = ["copper_ore", "limestone"] if paper else ["copper_ore"]
    rings, layers = ([1, 2], [1, 2]) if paper else ([1], [1])
    seeds = [1, 2, 3] if paper else [1]
    shape = (len(mats), len(rings), len(layers), len(energies), len(seeds))
    frac = np.full(shape, np.nan)
    radius = np.full(shape, np.nan)
    passing = np.full(shape + (len(SIEVES),), np.nan)
    sites = PITCH * np.array([0.0, 1.0, math.sqrt(3.0), 2.0])
    rng = np.random.default_rng(7)
    for i, j, k in np.ndindex(*shape[:3]):
        if j == 1 and k == 1:
            continue  # a sparse grid: multilayers of the 7-particle bed only
        for e, energy in enumerate(energies):
            if paper and (j, k) != (0, 0) and energy != 3.05:
                continue
            for s in range(len(seeds)):
                broken = min(0.95, 0.08 * energy ** 0.7 * (1 + 0.2 * i) * (1 + 0.15 * s))
                frac[i, j, k, e, s] = broken
                reach = min(int(energy > 0.2) + int(energy > 2) * (s % 2 + 1), 1 + 2 * j)
                # pushed outward by up to 0.4 mm before it breaks, as in the scene's runs
                radius[i, j, k, e, s] = sites[min(reach, 3)] + 4e-4 * rng.random() * (reach > 0)
                fines = broken * (SIEVES / 4.75e-3) ** (0.7 + 0.1 * i)
                passing[i, j, k, e, s] = np.where(SIEVES > 5.5e-3, 1.0, np.minimum(fines, 1.0))
    dims = ("material", "rings", "layers", "impact_energy", "seed")
    ds = xr.Dataset(
        {"broken_fraction": (dims, frac, {"units": "1"}),
         "capture_radius": (dims, radius, {"units": "m"}),
         "passing_fraction": ((*dims, "sieve"), passing, {"units": "1"})},
        coords={"material": ("material", mats, {"units": "1"}),
                "rings": ("rings", rings, {"units": "1"}),
                "layers": ("layers", layers, {"units": "1"}),
                "impact_energy": ("impact_energy", energies, {"units": "J"}),
                "seed": ("seed", seeds, {"units": "1"}),
                "sieve": ("sieve", SIEVES, {"units": "m"})},
        attrs={"title": "synthetic bed-impact aggregate", "param_spacing": 1.02,
               "param_particle_diameter": 5.5e-3,
               "stacked_over": json.dumps(list(dims))})
    return write_netcdf(tmp / f"bed{'_paper' if paper else ''}.nc", summary(ds))


def tavares(tmp):
    """A tavares_verification aggregate whose 'simulation' is the model itself with some scatter."""
    from millsim.models.breakage import tavares as tv
    from millsim.models.breakage import tavares_materials
    from millsim.models.breakage.tavares_predictions import (
        breakage_probability,
        product_passing_model,
        repeated_impact_broken,
        t10_model,
        table2_comparison,
    )

    mat = tavares_materials.load_materials(tavares_materials.MATERIALS_FILE, truncation="single_particle")["copper_ore"]
    share, d = 0.85, 5.5e-3
    ratios = np.array([0.5, 1.0, 1.5, 2.5])
    e50 = float(tv.median_fracture_energy(mat, d)) / share
    energy = ratios * e50
    p = breakage_probability(mat, d, energy, share)
    prob = np.stack([p, np.clip(p * 1.05, 0, 1)])[:, None, :]  # (mode, material, ratio)
    impacts = np.arange(1, 21)
    rep = np.asarray(repeated_impact_broken(mat, 0.0375, 94.7, share, 20, gamma=5.0, grid=20_000))
    frag_d, frag_ratios = 0.029, np.array([1.0, 2.0, 4.0])
    frag_e = frag_ratios * float(tv.median_fracture_energy(mat, frag_d)) / share
    t10 = np.array([[t10_model(mat, frag_d, e, share) for e in frag_e]] * 2)
    sieve = tv.SIEVE_RATIO ** -np.arange(0.0, 14.0)
    psd = np.array([[product_passing_model(mat, frag_d, e, share, sieve) for e in frag_e]] * 2)
    t2_sieve, paper, ours, target = table2_comparison()
    two = ("prob_mode", "prob_material", "energy_ratio")
    frag = ("frag_case", "frag_ratio")
    u = {"units": "1"}
    ds = xr.Dataset(
        {"prob_fraction": (two, prob, u), "prob_ci_lo": (two, prob * 0.8, u),
         "prob_ci_hi": (two, np.minimum(prob * 1.2 + 0.02, 1), u),
         "prob_specific_energy": (two, np.broadcast_to(energy, prob.shape), {"units": "J kg-1"}),
         "prob_absorbed_share": (two, np.full(prob.shape, share), u),
         "rep_fraction": (("gamma", "impact"), rep[None], u),
         "rep_ci_lo": (("gamma", "impact"), rep[None] * 0.9, u),
         "rep_ci_hi": (("gamma", "impact"), np.minimum(rep[None] * 1.1, 1), u),
         "rep_analytic": (("gamma", "impact"), rep[None], u),
         "t10": (frag, t10, {"units": "%"}), "t10_lo": (frag, t10 * 0.9, {"units": "%"}),
         "t10_hi": (frag, t10 * 1.1, {"units": "%"}),
         "t10_primary": (frag, t10 * 1.3, {"units": "%"}),
         "t10_specific_energy": (frag, np.broadcast_to(frag_e, t10.shape), {"units": "J kg-1"}),
         "t10_absorbed_share": (frag, np.full(t10.shape, share), u),
         "frag_material": (("frag_case",), ["copper_ore"] * 2, u),
         "frag_diameter": (("frag_case",), [frag_d] * 2, {"units": "m"}),
         "psd_sim": ((*frag, "sieve"), psd, {"units": "%"}),
         "table2_paper": (("table2_sieve",), paper, {"units": "%"}),
         "table2_families": (("table2_sieve",), ours, {"units": "%"}),
         "table2_target": (("table2_sieve",), target, {"units": "%"})},
        coords={"prob_mode": ("prob_mode", ["drop_weight", "single"], u),
                "prob_material": ("prob_material", ["copper_ore"], u),
                "energy_ratio": ("energy_ratio", ratios, u), "gamma": ("gamma", [5.0], u),
                "impact": ("impact", impacts, u),
                "frag_case": ("frag_case", ["copper_ore/single/29mm/end_of_loading",
                                            "copper_ore/single/29mm/first_reach"], u),
                "frag_ratio": ("frag_ratio", frag_ratios, u), "sieve": ("sieve", sieve, u),
                "table2_sieve": ("table2_sieve", t2_sieve, u)},
        attrs={"title": "synthetic Tavares verification", "prob_diameter_m": d,
               "rep_material": "copper_ore", "rep_diameter_m": 0.0375,
               "rep_specific_energy_J_per_kg": 94.7, "source_cases": "[]"})
    return write_netcdf(tmp / "tavares_verification.nc", ds)


def stirred(tmp):
    """A stirred-mill aggregate: 2 viscosities x 2 speeds (the quick study), with every field
    the figures draw."""
    from test_report import stirred_aggregate

    path = stirred_aggregate(tmp / "raw.nc", rpm=(2500.0, 3500.0))
    ds = xr.open_dataset(path).load()
    rng = np.random.default_rng(3)
    shape = (ds.sizes["eta"], ds.sizes["rpm"])
    grid = np.linspace(-0.02, 0.02, 16)
    ds = ds.assign_coords(gy=("gy", grid, {"units": "m"}), gz=("gz", grid, {"units": "m"}))
    freq = rng.random((*shape, 9))
    ds["collision_frequency_relative"] = (("eta", "rpm", "region"),
                                          100 * freq / freq.sum(-1, keepdims=True), {"units": "%"})
    for name, scale in (("cg_speed", 1.0), ("cg_spin", 300.0), ("cg_vy", 0.5), ("cg_vz", 0.5)):
        ds[name] = (("eta", "rpm", "gz", "gy"), scale * rng.random((*shape, 16, 16)),
                    {"units": "rad s-1" if name == "cg_spin" else "m s-1"})
    ds.attrs.update(param_slice=1, param_scale=0.45, param_disks=4, param_friction=0.3)
    ds["n_bead"] = (("eta", "rpm"), np.full(shape, 2487), {"units": "1"})
    return write_netcdf(tmp / "stirred_mill.nc", ds)


def calibration(tmp):
    """Stage 1-3 tables as the quick study makes them (config/config.yaml: mu 0.2-0.4, 2500 and
    3500 rpm, eta_sim 0.01-0.1 Pa s, 2 seeds) against the shipped reference: made-up powers near
    it, so that twin_A's eta_sim interval is open below (its reference lies under the grid)."""
    from millsim.analysis.stirred_mill import read_reference

    ref = read_reference(ROOT / "config/reference/stirred_mill_power.csv")
    dry = ref[ref["fluid"] == "dry"].set_index("rpm")["net_power"]
    rpms, mus, etas = [2500.0, 3500.0], [0.2, 0.3, 0.4], [0.01, 0.03, 0.1]

    def power(mu, eta, rpm):
        return dry[rpm] * (1 + 1.5 * (mu - 0.27)) + 10 * rpm / 2500 * eta

    cases = pd.DataFrame([dict(friction=mu, eta=e, rpm=r, net_power=power(mu, e, r),
                               net_power_ci=0.06 * r / 1000, replicates=2, replicate_scale=1.0,
                               replicate_dof=4)
                          for mu in mus for e in [0.0, *etas] for r in rpms])
    table, _, choice = calibrate_friction(cases, ref)
    visc, fluids = calibrate_viscosity(cases, ref, choice["friction"], 2500.0)
    pred = predict(cases, ref, choice["friction"], {f: c["eta_sim"] for f, c in fluids.items()})
    out = {}
    for name, frame in (("friction", table), ("viscosity", visc), ("prediction", pred)):
        out[name] = tmp / f"stirred_mill_{name}.csv"
        frame.to_csv(out[name], index=False)
    return out


def accuracy(tmp):
    from test_accuracy import synthetic_cases

    from millsim.analysis import accuracy as acc

    cases = synthetic_cases()
    points, choices = acc.analyse(cases, links={("ballmill", "verlet"): "gear"})
    ds = acc.to_dataset(cases, points, choices, {"tolerance": 0.01, "title": "synthetic"})
    return write_netcdf(tmp / "accuracy.nc", ds)


def ballmill3d(tmp):
    """The 3D ball mill's speed x filling sweep (tests/test_ballmill3d_study.py)."""
    return ballmill3d_study(tmp)


def snapshots(tmp):
    angle = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    wall = 0.05 * np.c_[np.cos(angle), np.sin(angle)]
    with SnapshotWriter(tmp / "snap.h5", dim=2) as snaps:
        for k in range(2):
            grains = np.c_[np.linspace(-0.02, 0.02, 10), np.full(10, -0.03 + 0.005 * k)]
            snaps.write(0.1 * k, np.r_[wall, grains], np.full(50, 0.004), np.ones((50, 2)) * k,
                        kinematic=np.r_[np.ones(40), np.zeros(10)].astype("int32"))
    return tmp / "snap.h5"


# the input builder of every entry of `millsim plot --list`
FIGURES = {
    "ballmill_rate": ballmill, "ballmill_size_distributions": ballmill,
    "ballmill_fragmentation_maps": ballmill, "ballmill_pressure_maps": forcechain,
    "ballmill_force_chains": forcechain, "animation": snapshots,
    "bed_broken_mass": bed, "bed_capture_radius": bed, "bed_size_distributions": bed,
    "tavares_probability": tavares, "tavares_repeated": tavares, "tavares_t10": tavares,
    "tavares_size_distributions": tavares, "tavares_table2": tavares,
    "stirred_mill_power": stirred, "stirred_mill_typology": stirred,
    "stirred_mill_regions": stirred, "stirred_mill_velocity": stirred,
    "stirred_mill_friction": calibration, "stirred_mill_viscosity": calibration,
    "stirred_mill_prediction": calibration, "error_vs_runtime_{name}": accuracy,
    "ballmill3d_power": ballmill3d, "ballmill3d_charge_shape": ballmill3d,
    "ballmill3d_spectra": ballmill3d, "ballmill3d_breakage_rate": ballmill3d,
}
# the bed figures change shape with the study: also drawn from the paper-like matrix
CASES = [(k, False) for k in FIGURES] + [(k, True) for k in FIGURES if k.startswith("bed_")]


def source(kind, tmp, paper=False):
    build = FIGURES[kind]
    if build is bed:
        return bed(tmp, paper)
    if build is calibration:
        return calibration(tmp)[kind.removeprefix("stirred_mill_")]
    return build(tmp)


def draw(kind, tmp, paper=False):
    """Draw figure ``kind`` through `millsim.plots.plot`; returns the last Figure it saved."""
    saved = []
    original = Figure.savefig

    def savefig(fig, *args, **kwargs):
        saved.append(fig)
        return original(fig, *args, **kwargs)

    name = kind.replace("{name}", "ballmill")
    out = tmp / f"{name}{'_paper' if paper else ''}.{'gif' if kind == 'animation' else 'png'}"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Figure, "savefig", savefig)
        plot(name, source(kind, tmp, paper), out)
    return saved[-1]


# ---- the checks --------------------------------------------------------------------------------

def drawn_texts(fig):
    """(text, window extent) of every text the renderer draws, after the figure's own layout."""
    from millsim.plots.style import RC

    texts = []
    original = Text.draw

    def record(self, renderer):
        original(self, renderer)
        if self.get_visible() and self.get_text().strip():
            texts.append((self, self.get_window_extent(renderer)))

    FigureCanvasAgg(fig)
    with pytest.MonkeyPatch.context() as mp, matplotlib.rc_context(RC):
        mp.setattr(Text, "draw", record)
        fig.canvas.draw()
    return texts


def layout_faults(fig):
    """What is wrong with the layout of ``fig``: texts off the canvas, legends over data."""
    texts = drawn_texts(fig)
    renderer = fig.canvas.get_renderer()
    canvas = fig.bbox.padded(SLACK)
    faults = [f"text {t.get_text()!r} at {box.bounds} leaves the canvas {fig.bbox.bounds}"
              for t, box in texts
              if not (canvas.contains(box.x0, box.y0) and canvas.contains(box.x1, box.y1))]
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is None or not legend.get_visible():
            continue
        box, frame = legend.get_window_extent(renderer), ax.bbox
        inside = frame.contains(*box.p0 + (box.p1 - box.p0) / 2)
        pad = frame.padded(SLACK)
        if inside and not (pad.contains(box.x0, box.y0) and pad.contains(box.x1, box.y1)):
            faults.append(f"legend of {ax.get_title()!r} crosses the axes frame")
        if not inside and box.overlaps(frame):
            faults.append(f"legend of {ax.get_title()!r} outside the axes overlaps them")
        if inside:
            faults += [f"legend of {ax.get_title()!r} covers a data marker of {line.get_label()!r}"
                       for line in _markers(ax) if _covered(line, box)]
    titles = [t for t, _ in texts if t is fig._suptitle or any(t is ax.title for ax in fig.axes)]
    for legend in fig.legends:
        box = legend.get_window_extent(renderer)
        faults += [f"figure legend overlaps the axes {ax.get_title()!r}"
                   for ax in fig.axes if ax.get_visible() and box.overlaps(ax.bbox)]
        faults += [f"figure legend overlaps the title {t.get_text()!r}"
                   for t, extent in texts if t in titles and box.overlaps(extent)]
    return faults


def _markers(ax):
    return [line for line in ax.get_lines()
            if line.get_visible() and line.get_marker() not in (None, "", "None", " ")]


def _covered(line, box):
    xy = line.get_transform().transform(np.column_stack(line.get_data()).astype(float))
    xy = xy[np.isfinite(xy).all(1)]
    inside = (xy[:, 0] > box.x0) & (xy[:, 0] < box.x1) & (xy[:, 1] > box.y0) & (xy[:, 1] < box.y1)
    return bool(inside.any())


@pytest.mark.parametrize("kind,paper", CASES, ids=[f"{k}{'-paper' if p else ''}" for k, p in CASES])
def test_every_figure_keeps_its_text_on_the_canvas_and_its_legends_off_the_data(
        tmp_path, kind, paper):
    assert layout_faults(draw(kind, tmp_path, paper)) == []


def test_the_layout_check_sees_a_title_cut_at_the_edge_and_a_legend_on_the_data():
    fig = Figure(figsize=(4, 3), layout="constrained")
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], "o", label="data")
    ax.set_title("a title far too long for a figure four inches wide, cut at its right edge")
    ax.legend(loc="upper left", bbox_to_anchor=(-0.08, 1.0))
    faults = layout_faults(fig)
    assert any("leaves the canvas" in f for f in faults)
    assert any("crosses the axes frame" in f for f in faults)
    ax.legend(loc="center", bbox_to_anchor=(0.0, 0.0))
    assert any("covers a data marker" in f for f in layout_faults(fig))
    ax.get_legend().remove()
    fig.suptitle("a suptitle as wide as the figure, beside a legend put outside at the top")
    fig.legend(loc="outside right upper")
    assert any("figure legend overlaps the title" in f for f in layout_faults(fig))


def test_every_registered_figure_is_covered():
    assert set(FIGURES) == set(PLOTS)


# ---- the honesty rules of issue 49 ---------------------------------------------------------------

def _legend_texts(fig):
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend()] + list(fig.legends)
    return [t.get_text() for legend in legends for t in legend.get_texts()]


def test_ballmill_size_distribution_is_cumulative_passing_on_log_axes(tmp_path):
    ax = draw("ballmill_size_distributions", tmp_path).axes[0]
    assert (ax.get_xscale(), ax.get_yscale()) == ("log", "log")
    assert ax.get_ylabel() == "cumulative passing [%]"
    lines = [line for line in ax.get_lines() if line.get_label().startswith("$n/n")]
    assert len(lines) == 6
    for line in lines:
        y = line.get_ydata()
        assert np.all(np.diff(y) >= 0) and y[-1] == pytest.approx(100.0)


def test_force_chain_counts_are_symbols_with_poisson_intervals(tmp_path):
    count_axes = draw("ballmill_force_chains", tmp_path).axes[0]
    bars = count_axes.containers
    assert len(bars) == 3  # one per speed
    for bar in bars:
        assert bar.lines[0].get_linestyle() == "None"  # no trend through counts
    # synthetic counts floor(12 / (L - 2)): 2 chains of length 7 at n/n_c = 0.13
    (low, high), = [seg for seg in bars[0].lines[2][0].get_segments() if seg[0][0] > 6.5]
    assert (low[1], high[1]) == pytest.approx((0.2422, 7.2247), abs=1e-4)


def test_capture_radius_is_drawn_at_the_site_radii(tmp_path):
    ax = draw("bed_capture_radius", tmp_path, paper=True).axes[0]
    sites = np.array(ax.get_yticks())
    pitch = 1e3 * PITCH
    for r in (0.0, pitch, math.sqrt(3) * pitch, 2 * pitch, pitch / math.sqrt(3)):
        assert np.isclose(sites, r, atol=1e-3).any()
    drawn = np.concatenate([c.get_offsets()[:, 1] for c in ax.collections if len(c.get_offsets())])
    beyond = drawn[:, None] - sites[None, :]
    assert np.where(beyond > -1e-9, beyond, np.inf).min(1).max() < 0.4  # just beyond a site
    assert not [line for line in ax.get_lines() if len(line.get_xdata()) > 2]  # no trend lines


def test_open_viscosity_intervals_keep_their_inequality(tmp_path):
    texts = _legend_texts(draw("stirred_mill_viscosity", tmp_path))
    assert any(t.startswith("twin_A") and "[\u2264 0.01, " in t for t in texts), texts
    assert any(t.startswith("twin_B") and ", \u2265 0.1]" in t for t in texts), texts


def test_friction_figure_marks_the_refined_value(tmp_path):
    from millsim.analysis.stirred_mill import _parabola_min, friction_ssr

    table = pd.read_csv(calibration(tmp_path)["friction"])
    s = friction_ssr(table)
    refined = _parabola_min(s["friction"].to_numpy(), s["ssr"].to_numpy())
    b = draw("stirred_mill_friction", tmp_path).axes[1]
    marks = [line for line in b.get_lines() if line.get_label().startswith("refined")]
    assert len(marks) == 1 and marks[0].get_xdata()[0] == pytest.approx(refined)
    assert f"{refined:.3g}" in marks[0].get_label() and refined != 0.3  # not the grid minimum
