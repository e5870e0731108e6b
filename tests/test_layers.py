"""The package's layers only look down (millsim.LAYERS): engine < models < scenes < studies.

Read from the source, not by importing: every ``import``/``from ... import`` of a millsim module is
checked against the layer of the importing module. Also: the analysis imports no numba, no plots and
no scene; no scene imports the analysis.
"""

import ast
from pathlib import Path

import millsim

ROOT = Path(millsim.__file__).parent


def _layer_of(module):
    """Index in millsim.LAYERS of a dotted module path below millsim ('engine.loop' -> 1); the
    package's own __init__ (names imported from it: "millsim" or "millsim.name") is the base."""
    top = module.split(".")[0]
    if not module or not ((ROOT / top).is_dir() or (ROOT / f"{top}.py").exists()):
        return 0
    for k, (_, parts) in enumerate(millsim.LAYERS):
        if top in parts:
            return k
    raise AssertionError(f"millsim.{module}: not in any layer of millsim.LAYERS")


def _imports(path):
    """(line, imported module below millsim or a third-party top name) of one source file."""
    rel = path.relative_to(ROOT).with_suffix("")
    package = list(rel.parts[:-1]) if rel.name != "__init__" else list(rel.parts[:-1])
    tree = ast.parse(path.read_text(), str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
                names = [mod] if node.module else [".".join(base + [a.name]) for a in node.names]
                for name in names:
                    yield node.lineno, "millsim." + name if name else "millsim"
            else:
                yield node.lineno, node.module


def _sources():
    return [p for p in sorted(ROOT.rglob("*.py")) if p.name != "__init__.py" or p.parent != ROOT]


def test_every_module_has_a_layer():
    for path in _sources():
        _layer_of(".".join(path.relative_to(ROOT).with_suffix("").parts))


def test_imports_only_look_down():
    wrong = []
    for path in _sources():
        own = _layer_of(".".join(path.relative_to(ROOT).with_suffix("").parts))
        for line, mod in _imports(path):
            if not mod.startswith("millsim.") or mod == "millsim":
                continue
            target = _layer_of(mod[len("millsim."):])
            if target > own:
                wrong.append(f"{path.relative_to(ROOT)}:{line} imports {mod} "
                             f"({millsim.LAYERS[own][0]} -> {millsim.LAYERS[target][0]})")
    assert not wrong, "imports that run up the layers:\n" + "\n".join(wrong)


def test_analysis_imports_no_numba_plots_or_scenes():
    wrong = []
    for path in sorted((ROOT / "analysis").rglob("*.py")):
        for line, mod in _imports(path):
            if mod.split(".")[0] == "numba" or mod.startswith(("millsim.plots", "millsim.scenes")):
                wrong.append(f"{path.relative_to(ROOT)}:{line} imports {mod}")
    assert not wrong, "\n".join(wrong)


def test_the_rule_sees_relative_imports():
    """The checker is not vacuous: relative imports resolve to the modules they name, and a
    model sits above the engine."""
    found = dict((mod, line) for line, mod in _imports(ROOT / "engine" / "simulation.py"))
    assert "millsim.engine.loop" in found
    found = dict((mod, line) for line, mod in _imports(ROOT / "engine" / "walls.py"))
    assert "millsim.util.validation" in found
    found = {mod for _, mod in _imports(ROOT / "models" / "contact" / "linear_hw.py")}
    assert "millsim.engine.timestep" in found and "millsim.models.contact.base" in found
    assert _layer_of("models.contact") > _layer_of("engine.loop") > _layer_of("util.stats")
