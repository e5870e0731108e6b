"""The materials file as data (docs/materials.md): a bad file is refused with one line naming the
file, the material (or block), the key and its allowed range; any material of a good file runs.

The table checks need no simulation; one user ore runs through `millsim run single_particle`.
"""

import copy
import math
from pathlib import Path

import pytest
import yaml

from millsim.cli import main
from millsim.io import case_parameters, read_case
from millsim.models.breakage import tavares as tv
from millsim.models.breakage import tavares_materials
from millsim.models.breakage import tavares_predictions as pred
from millsim.scenes.base import get_scene

SHIPPED = Path(__file__).resolve().parents[1] / "config" / "materials.yaml"
GOOD = yaml.safe_load(SHIPPED.read_text())
DELETE = object()
BETA = "t1.2 >= t1.5 >= t2 >= t4 >= t10 >= t25 >= t50 >= t75 at every t10 in (0, A_percent]"

# (keys to the edited entry, new value or DELETE, the message after "FILE: ")
BAD = [
    (("materials", "copper_ore", "young_GPa"), -52,
     "materials.copper_ore.young_GPa: -52 is outside the allowed range (0, inf)"),
    (("model", "device_surface", "young_GPa"), 0,
     "model.device_surface.young_GPa: 0 is outside the allowed range (0, inf)"),
    (("materials", "steel", "density_kg_m3"), -7800,
     "materials.steel.density_kg_m3: -7800 is outside the allowed range (0, inf)"),
    (("materials", "limestone", "poisson"), 0.5,
     "materials.limestone.poisson: 0.5 is outside the allowed range [0, 0.5)"),
    (("materials", "copper_ore", "sigma"), 0,
     "materials.copper_ore.sigma: 0 is outside the allowed range (0, 10]"),
    (("materials", "copper_ore", "sigma"), "wide",
     "materials.copper_ore.sigma: must be a number, got 'wide'"),
    (("materials", "granulite", "A_percent"), 120,
     "materials.granulite.A_percent: 120 is outside the allowed range (0, 100]"),
    (("materials", "copper_ore", "A_percent"), 0,
     "materials.copper_ore.A_percent: 0 is outside the allowed range (0, 100]"),
    (("model", "emax_over_e50", "bed"), 1,
     "model.emax_over_e50.bed: 1 is outside the allowed range (1, inf)"),
    (("materials", "copper_ore", "Emax_over_E50"), 0.5,
     "materials.copper_ore.Emax_over_E50: 0.5 is outside the allowed range (1, inf)"),
    (("model", "emax_over_e50", "single_particle"), DELETE,
     "model.emax_over_e50.single_particle: missing (required: single_particle, bed)"),
    # t4 above t2 at small t10: the pair of n = 4 replaced by a much steeper curve
    (("materials", "copper_ore", "incomplete_beta", "4"), [0.2, 0.2],
     f"materials.copper_ore.incomplete_beta: t4 > t2 for t10 in [0.169, 3.89] %; eq 10 needs "
     f"{BETA}"),
    (("materials", "granulite", "incomplete_beta", "75"), DELETE,
     "materials.granulite.incomplete_beta: needs exactly n = 1.2, 1.5, 2, 4, 25, 50, 75, got "
     "n = 1.2, 1.5, 2, 4, 25, 50"),
    (("materials", "limestone", "incomplete_beta", "2"), [0.78, -5.55],
     "materials.limestone.incomplete_beta.2[1] (beta): -5.55 is outside the allowed range "
     "(0, inf)"),
    (("materials", "copper_ore", "sigmaa"), 0.8,
     "materials.copper_ore.sigmaa: unknown key; known: " + ", ".join(tavares_materials.MATERIAL_KEYS)),
    (("model", "kapa"), 1.0, "model.kapa: unknown key; known: " + ", ".join(tavares_materials.MODEL_KEYS)),
    (("simulation",), {"d_min_over_top_size": 0.05},
     "simulation: unknown key; known: model, materials, contacts"),
    (("materials", "steel", "sigma"), 0.8,
     "materials.steel.sigma: not a key of a material with breakable: false (it never breaks); "
     "known: source, breakable, density_kg_m3, young_GPa, poisson"),
    (("materials", "copper_ore", "E_inf_basis"), "input",
     "materials.copper_ore.E_inf_basis: 'input' is not one of stress_vs_steel, absorbed"),
    (("model", "E_inf_basis"), "input",
     "model.E_inf_basis: 'input' is not one of stress_vs_steel, absorbed"),
    (("materials", "copper_ore", "E_inf"), {"MJ_per_t": 0.2},
     "materials.copper_ore.E_inf: give exactly one of {J_per_kg: x} or {kWh_per_t: x}, x > 0"),
    (("materials", "copper_ore", "E_inf"), {"kWh_per_t": -1},
     "materials.copper_ore.E_inf.kWh_per_t: -1 is outside the allowed range (0, inf)"),
    (("materials", "limestone", "b_prime"), DELETE,
     "materials.limestone.b_prime: missing (a breakable material needs E_inf, d0_mm, phi, sigma, "
     "gamma, A_percent, b_prime, incomplete_beta; or set breakable: false)"),
    (("materials", "copper_ore", "breakable"), "maybe",
     "materials.copper_ore.breakable: must be true or false, got 'maybe'"),
    (("model", "family_classes"), 9.5,
     "model.family_classes: must be an integer in [2, 20], got 9.5"),
    (("model", "family_classes"), 1,
     "model.family_classes: 1 is outside the allowed range [2, 20]"),
    (("materials", "steel"), DELETE,
     "materials.steel: missing (balls, plates, anvils and strikers of the scenes are steel)"),
    (("materials", "my ore"), GOOD["materials"]["copper_ore"],
     "materials.'my ore': a name is a letter followed by letters, digits or _ (it becomes part "
     "of the case paths)"),
    (("contacts", "particle_steel", "restitution"), 0,
     "contacts.particle_steel.restitution: 0 is outside the allowed range (0, 1]"),
    (("contacts", "steel_steel"), DELETE,
     "contacts.steel_steel: missing (required: particle_steel, particle_particle, steel_steel)"),
]


def edited(keys, value):
    doc = copy.deepcopy(GOOD)
    block = doc
    for key in keys[:-1]:
        block = block[key]
    if value is DELETE:
        del block[keys[-1]]
    else:
        block[keys[-1]] = value
    return yaml.safe_dump(doc, sort_keys=False)


@pytest.mark.parametrize("keys, value, message", BAD, ids=[".".join(k) for k, _, _ in BAD])
def test_bad_file_exact_one_line_message(tmp_path, keys, value, message):
    path = tmp_path / "m.yaml"
    path.write_text(edited(keys, value))
    with pytest.raises(ValueError) as refused:
        tavares_materials.check_materials_file(path)
    assert str(refused.value) == f"{path}: {message}"


LIMESTONE_LINE = SHIPPED.read_text().splitlines().index("  limestone:") + 1


@pytest.mark.parametrize("text, message", [
    # a copied block left under its old name would replace the original silently
    (SHIPPED.read_text().replace("  limestone:\n", "  copper_ore:\n"),
     f"line {LIMESTONE_LINE}: duplicate key 'copper_ore'"),
    ("materials: [copper_ore\n",
     "line 2: not valid YAML (expected ',' or ']', but got '<stream end>')"),
    ("", "expected a mapping of keys, got None"),
])
def test_unreadable_file_one_line(tmp_path, text, message):
    path = tmp_path / "m.yaml"
    path.write_text(text)
    with pytest.raises(ValueError) as refused:
        tavares_materials.check_materials_file(path)
    assert str(refused.value) == f"{path}: {message}"


def test_shipped_file_holds_the_paper_materials_and_cites_no_file_path():
    assert tavares_materials.check_materials_file() == ["copper_ore", "granulite", "limestone"]
    text = SHIPPED.read_text()
    assert "Tavares, Rodriguez, Sousani, Padros" in text and "(2021)" in text
    assert "/work/" not in text and ".txt" not in text


@pytest.mark.parametrize("scene", ["single_particle", "bed_impact"])
def test_scenes_take_any_breakable_material_of_their_file(tmp_path, scene):
    ore = my_ore_file(tmp_path)
    values = get_scene(scene).resolve({"material": "my_ore", "materials_file": str(ore)})
    assert values["material"] == "my_ore"
    with pytest.raises(ValueError) as refused:
        get_scene(scene).resolve({"material": "my_ore"})
    assert str(refused.value) == ("material: 'my_ore' not in config/materials.yaml; known: "
                                  "copper_ore, granulite, limestone")
    with pytest.raises(ValueError) as refused:
        get_scene(scene).resolve({"material": "steel", "materials_file": str(ore)})
    assert str(refused.value) == (f"material: 'steel' never breaks (breakable: false in {ore}); "
                                  "breakable: copper_ore, granulite, limestone, my_ore")


@pytest.mark.parametrize("args, message", [
    (["bed_impact", "--materials", "BAD"],
     "BAD: materials.copper_ore.sigma: 0 is outside the allowed range (0, 10]"),
    (["single_particle", "--materials", "nosuch.yaml"], "nosuch.yaml: materials file not found"),
    (["collision", "--materials", "config/materials.yaml"],
     "--materials: scene 'collision' takes no materials file"),
    (["single_particle", "--materials", "config/materials.yaml", "--set", "materials_file=x.yaml"],
     "--materials: also given as --set materials_file; give one"),
])
def test_cli_bad_materials_one_line_exit_2_no_file(tmp_path, monkeypatch, capsys, args, message):
    monkeypatch.chdir(tmp_path)
    bad = tmp_path / "bad.yaml"
    bad.write_text(edited(("materials", "copper_ore", "sigma"), 0))
    args = [str(bad) if a == "BAD" else a for a in args]
    assert main(["run", *args, "--out", "case.nc", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"millsim: error: {message.replace('BAD', str(bad))}"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.yaml"]


def my_ore_file(tmp_path):
    """The shipped file with `my_ore`: copper ore, 10 times as strong and a little stiffer."""
    doc = copy.deepcopy(GOOD)
    ore = copy.deepcopy(doc["materials"]["copper_ore"])
    ore.update(source="a test ore", E_inf={"J_per_kg": 2135.0}, young_GPa=60)
    doc["materials"]["my_ore"] = ore
    path = tmp_path / "my_materials.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_user_ore_runs_through_single_particle(tmp_path):
    """`millsim run single_particle --materials FILE --set material=my_ore`: the case is made of
    my_ore (its median fracture energy, its energy share), and at copper ore's median input
    energy, where half the copper-ore particles would break, my_ore almost never does."""
    path = my_ore_file(tmp_path)
    mats = tavares_materials.load_materials(path, truncation="single_particle")
    mine, copper = mats["my_ore"], mats["copper_ore"]
    d = 5.5e-3
    energy = pred.stressing_median(copper, d, pred.absorbed_share(copper))
    out = tmp_path / "case.nc"
    assert main(["run", "single_particle", "--materials", str(path), "--set", "material=my_ore",
                 "--set", f"specific_energy={energy!r}", "--set", "n_particles=4",
                 "--set", "replacement=false", "--out", str(out), "--quiet"]) == 0
    ds = read_case(out)
    params = case_parameters(ds)
    assert params["material"] == "my_ore" and params["materials_file"] == str(path)
    share = pred.absorbed_share(mine)
    assert float(ds["absorbed_share"]) == pytest.approx(share)
    assert share != pytest.approx(pred.absorbed_share(copper))
    assert float(ds["median_fracture_energy"]) == pytest.approx(
        float(tv.median_fracture_energy(mine, d)))
    p_mine = float(pred.breakage_probability(mine, d, energy, share))
    assert float(ds["broken_fraction_analytic"]) == pytest.approx(p_mine)
    assert p_mine < 0.01 < 0.4 < float(pred.breakage_probability(copper, d, energy,
                                                                  pred.absorbed_share(copper)))
    assert int(ds["n_broken"]) == 0


# The closed upper ends of docs/materials.md's ranges (restitution (0, 1], sigma (0, 10],
# family_classes [2, 20]): the bound itself is a valid input, the next float above it is not
# (sampled mutant tavares_materials:72:52, `x > hi` -> `x >= hi`, refused the bound and no
# test saw it).
CLOSED_TOP = [(("contacts", "particle_particle", "restitution"), 1.0),
              (("materials", "copper_ore", "sigma"), 10.0),
              (("model", "family_classes"), 20)]


@pytest.mark.parametrize("keys, top", CLOSED_TOP, ids=[k[-1] for k, _ in CLOSED_TOP])
def test_a_closed_upper_bound_is_accepted_and_just_past_it_refused(tmp_path, keys, top):
    path = tmp_path / "m.yaml"
    path.write_text(edited(keys, top))
    tavares_materials.check_materials_file(path)
    path.write_text(edited(keys, math.nextafter(float(top), math.inf)))
    with pytest.raises(ValueError, match="is outside the allowed range|must be an integer"):
        tavares_materials.check_materials_file(path)


def test_the_default_materials_file_is_found_from_any_working_directory(tmp_path, monkeypatch):
    """The default path is relative to the repository ("config/materials.yaml"): a run started
    elsewhere (a Snakemake job's directory, a notebook) reads the shipped file, the same
    materials as from the root (sampled mutant tavares_materials:270:15, which looked one
    directory too high, passed every test run from the root)."""
    from_root = tavares_materials.load_materials()
    monkeypatch.chdir(tmp_path)
    assert not (tmp_path / tavares_materials.MATERIALS_FILE).exists()
    elsewhere = tavares_materials.load_materials()
    assert sorted(elsewhere) == sorted(from_root) == sorted(GOOD["materials"])
    assert elsewhere["copper_ore"].density == GOOD["materials"]["copper_ore"]["density_kg_m3"]
