"""Walls from the config (scenes/config_walls.py, docs/walls.md "Walls from the config") and the
wall ramp (engine/kinematics.py ``ramp_walls``).

- A ramped wall against the closed forms of a start from rest at constant acceleration over T:
  omega(t) = omega t / T, angle omega t^2 / (2T) (a mesh's), point p0 + v t^2 / (2T), each
  the full rate and p0 + v (t - T/2) after T; a turning cylinder's surface speed omega(t) x the
  contact radius.
- The packing scene with a plate from ``walls``, rising with a ramp under its one sphere: the
  sphere rides it (z = plate + r to within the Hertz overlap, vz = v); without the plate it
  would lie on the box's floor.
- Every scene but the 2D ball mill hands the config's walls to its Simulation, after its own.
- Bad input is refused in one line naming the key; the schema checks the structure and keeps in
  step with the wall registry; the list is recorded in the case file as YAML text.

One compiled variant for the file: the packing scene's spec with the switches its user walls
turn on (walls, translating, mesh, ramped; Hertz-Mindlin), which the engine tests use too.
"""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from millsim.engine import PhysicsSpec, Simulation
from millsim.engine.kinematics import W_COS, W_MATERIAL, W_OMEGA, W_POINT, W_SIN, W_VELOCITY
from millsim.engine.mesh_io import box_mesh, write_stl
from millsim.engine.walls import BY_NAME, wall_contact
from millsim.models import Interaction, Material, MaterialTable
from millsim.scenes import load_all
from millsim.scenes.base import REGISTRY, get_scene
from millsim.scenes.config_walls import scene_walls

ROOT = Path(__file__).resolve().parents[1]
SPEC = PhysicsSpec(dim=3, walls=True, translating_walls=True, mesh_walls=True, ramped_walls=True)
T = 0.02  # ramp [s]


def _table():
    return MaterialTable([Material("grain", 2500.0, 5e6, 0.3)],
                         {"*": Interaction(restitution=0.5, friction=0.3)}, "hertz_mindlin")


def _ramped(t, full):
    """(rate, distance at that rate) of a start from rest at constant acceleration over T."""
    if t < T:
        return full * t / T, full * t * t / (2 * T)
    return full, full * (t - T / 2)


def test_ramped_walls_follow_the_closed_form():
    omega, v, omega_mesh = 3.0, 0.5, 2.0
    vertices, faces = box_mesh((1.0, 1.0, 1.0), (1.1, 1.1, 1.1))
    walls = [dict(kind="cylinder_inner", point=(0, 0, 0), axis=(0, 0, 1), radius=0.5,
                  omega=omega, ramp=T, material="grain"),
             dict(kind="plane", point=(0, 0, -0.2), normal=(0, 0, 1), velocity=(0, 0, v),
                  ramp=T, material="grain"),
             dict(kind="mesh", vertices=vertices, faces=faces, point=(1.05, 1.05, 1.05),
                  omega=omega_mesh, ramp=T, material="grain")]
    sim = Simulation(SPEC, _table(), x=[[0.0, 0.0, 0.0]], radius=[1e-3], material="grain",
                     walls=walls, gravity=(0, 0, 0))
    assert sim.walls[0, W_OMEGA] == 0.0 and not sim.walls[1, W_VELOCITY].any()  # at rest at 0
    for target in (0.3 * T, 0.7 * T, 1.6 * T):
        sim.run(int(round(target / sim.dt)) - sim.step)
        t = sim.time
        rate, angle = _ramped(t, omega)
        assert sim.walls[0, W_OMEGA] == pytest.approx(rate, rel=1e-12)
        # the surface speed at a contact: omega(t) x the mid-overlap radius
        xi, *_, w0, w1, w2 = wall_contact(sim.walls[0], 0.4995, 0.0, 0.0, 1e-3)
        assert math.hypot(w0, w1, w2) == pytest.approx(rate * (0.5 + 0.5 * xi), rel=1e-12)
        speed, rise = _ramped(t, v)
        assert sim.walls[1, W_VELOCITY] == pytest.approx([0, 0, speed], rel=1e-12)
        assert sim.walls[1, W_POINT] == pytest.approx([0, 0, -0.2 + rise], rel=1e-12, abs=1e-15)
        _, turned = _ramped(t, omega_mesh)
        got = math.atan2(sim.walls[2, W_SIN], sim.walls[2, W_COS])
        assert math.remainder(got - turned, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


def test_set_wall_leaves_a_ramp_alone():
    sim = Simulation(SPEC, _table(), x=[[0.0, 0.0, 0.0]], radius=[1e-3], material="grain",
                     walls=[dict(kind="plane", normal=(0, 0, 1), point=(0, 0, -1), omega=1.0,
                                 ramp=T, material="grain")], gravity=(0, 0, 0))
    with pytest.raises(ValueError, match=r"walls\[0\]: a ramped wall's point"):
        sim.set_wall(0, omega=2.0)


@pytest.fixture(scope="module")
def liner_file(tmp_path_factory):
    """A walls YAML file with a mesh (a box STL) beside the packing box, and a rising plate."""
    where = tmp_path_factory.mktemp("walls")
    write_stl(where / "block.stl", *box_mesh((0.1, 0.1, 0.0), (0.12, 0.12, 0.02)))
    walls = [dict(kind="plane", point=[0, 0, 0], normal=[0, 0, 1], velocity=[0, 0, 0.05],
                  ramp=T, material="grain"),
             dict(kind="mesh", file=str(where / "block.stl"), scale=1.0, point=[0.11, 0.11, 0],
                  axis=[0, 0, 1], omega=1.0, ramp=T, material="grain")]
    path = where / "walls.yaml"
    path.write_text(yaml.safe_dump(walls))
    return path


def test_a_plate_from_the_config_lifts_the_sphere(liner_file):
    """The packing box's one sphere falls 0.1 r onto the floor and a plate of the config that
    rises from it with a ramp: it rides the plate, not the floor."""
    scene = get_scene("packing")
    values = scene.resolve({"n": "1", "walls": str(liner_file)})
    case = scene.build(values)
    sim, r = case.sim, values["radius"]
    assert sim.spec == SPEC  # the variant the engine test compiled
    assert len(sim.walls) == 5 + 2  # the box's five, then the config's
    sim.run(int(round(2 * T / sim.dt)))
    _, plate = _ramped(sim.time, 0.05)
    z, vz = sim.particles.x[0, 2], sim.particles.v[0, 2]
    assert z == pytest.approx(plate + r, abs=0.01 * r)  # Hertz overlap m g / ... ~ 1e-3 r
    assert vz == pytest.approx(0.05, rel=0.02)


def test_the_case_file_records_the_walls(tmp_path, monkeypatch, liner_file):
    from millsim.cli import main
    from millsim.io import read_case

    monkeypatch.chdir(tmp_path)
    sets = ["n=1", "settle_steps=20", "steps=20", "record_every=10", f"walls={liner_file}"]
    assert main(["run", "packing", *(a for s in sets for a in ("--set", s)), "--out", "c.nc",
                 "--quiet"]) == 0
    ds = read_case("c.nc")
    given = yaml.safe_load(liner_file.read_text())
    assert yaml.safe_load(ds.attrs["param_walls"]) == given
    assert json.loads(ds.attrs["parameters_json"])["walls"] == given


FAR = "[{kind: plane, point: [0, 0, -50], normal: [0, 0, 1], material: %s}]"
SMALL = {"collision": {}, "packing": {"n": "8"}, "ballmill2d": None,
         "stirred_mill": dict(scale="0.3", slice="true", n_beads="40", eta="0"),
         "bed_impact": {"rings": "1"}, "single_particle": {},
         "silo": dict(n="300", silo_radius="0.009", orifice_diameter="0.010",
                      pour_height="0.025", settle_time="0.15", discharge_time="0.2")}


@pytest.mark.parametrize("name", sorted(SMALL))
def test_every_scene_adds_the_config_walls_after_its_own(name):
    scene = get_scene(name)
    if SMALL[name] is None:
        with pytest.raises(ValueError, match="walls: scene 'ballmill2d' takes no walls from the "
                                             "config: a 2D mill"):
            scene.resolve({"walls": FAR % "grain"})
        return
    bare = scene.build(scene.resolve(SMALL[name])).sim
    values = scene.resolve(SMALL[name])
    material = scene.wall_materials(values)[-1]
    sim = scene.build(scene.resolve({**SMALL[name], "walls": FAR % material})).sim
    assert np.array_equal(sim.walls[:-1], bare.walls)
    assert len(sim.walls) == len(bare.walls) + 1
    assert sim.walls[-1, W_POINT].tolist() == [0.0, 0.0, -50.0]
    assert sim.material_index(material) == int(sim.walls[-1, W_MATERIAL])


def test_every_registered_scene_takes_walls():
    load_all()
    assert set(REGISTRY) >= set(SMALL)
    for scene in REGISTRY.values():
        assert "walls" in {p.name for p in scene.params}


def test_a_walls_file_with_the_example_liner_parses(tmp_path):
    path = tmp_path / "chamber.yaml"
    path.write_text(f"- {{kind: mesh, file: {ROOT / 'examples/meshes/ballmill_liner.stl'}, "
                    "scale: 1.0, axis: [0, 1, 0], omega: 2.0, ramp: 0.5, material: grain}\n"
                    "- {kind: frustum, point: [0, 0, 0.2], axis: [0, 0, 1], start: [0, 0.05], "
                    "end: [0.1, 0.02], material: grain}\n")
    walls = get_scene("packing").resolve({"walls": str(path)})["walls"]
    assert [w["kind"] for w in walls] == ["mesh", "frustum"]


def _open_mesh(path):
    vertices, faces = box_mesh((0, 0, 0), (0.01, 0.01, 0.01))
    write_stl(path, vertices, faces[:-2])  # one face of the box missing
    return path


@pytest.mark.parametrize("walls, needle", [
    ("[{kind: sphere, material: particle}]", r"walls\[0\]\.kind: must be one of \['annulus'"),
    ("[{kind: plane, normal: [0, 0, 1], inner_radius: 1, material: particle}]",
     r"walls\[0\]: unknown keys \['inner_radius'\] for a plane wall"),
    ("[{kind: plane, normal: [0, 0, 1], material: particle}, "
     "{kind: cylinder_inner, axis: [0, 0, 1], material: particle}]",
     r"walls\[1\]\.radius: required for a cylinder_inner wall"),
    ("[{kind: plane, normal: [0, 0, 1]}]", r"walls\[0\]\.material: required"),
    ("[{kind: plane, normal: [0, 0, 1], material: steel}]",
     r"walls\[0\]\.material: 'steel' is not a material of scene 'collision'; available: particle"),
    ("[{kind: mesh, file: nowhere.stl, material: particle}]",
     r"walls\[0\]\.file: nowhere.stl: no such file"),
    ("[{kind: mesh, file: OPEN, material: particle}]", r"walls\[0\]\.file: .*open mesh"),
    ("{kind: plane, normal: [0, 0, 1], material: particle}", r"walls: must be a list of walls"),
    ("[plane]", r"walls\[0\]: must be a mapping"),
    ("nowhere.yaml", r"walls: nowhere.yaml: no such file"),
    ("[{kind: plane, point: [0, 0], normal: [0, 0, 1], material: particle}]",
     r"walls\[0\]\.point: must be 3 finite numbers"),
    ("[{kind: plane, normal: [0, 0, 1], ramp: -1, material: particle}]",
     r"walls\[0\]\.ramp: must be a finite time >= 0"),
    ("[{kind: cylinder_inner, axis: [0, 0, 1], radius: 400, material: particle}]",
     r"walls\[0\]\.radius: 400 m is beyond 100 m"),
    ("[{kind: mesh, file: MM, material: particle}]", r"walls\[0\]\.scale: the mesh spans 200 m"),
    ("[{kind: plane, point: [0, a, 0], normal: [0, 0, 1], material: particle}]",
     r"walls\[0\]\.point: must be 3 finite numbers, got \[0, 'a', 0\]"),
    ("[{kind: plane, normal: [0, 0, 1], file: nowhere.stl, material: particle}]",
     r"walls\[0\]: unknown keys \['file'\] for a plane wall"),
    ("[{kind: mesh, file: BOX, triangle_materials: [particle, particle, steel, particle, particle, "
     "particle, particle, particle, particle, particle, particle, particle], material: particle}]",
     r"walls\[0\]\.triangle_materials\[2\]: 'steel' is not a material of scene 'collision'"),
])
def test_bad_walls_are_refused_in_one_line_naming_the_key(tmp_path, walls, needle):
    walls = walls.replace("OPEN", str(_open_mesh(tmp_path / "open.stl")))
    if "MM" in walls:  # a box 200 mm wide, its file in mm given without scale
        write_stl(tmp_path / "mm.stl", *box_mesh((0, 0, 0), (200.0, 200.0, 200.0)))
        walls = walls.replace("MM", str(tmp_path / "mm.stl"))
    if "BOX" in walls:  # 12 triangles
        write_stl(tmp_path / "box.stl", *box_mesh((0, 0, 0), (0.01, 0.01, 0.01)))
        walls = walls.replace("BOX", str(tmp_path / "box.stl"))
    with pytest.raises(ValueError) as err:
        get_scene("collision").resolve({"walls": walls})
    assert re.search(needle, str(err.value)) and "\n" not in str(err.value)


def test_text_that_is_not_yaml_is_refused_with_the_parsers_reason_cut_at_160_characters():
    """One line: the YAML parser's message, its whitespace collapsed, cut at 160 characters."""
    text = "[{kind: plane, normal: [0, 0, 1]"
    with pytest.raises(yaml.YAMLError) as parser:
        yaml.safe_load(text)
    reason = " ".join(str(parser.value).split())
    assert len(reason) > 160
    with pytest.raises(ValueError) as err:
        get_scene("collision").resolve({"walls": text})
    assert str(err.value) == f"walls: not YAML ({reason[:160]})"


def test_walls_switch_on_only_the_motions_they_declare():
    """A still plane needs walls alone; a velocity, translating walls; a ramp, ramped walls
    (each switch is another compiled variant: none is asked for without cause)."""
    plane = dict(kind="plane", normal=(0, 0, 1), material="particle")
    base = PhysicsSpec(dim=3)
    assert scene_walls({"walls": [plane]}, base, [])[0] == PhysicsSpec(dim=3, walls=True)
    moving = dict(plane, velocity=(0.0, 0.0, 0.1))
    assert scene_walls({"walls": [moving]}, base, [])[0] == PhysicsSpec(
        dim=3, walls=True, translating_walls=True)
    ramped = dict(plane, omega=1.0, ramp=0.5)
    assert scene_walls({"walls": [ramped]}, base, [])[0] == PhysicsSpec(
        dim=3, walls=True, ramped_walls=True)
    assert scene_walls({"walls": []}, base, []) == (base, [])


# ---- the schema, the pipeline, the docs --------------------------------------------------------

SCHEMA = ROOT / "workflow" / "schemas" / "config.schema.yaml"


def _config():
    return yaml.safe_load((ROOT / "config" / "config.yaml").read_text())


def test_the_schema_takes_walls_and_refuses_bad_ones():
    from snakemake.exceptions import WorkflowError
    from snakemake.utils import validate

    good = [{"kind": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "material": "grain",
             "velocity": [0, 0, 0.1], "ramp": 0.5},
            {"kind": "mesh", "file": "liner.stl", "scale": 0.001, "material": "grain"}]
    config = _config()
    config["ballmill"]["parameters"]["walls"] = good
    validate(config, str(SCHEMA))
    config["ballmill"]["parameters"]["walls"] = "chamber.yaml"
    validate(config, str(SCHEMA))
    for bad in ({"kind": "sphere", "material": "grain"}, {"kind": "plane"},
                {"kind": "plane", "material": "grain", "point": [0, 0]},
                {"kind": "plane", "material": "grain", "colour": "red"},
                {"kind": "plane", "material": "grain", "ramp": -1.0}):
            config = _config()
            config["ballmill"]["parameters"]["walls"] = [bad]
            with pytest.raises(WorkflowError):
                validate(config, str(SCHEMA))


def test_the_schema_knows_the_registry_kinds_and_keys():
    wall = yaml.safe_load(SCHEMA.read_text())["$defs"]["wall"]
    assert sorted(wall["properties"]["kind"]["enum"]) == sorted(BY_NAME)
    assert set(wall["properties"]) == set().union(*(kind.keys for kind in BY_NAME.values()))


def test_the_docs_examples_resolve():
    """The command line and the config of docs/walls.md, "Walls from the config", hold valid
    walls of their scenes, and the config passes the schema."""
    from snakemake.utils import validate

    text = (ROOT / "docs" / "walls.md").read_text().split("## Walls from the config")[1]
    line = re.search(r"millsim run packing --set '(walls=.*?)'", text).group(1)
    assert get_scene("packing").resolve({"walls": line.split("=", 1)[1]})["walls"][0]["ramp"] > 0
    block = yaml.safe_load(re.search(r"```yaml\n(.*?)```", text, re.S).group(1))
    walls = block["stirred_mill"]["parameters"]["walls"]
    assert get_scene("stirred_mill").resolve({"walls": json.dumps(walls)})["walls"] == walls
    config = _config()
    config["stirred_mill"]["parameters"]["walls"] = walls
    validate(config, str(SCHEMA))


def _dry_run(workdir, config):
    """The files a dry run of ``config`` plans (tests/test_workflow.py's way)."""
    from snakemake import api
    from snakemake.settings import types as settings

    (workdir / "config" / "config.yaml").write_text(yaml.safe_dump(config))
    updated = []
    output = settings.OutputSettings(dryrun=True, quiet={settings.Quietness.ALL})
    with api.SnakemakeApi(output) as sm:
        workflow = sm.workflow(resource_settings=settings.ResourceSettings(cores=2),
                               snakefile=workdir / "Snakefile", workdir=workdir)
        workflow.dag(settings.DAGSettings(targets={"single_particle"})).execute_workflow(
            executor="dryrun", updated_files=updated)
    return {str(Path(f)) for f in updated}


def test_the_pipeline_takes_a_walls_list_as_one_value(workdir):
    """A list of walls under `parameters` is no sweep: the same cases as without it (no
    walls~ in their paths); a wall of a material the scene lacks is refused before any job."""
    config = _config()
    bare = _dry_run(workdir, config)
    plate = {"kind": "plane", "point": [0, 0, -1], "normal": [0, 0, 1], "material": "steel"}
    config["single_particle"].setdefault("parameters", {})["walls"] = [plate, plate]
    assert _dry_run(workdir, config) == bare and not any("walls" in f for f in bare)
    plate["material"] = "rubber"
    with pytest.raises(Exception, match=r"walls\[0\]\.material: 'rubber' is not a material"):
        _dry_run(workdir, config)
    assert not (workdir / "results").exists()
