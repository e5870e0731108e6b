"""Scenes: recipes that compose the engine into one kind of experiment."""

from importlib import import_module

SCENE_MODULES = ("collision", "packing", "ballmill2d", "stirred_mill", "bed_impact",
                 "single_particle", "silo")


def load_all():
    """Import every scene module so that each registers itself."""
    for name in SCENE_MODULES:
        import_module(f"{__name__}.{name}")
