"""The README and the guides in docs/ name only things that exist: every repository path, every
test named with ``::``, every ``millsim.`` dotted name, module-relative file and class attribute
they quote in backticks. The measurement pages of docs/results/ are dated records of their commit
and are left out."""

import importlib
import inspect
import math
import pkgutil
import re
from pathlib import Path

import pytest

import millsim

ROOT = Path(__file__).resolve().parents[1]
GUIDES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
TOP_DIRS = ("src", "tests", "tools", "bench", "docs", "workflow", "config", "examples", "profiles")
SUBPACKAGES = ("engine", "models", "scenes", "analysis", "plots", "util")
QUOTED = re.compile(r"`([^`\n]+)`")
REPO_PATH = re.compile(rf"((?:{'|'.join(TOP_DIRS)})/[\w./-]+?)/?(?:::(\w+))?")
PACKAGE_FILE = re.compile(rf"((?:{'|'.join(SUBPACKAGES)})/[\w/]*?(?:\.py)?)/?")
DOTTED = re.compile(r"[A-Za-z_]\w*(?:\.[A-Za-z_]\w*)+")


def _modules():
    found = {"millsim": millsim}
    for info in pkgutil.walk_packages(millsim.__path__, "millsim."):
        found[info.name] = importlib.import_module(info.name)
    return found


MODULES = _modules()
CLASSES = {name: obj for module in MODULES.values() for name, obj in vars(module).items()
           if inspect.isclass(obj) and obj.__module__.startswith("millsim")}


def _quoted(path):
    for number, line in enumerate(path.read_text().splitlines(), 1):
        for match in QUOTED.finditer(line):
            yield number, re.sub(r"\(.*\)$", "", match.group(1).strip())


def _has_attribute(obj, name):
    return hasattr(obj, name) or name in getattr(obj, "__dataclass_fields__", {}) or \
        name in getattr(obj, "__annotations__", {})


def _resolve(parts):
    """Whether millsim.<parts> names a module or an attribute chain below one."""
    for cut in range(len(parts), 0, -1):
        module = MODULES.get("millsim." + ".".join(parts[:cut]))
        if module is None:
            continue
        obj = module
        for name in parts[cut:]:
            if not _has_attribute(obj, name):
                return False
            obj = getattr(obj, name, None)
        return True
    return False


def problems(path):
    """(line, quoted text, what is wrong) for every quoted name of PATH that does not exist."""
    found = []
    for number, text in _quoted(path):
        if any(mark in text for mark in "*<{$ "):
            continue  # a pattern or a placeholder, not a name
        if match := REPO_PATH.fullmatch(text):
            target = ROOT / match.group(1)
            if not target.exists():
                found.append((number, text, "no such path"))
            elif match.group(2) and not re.search(rf"def {match.group(2)}\b", target.read_text()):
                found.append((number, text, "no such test"))
        elif match := PACKAGE_FILE.fullmatch(text):
            if not (ROOT / "src" / "millsim" / match.group(1)).exists():
                found.append((number, text, "no such file in src/millsim"))
        elif DOTTED.fullmatch(text):
            parts = text.split(".")
            if parts[0] == "millsim":
                parts = parts[1:]
            if parts[0] in SUBPACKAGES:
                if not _resolve(parts):
                    found.append((number, text, "no such module or name"))
            elif parts[0] in CLASSES and len(parts) == 2:
                if not _has_attribute(CLASSES[parts[0]], parts[1]):
                    found.append((number, text, f"{parts[0]} has no {parts[1]}"))
    return found


@pytest.mark.parametrize("path", GUIDES, ids=lambda p: p.name)
def test_quoted_names_exist(path):
    assert problems(path) == []


def test_the_checker_sees_a_stale_name(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("`tests/test_engine.py::no_such_test`, `engine/no_such.py`, "
                    "`millsim.engine.simulation.NoSuchThing`, `Simulation.no_such_method`, "
                    "`tests/test_engine.py`, `engine/mesh.py`, `Simulation.run`, `io.py`\n")
    assert [what for _, _, what in problems(page)] == [
        "no such test", "no such file in src/millsim", "no such module or name",
        "Simulation has no no_such_method"]


# quoted identifiers of other programs, or the reader's own (an ore of theirs), that the code base
# rightly never names
FOREIGN = {"Law2_ScGeom_ImplicitLubricationPhys", "my_ore"}
CODE_FILES = [p for d in ("src", "tests", "config", "workflow", "tools", "bench", "examples", "profiles")
              for p in (ROOT / d).rglob("*") if p.is_file() and
              p.suffix in (".py", ".yaml", ".yml", ".smk", ".rst", ".sh", ".json")]
CODE = "\n".join([p.read_text(errors="replace") for p in CODE_FILES] +
                 [(ROOT / f).read_text() for f in ("Snakefile", "Makefile", "pyproject.toml")])
IDENTIFIER = re.compile(r"[a-z]\w*_\w+|[A-Z][a-z]+[A-Z]\w*")  # snake_case or CamelCase


@pytest.mark.parametrize("path", GUIDES, ids=lambda p: p.name)
def test_quoted_identifiers_occur_in_the_code(path):
    """A quoted snake_case or CamelCase word (a function, key, variable, class) that no source,
    config or workflow file contains is a name the code no longer has."""
    stale = sorted({text for _, text in _quoted(path) if IDENTIFIER.fullmatch(text)
                    and text not in FOREIGN and not re.search(rf"\b{text}\b", CODE)})
    assert stale == []


def test_the_engine_guide_names_every_physics_switch():
    from millsim.engine.spec import PhysicsSpec

    guide = (ROOT / "docs" / "engine.md").read_text()
    missing = [f for f in PhysicsSpec.__dataclass_fields__ if f"`{f}`" not in guide]
    assert missing == []


def test_the_engine_guide_tables_every_contact_laws_constants():
    """docs/engine.md's table of the constants each law takes from an Interaction: the same
    laws, constants, defaults ("required": none) and allowed ranges as the laws declare
    (``ContactLaw.parameters``), so that a user reads what the code does (issue 47, seed 57:
    a law's default friction or its restitution's upper end changed, and no test saw it)."""
    from fractions import Fraction

    from millsim.models.contact import LAWS

    guide = (ROOT / "docs" / "engine.md").read_text()
    rows = re.findall(r"^\| `(\w+)` \| `(\w+)` \| [^|]+ \| ([^|]+) \| ([\[(])(\S+), (\S+)([\])]) \|$",
                      guide, re.M)
    documented = {(law, name): (default.strip(), lo_bracket, lo, hi, hi_bracket)
                  for law, name, default, lo_bracket, lo, hi, hi_bracket in rows}
    declared = {}
    for law in LAWS.values():
        for p in law.parameters:
            default = "required" if p.default is None else p.default
            hi = math.inf if p.hi is None else p.hi
            declared[(law.name, p.name)] = (default, "(" if p.lo_open else "[", p.lo, hi,
                                            ")" if p.hi_open or hi == math.inf else "]")
    assert sorted(documented) == sorted(declared)
    for key, (default, lo_bracket, lo, hi, hi_bracket) in documented.items():
        want = declared[key]
        got = (default if default == "required" else float(Fraction(default)), lo_bracket,
               float(lo), float(hi), hi_bracket)
        assert got == want, key


def test_the_engine_guide_tables_a_materials_fields():
    """docs/engine.md's table of a Material's fields: the same fields and defaults as the
    dataclass, and each range's ends refused or taken as the table's brackets say (issue 47,
    seed 57 `materials:25`: the default Poisson ratio changed, and no test saw it)."""
    import dataclasses

    from millsim.models import Material

    guide = (ROOT / "docs" / "engine.md").read_text()
    rows = re.findall(r"^\| `(\w+)` \| [^|]+ \| ([^|]+) \| ([^|]+) \|$", guide, re.M)
    fields = {f.name: f.default for f in dataclasses.fields(Material)}
    documented = {name: (default.strip(), allowed.strip()) for name, default, allowed in rows
                  if name in fields}
    assert sorted(documented) == sorted(fields)
    for name, (default, allowed) in documented.items():
        value = fields[name]
        if default.startswith("required"):
            assert value is dataclasses.MISSING or math.isnan(value), name
        else:
            assert value == float(default), name
        ends = re.fullmatch(r"([\[(])(\S+), (\S+)([\])])", allowed)
        if ends is None:
            continue
        given = {"name": "m", "density": 1000.0, "youngs_modulus": 1e9, "poisson_ratio": 0.3}
        for end, bracket in ((float(ends[2]), ends[1]), (float(ends[3]), ends[4])):
            if math.isinf(end):
                continue
            if bracket in "()":
                with pytest.raises(ValueError, match=rf"^m\.{name}: "):
                    Material(**{**given, name: end})
            else:
                assert getattr(Material(**{**given, name: end}), name) == end
