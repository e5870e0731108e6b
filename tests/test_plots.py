"""Aggregation and figures on synthetic ball-mill case files (no simulation needed), and the plot
registry behind `millsim plot`."""

import numpy as np
import pytest
import xarray as xr

from millsim.analysis.aggregate import aggregate, swept_parameters
from millsim.cli import main
from millsim.io import SnapshotWriter, read_case, write_case
from millsim.plots import PLOTS, find
from millsim.plots.ballmill import bond_austin_speed_factor

DRUM = 0.05
PNG = b"\x89PNG\r\n\x1a\n"


def _masses(rng, n_over_nc):
    """Mass per radius class (3 snapshots x 6 classes, coarse to fine mass moving finer with time
    and speed), with some noise: a product that looks like one."""
    fine = 1.0 / (0.8 + 0.6 * n_over_nc * np.array([[0.6], [0.8], [1.0]]))
    classes = np.arange(6)[None, :]  # 0: finest
    return np.exp(-fine * (5 - classes) ** 1.3) * (1 + 0.1 * rng.random((3, 6)))


def synthetic_case(path, n_over_nc, fragmentation=True, filling=0.3, seed=1):
    """A case file with every variable of the ballmill2d contract, numbers made up from n/n_c."""
    rng = np.random.default_rng(int(n_over_nc * 100))
    time = np.linspace(0.0, 1.0, 11)
    grid = np.linspace(-DRUM, DRUM, 8)
    unit = {"units": "1"}
    coords = {
        "time": ("time", time, {"units": "s"}),
        "gx": ("gx", grid, {"units": "m"}), "gy": ("gy", grid, {"units": "m"}),
    }
    data = {
        "grains": ("time", np.full(11, 100.0), unit),
        "kinetic_energy": ("time", rng.random(11), {"units": "J"}),
        "pressure": (("gy", "gx"), rng.random((8, 8)) * 1e4, {"units": "Pa"}),
        "mean_drive_power": ((), 2.0 * n_over_nc, {"units": "W"}),
        "n_c": ((), 2.2, {"units": "s-1"}),
        "n_over_nc": ((), n_over_nc, unit),
    }
    if fragmentation:
        edges = np.geomspace(1e-4, 4e-3, 7)
        coords |= {
            "snapshot": ("snapshot", [0.5, 0.75, 1.0], {"units": "s"}),
            "size_class": ("size_class", 0.5 * (edges[1:] + edges[:-1]),
                           {"units": "m", "bounds": "size_class_bounds"}),
            # the scene's CF bounds of each class (scenes/ballmill2d.py)
            "size_class_bounds": (("size_class", "bound"),
                                  np.column_stack([edges[:-1], edges[1:]]), {"units": "m"}),
            "event": ("event", np.arange(5), unit),
        }
        data |= {
            "size_distribution": (("snapshot", "size_class"), _masses(rng, n_over_nc),
                                  {"units": "kg"}),
            "event_time": ("event", np.sort(rng.random(5)), {"units": "s"}),
            "fracture_frequency": (("gy", "gx"), rng.random((8, 8)), {"units": "s-1 m-2"}),
            # a rate peaked at n/n_c = 1, as Buchholtz et al. 2000 reports
            "comminution_rate": ((), 10.0 * np.exp(-((n_over_nc - 1.0) ** 2)), {"units": "s-1"}),
            "comminution_rate_ci": ((), 0.5, {"units": "s-1"}),
        }
    else:
        length = np.arange(3, 8 if n_over_nc < 1 else 6)  # fast drums: no long chains
        coords |= {"chain_length": ("chain_length", length, unit),
                   "chain_position": ("chain_position", np.linspace(0.05, 0.95, 10), unit)}
        data |= {
            # whole chains counted over all records: small integers, as in a short run
            "chain_count": ("chain_length", np.floor(12.0 / (length - 2)), unit),
            "chain_max_pressure": ("chain_length", 1e4 * length, {"units": "Pa"}),
            "chain_force_profile": ("chain_position", np.linspace(1.0, 2.0, 10), {"units": "N"}),
        }
    ds = xr.Dataset({k: xr.Variable(*v) for k, v in data.items()},
                    coords={k: xr.Variable(*v) for k, v in coords.items()})
    params = {"n_over_nc": n_over_nc, "drum_radius": DRUM, "filling": filling,
              "fragmentation": fragmentation, "seed": seed}
    write_case(path, ds, {"scene": "ballmill2d", "parameters": params, "seed": seed, "dt": 1e-5,
                          "steps": 1000, "wall_time_s": float(n_over_nc)})
    return path


@pytest.fixture
def cases(tmp_path):
    # written out of order: the aggregate must sort them
    return [synthetic_case(tmp_path / f"case_{s}.nc", s) for s in (1.0, 0.5, 1.5)]


@pytest.fixture
def chain_cases(tmp_path):
    return [synthetic_case(tmp_path / f"chain_{s}.nc", s, fragmentation=False) for s in (0.5, 1.5)]


def test_aggregate_stacks_along_speed_and_normalises_rate(cases):
    ds = aggregate("ballmill2d", cases, ["n_over_nc"])
    assert ds.sizes["n_over_nc"] == 3
    assert list(ds["n_over_nc"].values) == [0.5, 1.0, 1.5]
    rate = 10.0 * np.exp(-((ds["n_over_nc"].values - 1.0) ** 2))
    np.testing.assert_allclose(ds["comminution_rate"], rate)
    np.testing.assert_allclose(ds["relative_rate"], rate / rate.max())
    np.testing.assert_allclose(ds["relative_rate_ci"], 0.5 / rate.max())
    assert float(ds["relative_rate"].max()) == 1.0
    np.testing.assert_allclose(ds["mean_drive_power"], 2.0 * ds["n_over_nc"])
    # per-case records are gone, summaries stay
    assert not {"time", "event", "snapshot"} & set(ds.dims)
    assert ds["mass_fraction"].dims == ("n_over_nc", "size_class")
    np.testing.assert_allclose(ds["mass_fraction"].sum("size_class"), 1.0)
    # per case: the mass fraction of each snapshot, then its mean and (population) spread over
    # the snapshots, from the case file's own size distribution
    for path in cases:
        case = read_case(path)
        mass = case["size_distribution"].values  # (snapshot, size_class)
        fraction = mass / mass.sum(1, keepdims=True)
        speed = float(case["n_over_nc"])
        np.testing.assert_allclose(ds["mass_fraction"].sel(n_over_nc=speed), fraction.mean(0),
                                   rtol=1e-12)
        np.testing.assert_allclose(ds["mass_fraction_std"].sel(n_over_nc=speed), fraction.std(0),
                                   rtol=1e-12)
        np.testing.assert_allclose(ds["size_distribution_mean"].sel(n_over_nc=speed), mass.mean(0),
                                   rtol=1e-12)
    assert ds["size_distribution_mean"].attrs["units"] == "kg"
    assert ds["mass_fraction"].attrs["units"] == "1"
    assert ds["pressure"].dims == ("n_over_nc", "gy", "gx")
    # provenance: equal attributes survive, differing ones do not
    assert ds.attrs["param_filling"] == 0.3 and ds.attrs["scene"] == "ballmill2d"
    assert "wall_time_s" not in ds.attrs and "param_n_over_nc" not in ds.attrs


def test_aggregate_defaults_to_swept_parameters_and_rejects_duplicates(cases, tmp_path):
    assert swept_parameters([read_case(p) for p in cases]) == ["n_over_nc"]
    twin = synthetic_case(tmp_path / "twin.nc", 1.0)
    with pytest.raises(ValueError, match=r"case_1.0.nc and .*twin.nc are the same point "
                                         r"\(n_over_nc=1.0\)"):
        aggregate("ballmill2d", [*cases, twin])
    with pytest.raises(ValueError, match="not 'packing'"):
        aggregate("packing", cases, ["n_over_nc"])


def test_aggregate_refuses_cases_that_differ_beyond_the_stacked_parameters(cases, tmp_path):
    """A parameter that differs between the cases but is not stacked over, a fixed one or the
    seed, would be dropped from the aggregate: refused, naming it and both values."""
    odd = synthetic_case(tmp_path / "odd.nc", 2.0, filling=0.4)
    with pytest.raises(ValueError, match=r"^filling: 0.3 in .*case_1.0.nc but 0.4 in .*odd.nc"):
        aggregate("ballmill2d", [*cases, odd], ["n_over_nc"])
    reseeded = synthetic_case(tmp_path / "reseeded.nc", 2.0, seed=2)
    with pytest.raises(ValueError, match=r"^seed: 1 in .*case_1.0.nc but 2 in .*reseeded.nc"):
        aggregate("ballmill2d", [*cases, reseeded], ["n_over_nc"])


def test_aggregate_over_two_parameters(tmp_path):
    paths = [synthetic_case(tmp_path / f"{s}_{f}.nc", s, filling=f)
             for s in (0.5, 1.0) for f in (0.2, 0.4)]
    ds = aggregate("ballmill2d", paths)
    assert ds["comminution_rate"].dims == ("filling", "n_over_nc")
    # normalised along n/n_c for each filling separately
    np.testing.assert_allclose(ds["relative_rate"].max("n_over_nc"), 1.0)


def test_force_chain_aggregate_counts_missing_lengths_as_zero(chain_cases):
    ds = aggregate("ballmill2d", chain_cases, ["n_over_nc"])
    assert list(ds["chain_length"].values) == [3, 4, 5, 6, 7]
    assert float(ds["chain_count"].sel(n_over_nc=1.5, chain_length=7)) == 0.0
    assert np.isnan(float(ds["chain_max_pressure"].sel(n_over_nc=1.5, chain_length=7)))
    assert "relative_rate" not in ds


def test_reference_shape_peaks_at_one_near_critical_speed():
    phi = np.linspace(0.0, 1.5, 1501)
    shape = bond_austin_speed_factor(phi)
    assert shape.max() == pytest.approx(1.0, abs=1e-6)
    assert phi[shape.argmax()] == pytest.approx(0.941, abs=0.002)
    assert shape[phi > 1.24].max() < 0.0  # where the empirical fit ends
    # tabulated in reference/ballmill.md section 3
    assert bond_austin_speed_factor(0.5) == pytest.approx(0.609, abs=1e-3)


def _aggregate_cli(paths, out):
    assert main(["aggregate", "ballmill2d", *map(str, paths), "--over", "n_over_nc",
                 "--out", str(out)]) == 0
    ds = read_case(out)
    assert ds["n_over_nc"].attrs["units"] == "1"  # from the scene's parameter declaration
    return out


@pytest.mark.parametrize("kind", ["ballmill_rate", "ballmill_size_distributions",
                                  "ballmill_fragmentation_maps"])
def test_comminution_plots_are_pngs(cases, tmp_path, kind):
    agg = _aggregate_cli(cases, tmp_path / "ballmill.nc")
    out = tmp_path / f"{kind}.png"
    assert main(["plot", kind, str(agg), "--out", str(out)]) == 0
    assert out.read_bytes().startswith(PNG) and out.stat().st_size > 10_000


@pytest.mark.parametrize("kind", ["ballmill_pressure_maps", "ballmill_force_chains"])
def test_force_chain_plots_are_pngs(chain_cases, tmp_path, kind):
    agg = _aggregate_cli(chain_cases, tmp_path / "forcechain.nc")
    out = tmp_path / f"{kind}.png"
    assert main(["plot", kind, str(agg), "--out", str(out)]) == 0
    assert out.read_bytes().startswith(PNG) and out.stat().st_size > 10_000


def test_unknown_plot_kind_exits_2(cases, tmp_path, capsys):
    assert main(["plot", "pie", str(cases[0]), "--out", str(tmp_path / "x.png")]) == 2
    assert "kind: unknown plot 'pie'" in capsys.readouterr().err


def test_animation_is_a_gif_with_one_frame_per_snapshot(tmp_path):
    from PIL import Image

    angle = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    wall = DRUM * np.c_[np.cos(angle), np.sin(angle)]
    with SnapshotWriter(tmp_path / "snap.h5", dim=2) as snaps:
        for k in range(4):
            grains = np.c_[np.linspace(-0.02, 0.02, 10), np.full(10, -0.03 + 0.005 * k)]
            snaps.write(0.1 * k, np.r_[wall, grains], np.full(50, 0.004), np.ones((50, 2)) * k,
                        kinematic=np.r_[np.ones(40), np.zeros(10)].astype("int32"))
    out = tmp_path / "anim.gif"
    assert main(["plot", "animation", str(tmp_path / "snap.h5"), "--out", str(out)]) == 0
    with Image.open(out) as gif:
        assert gif.format == "GIF" and gif.n_frames == 4


def test_registry_lists_every_figure_once_with_a_drawing_function(capsys):
    assert main(["plot", "--list"]) == 0
    rows = [line.split("\t") for line in capsys.readouterr().out.splitlines()]
    assert [name for name, _, _ in rows] == list(PLOTS)
    for name, source, caption in rows:
        kind, _, dataset = source.partition(":")
        assert kind in ("aggregate", "table", "snapshots")
        assert bool(dataset) == (kind != "snapshots")
        assert len(caption) > 40, name
        assert callable(PLOTS[name].function())
    # the figures the pipeline draws, by study
    names = set(PLOTS)
    assert {"ballmill_rate", "ballmill_force_chains", "animation", "bed_broken_mass",
            "tavares_probability", "stirred_mill_power", "stirred_mill_friction",
            "error_vs_runtime_{name}"} <= names


def test_a_family_name_passes_its_field():
    entry, fields = find("error_vs_runtime_stirred_mill")
    assert entry.name == "error_vs_runtime_{name}" and fields == {"name": "stirred_mill"}
    assert find("ballmill_rate") == (PLOTS["ballmill_rate"], {})
    with pytest.raises(ValueError, match="kind: unknown plot 'error_vs_runtime_'"):
        find("error_vs_runtime_")


def test_plot_needs_a_figure_or_list(tmp_path, capsys):
    assert main(["plot", "ballmill_rate"]) == 2
    assert "plot: give KIND INPUT --out FILE, or --list" in capsys.readouterr().err
    assert main(["plot", "--list", "ballmill_rate"]) == 2
