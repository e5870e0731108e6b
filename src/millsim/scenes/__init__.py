"""Scenes: recipes that compose the engine into one kind of experiment.

A scene registers itself when its module is imported (``register(Scene(...))``,
:mod:`millsim.scenes.base`). Besides the modules of this package, scenes come from

- installed packages that name a module in the entry-point group ``millsim.scenes``
  (``[project.entry-points."millsim.scenes"]`` in their pyproject.toml), loaded with the
  built-in ones: ``millsim run``, ``millsim scenes`` and the workflow see them;
- a module given to ``millsim run --scene-module`` / ``millsim scenes --scene-module``: a file
  (``examples/my_scene.py``) or an importable name (``mypackage.scenes``).
"""

import hashlib
import importlib.util
import sys
from importlib import import_module, metadata
from pathlib import Path

SCENE_MODULES = ("collision", "packing", "ballmill2d", "stirred_mill", "bed_impact",
                 "single_particle", "silo", "ballmill3d")
ENTRY_POINT_GROUP = "millsim.scenes"

_loaded_entry_points = False


def load_all():
    """Import every scene module so that each registers itself: the built-in ones, then those
    of the entry-point group ``millsim.scenes`` (once per process)."""
    global _loaded_entry_points
    for name in SCENE_MODULES:
        import_module(f"{__name__}.{name}")
    if _loaded_entry_points:
        return
    _loaded_entry_points = True
    for entry in metadata.entry_points(group=ENTRY_POINT_GROUP):
        try:
            entry.load()
        except Exception as exc:  # a broken plugin is named, not a traceback from importlib
            raise ValueError(f"scene plugin {entry.name!r} ({entry.value}, entry point group "
                             f"{ENTRY_POINT_GROUP}): {type(exc).__name__}: {exc}") from exc


def load_module(spec, key="--scene-module"):
    """Import a user's scene module, which registers its scenes: ``spec`` is a ``.py`` file or
    an importable module name. Returns the module."""
    path = Path(spec)
    if path.suffix == ".py":
        if not path.is_file():
            raise ValueError(f"{key}: {spec}: no such file")
        # one name per file, the same in every process: a checkpoint names the scene's Case by
        # its module's name, and the resumed run imports the file again under it
        digest = hashlib.sha1(str(path.resolve()).encode()).hexdigest()[:8]
        name = f"millsim_user_scene_{path.stem}_{digest}"
        if name in sys.modules:
            return sys.modules[name]
        found = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(found)
        sys.modules[name] = module
        try:
            found.loader.exec_module(module)
        except BaseException:
            del sys.modules[name]
            raise
        return module
    try:
        return import_module(spec)
    except ModuleNotFoundError as exc:
        if exc.name and spec.startswith(exc.name):  # the module itself, not one it imports
            raise ValueError(f"{key}: no module named {spec!r} (a .py file, or a module on "
                             "the Python path)") from None
        raise
