"""Every scene declares its case file once: ``series`` (recorded) and ``outputs`` (summaries,
:class:`~millsim.scenes.driver.Output`), with units and long names; ``finish`` returns values only
and the driver writes exactly what is declared.

The tables are checked for every registered scene without a run; the written file is checked on
two cheap runs (collision, single_particle: the compiled loops the suite builds anyway). The other
scenes' own tests run them through the same driver, which refuses a missing or undeclared output.
"""

import pytest

from millsim.cli import main
from millsim.io import read_case
from millsim.scenes import load_all
from millsim.scenes.base import REGISTRY, RunContext
from millsim.scenes.driver import Case, Output, Series, summary_variables

load_all()
SCENES = sorted(REGISTRY)


def _case_class(scene):
    build = scene.build
    return build if isinstance(build, type) and issubclass(build, Case) else None


@pytest.mark.parametrize("name", SCENES)
def test_declared_tables_have_unique_names_units_and_long_names(name):
    case = _case_class(REGISTRY[name])
    assert case is not None, f"{name}: build is not a Case class; its tables cannot be read"
    assert all(isinstance(s, Series) for s in case.series)
    assert all(isinstance(o, Output) for o in case.outputs)
    names = ["time"] * bool(case.series) + [s.name for s in case.series] + [
        o.name for o in case.outputs]
    assert len(names) == len(set(names)), f"{name}: a name declared twice"
    for entry in (*case.series, *case.outputs):
        assert isinstance(entry.units, str) and entry.units, f"{name}.{entry.name}: no units"
        assert isinstance(entry.long_name, str) and entry.long_name.strip(), \
            f"{name}.{entry.name}: no long name"
    for o in case.outputs:
        assert isinstance(o.dims, tuple) and all(isinstance(d, str) for d in o.dims), \
            f"{name}.{o.name}: dims must be a tuple of dimension names"
        assert o.when is None or callable(o.when)
        assert {"units", "long_name"}.isdisjoint(o.cf), f"{name}.{o.name}: units twice"
    # a coordinate is declared for every dimension an output uses (the time of the series aside)
    coords = {o.name for o in case.outputs if o.coord}
    for o in case.outputs:
        for dim in o.dims:
            assert dim in coords or dim == "bound", f"{name}.{o.name}: no coordinate {dim!r}"


def _check_file(path, scene, values):
    """The case file holds exactly the declared variables that apply, with their attributes."""
    case = _case_class(scene)
    ds = read_case(path, scene.name)
    expected = {o.name: o for o in case.outputs if o.when is None or o.when(values)}
    series = {s.name: s for s in case.series}
    written = set(ds.variables)
    assert written == set(expected) | set(series) | ({"time"} if series else set())
    for name, o in expected.items():
        assert ds[name].dims == o.dims, name
        assert ds[name].attrs == o.attrs(), name
    for name, s in series.items():
        assert ds[name].dims == ("time",)
        assert ds[name].attrs == {"units": s.units, "long_name": s.long_name}


@pytest.mark.parametrize("name, overrides", [
    ("collision", {}),
    ("single_particle", {"n_particles": 4}),  # with replacement: the sieve outputs too
])
def test_case_file_holds_exactly_the_declared_outputs(tmp_path, name, overrides):
    scene = REGISTRY[name]
    values = scene.resolve(overrides)
    path = tmp_path / "case.nc"
    scene.run(values, RunContext(), out=path)
    _check_file(path, scene, values)


def test_driver_refuses_a_missing_or_undeclared_output_naming_scene_and_variable():
    outputs = (Output("a", (), "m", "a length"),
               Output("b", (), "s", "a time", when=lambda values: values["with_b"]))
    data, coords = summary_variables("demo", outputs, {"with_b": False}, {"a": 1.0})
    assert data == {"a": ((), 1.0, {"units": "m", "long_name": "a length"})} and coords == {}
    with pytest.raises(ValueError, match=r"^scene demo: finish did not return the declared "
                                         r"output 'b'$"):
        summary_variables("demo", outputs, {"with_b": True}, {"a": 1.0})
    with pytest.raises(ValueError, match=r"^scene demo: finish returned 'c', which is not "
                                         r"declared in its outputs$"):
        summary_variables("demo", outputs, {"with_b": False}, {"a": 1.0, "c": 2})
    with pytest.raises(ValueError, match=r"^scene demo: finish returned 'b', which does not "
                                         r"apply to these parameters$"):
        summary_variables("demo", outputs, {"with_b": False}, {"a": 1.0, "b": 2.0})


def test_scenes_command_lists_the_declared_case_file(capsys):
    assert main(["scenes", "collision"]) == 0
    out = capsys.readouterr().out
    assert "  overlap(time) [m]: normal overlap" in out
    assert "  restitution [1]: measured coefficient of restitution; last normal velocity" in out
