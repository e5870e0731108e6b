"""Bounds on every size: each count or grid parameter refused before anything is allocated when the
memory it needs exceeds what the run may use (RAM, cgroup, SLURM, --max-memory), naming the key
and the largest value allowed; YAML files loaded with limits on size, depth and aliases. Nothing
here runs a simulation: every case is refused while its parameters are resolved."""

import math
import re

import pytest

from millsim.cli import main
from millsim.scenes.base import get_scene
from millsim.util import memory, safe_yaml


def _refused(capsys, directory, scene, *args):
    """The one line of `millsim run` refusing ``args``; nothing written in ``directory``."""
    directory.mkdir(exist_ok=True)
    out = directory / "case.nc"
    assert main(["run", scene, *args, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert list(directory.iterdir()) == []
    return err.strip()


@pytest.mark.parametrize("scene, key, value, noun", [
    # the cases: a ball mill that ran its whole simulation and died making the size
    # distribution (1.5 GiB), maps of 7 TiB, a stirred-mill grid of 373 GiB
    ("ballmill2d", "size_classes", 10**8, "radius classes"),
    ("ballmill2d", "grid_cells", 10**6, "cells per side"),
    ("stirred_mill", "cg_cells", 10**5, "cells per side"),
    ("ballmill2d", "rate_blocks", 10**12, "blocks"),
    ("ballmill2d", "lifters", 10**9, "lifter bars"),
    ("ballmill2d", "n_grains", 10**9, "particles"),
    ("stirred_mill", "records_per_revolution", 10**11, "records per revolution"),
    ("silo", "n", 10**9, "particles"),
])
def test_size_refused_up_front_with_the_largest_allowed(capsys, tmp_path, scene, key, value,
                                                        noun):
    line = _refused(capsys, tmp_path, scene, "--set", f"{key}={value}", "--max-memory", "1G")
    assert line.startswith(f"millsim: error: {key}: {value} {noun} need at least"), line
    largest = int(re.search(rf"allowed up to (\d+) {noun}$", line)[1])
    # the largest allowed passes, one more does not (with the same limit)
    with memory.max_memory("1G"):
        get_scene(scene).resolve({key: str(largest)})
        with pytest.raises(ValueError, match=f"{key}: {largest + 1} {noun}"):
            get_scene(scene).resolve({key: str(largest + 1)})


@pytest.mark.parametrize("scene, key, grids", [("ballmill2d", "grid_cells", 10),
                                                ("stirred_mill", "cg_cells", 14)])
def test_grids_are_estimated_as_docs_pipeline_states(capsys, tmp_path, scene, key, grids):
    """docs/pipeline.md: the ball mill's grid_cells ten maps and the stirred mill's cg_cells 14
    grids of cells^2 values, 8 B each: under 1 GiB the largest side is
    floor(sqrt(2^30 / (8 grids)))."""
    line = _refused(capsys, tmp_path, scene, "--set", f"{key}=100000", "--max-memory", "1G")
    assert f"need at least {grids * 8 * 1e10 / 1e9:.3g} GB" in line, line
    assert line.endswith(f"allowed up to {math.isqrt(2**30 // (8 * grids))} cells per side"), line


def test_record_interval_bounded_by_the_records_it_keeps(capsys, tmp_path):
    """Without fragmentation every record keeps per-particle force sums for the force chains."""
    line = _refused(capsys, tmp_path, "ballmill2d", "--set", "fragmentation=false", "--set",
                    "record_interval=1e-6", "--max-memory", "1G")
    assert "record_interval: 3000001 records need at least" in line
    assert "force-chain data included" in line
    assert re.search(r"allowed record_interval >= [0-9.e-]+ s \(\d+ records of the duration\)$",
                     line)


@pytest.mark.parametrize("env, source", [
    ({"SLURM_MEM_PER_NODE": "4000"}, "of the SLURM job (SLURM_MEM_PER_NODE)"),
    ({"SLURM_MEM_PER_CPU": "1000", "SLURM_CPUS_ON_NODE": "2"},
     "of the SLURM job (SLURM_MEM_PER_CPU x 2 CPUs)"),
    ({"MILLSIM_MAX_MEMORY": "2G"}, "of MILLSIM_MAX_MEMORY"),
])
def test_particle_count_against_the_job_limit(capsys, tmp_path, monkeypatch, env, source):
    """packing n=2e7 fits in the RAM of a large node but not in the job's --mem: refused
    before the lattice is placed, not killed by the OOM killer after."""
    for name in ("SLURM_MEM_PER_NODE", "SLURM_MEM_PER_CPU", "MILLSIM_MAX_MEMORY"):
        monkeypatch.delenv(name, raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    line = _refused(capsys, tmp_path, "packing", "--set", "n=20000000")
    assert line.startswith("millsim: error: n: 20000000 particles need at least 20 GB")
    assert source in line


def test_max_memory_option(capsys, tmp_path):
    line = _refused(capsys, tmp_path, "packing", "--set", "n=2000000", "--max-memory", "1G")
    assert "more than the 1.07 GB of --max-memory; allowed up to 1073741 particles" in line
    line = _refused(capsys, tmp_path, "packing", "--max-memory", "lots")
    assert line == ("millsim: error: --max-memory: expected a positive size such as 16G, 500M or "
                    "1.5GiB, got 'lots'")


@pytest.mark.parametrize("text, bytes_", [("16G", 16 * 2**30), ("500M", 500 * 2**20),
                                          ("1.5GiB", 3 * 2**29), ("2048", 2048), ("4 kb", 4096)])
def test_parse_size(text, bytes_):
    assert memory.parse_size(text) == bytes_


# ---- YAML ----------------------------------------------------------------------------------

def _bomb(levels=9):
    """A 'billion laughs' under a material's `source:` key: 10^levels strings from ~0.5 kB."""
    lines = ['    l0: &l0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"    l{i}: &l{i} [" + ", ".join([f"*l{i - 1}"] * 10) + "]"
              for i in range(1, levels + 1)]
    return "\n".join(lines)


def _materials(tmp_path, source):
    text = open("config/materials.yaml").read()
    anchor = "materials:\n"
    assert anchor in text
    path = tmp_path / "m.yaml"
    path.write_text(text.replace(anchor, f"bomb:\n  source:\n{source}\n{anchor}", 1))
    return path


@pytest.mark.parametrize("source, needle", [
    (_bomb(), "expands to more than 1000000 values; a few kB of aliases can stand for gigabytes "
     "(an alias bomb)"),
    ("    x: &x 1\n" + "".join(f"    y{i}: *x\n" for i in range(101)),
     "more than 100 aliases (*name); a few kB of aliases can stand for gigabytes (an alias bomb)"),
    ("    x: " + "[" * 2000 + "]" * 2000, "nested deeper than 32 levels"),
])
def test_yaml_limits_one_line(capsys, tmp_path, source, needle):
    path = _materials(tmp_path, source)
    line = _refused(capsys, tmp_path / "out", "single_particle", "--materials", str(path))
    assert line.startswith(f"millsim: error: {path}: line ") and line.endswith(f"{needle}; refused")


def test_yaml_file_size_refused_before_reading(capsys, tmp_path):
    path = tmp_path / "huge.yaml"
    path.write_text("# padding\n" * (safe_yaml.MAX_BYTES // 10 + 1))
    line = _refused(capsys, tmp_path / "out", "single_particle", "--materials", str(path))
    assert line == (f"millsim: error: {path}: {path.stat().st_size} bytes, more than the "
                    f"{safe_yaml.MAX_BYTES} a YAML file of millsim may have; refused")


def test_shipped_yaml_within_the_limits():
    from millsim.models.breakage.tavares_materials import check_materials_file

    assert check_materials_file("config/materials.yaml")
    for config in ("config/config.yaml", "config/paper.yaml", "config/bed_trends.yaml"):
        safe_yaml.check_size(config)
        assert isinstance(safe_yaml.load(open(config).read(), config), dict)


def test_a_drop_weight_test_counts_a_striker_per_particle():
    """A drop-weight test has a steel striker above every particle: in the same memory it takes
    half as many particles as a single-impact test."""
    scene = get_scene("single_particle")
    with memory.max_memory("1G"):
        with pytest.raises(ValueError) as refused:
            scene.resolve({"n_particles": str(10**9)})
        largest = int(re.search(r"allowed up to (\d+) particles$", str(refused.value))[1])
        scene.resolve({"n_particles": str(largest)})
        scene.resolve({"n_particles": str(largest // 2), "mode": "drop_weight"})
        # the line names the count the user gave and the largest allowed in the same terms
        with pytest.raises(ValueError, match=rf"^n_particles: {largest // 2 + 1} particles need "
                                             rf".* allowed up to {largest // 2} particles$"):
            scene.resolve({"n_particles": str(largest // 2 + 1), "mode": "drop_weight"})
