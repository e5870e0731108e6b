"""The packing scene's defaults are the LIGGGHTS benchmark's box case (bench/liggghts/*.in, the
peer's own input deck, shared/reference/peers.md part B): `millsim run packing` and
`python bench/liggghts.py --case box` time the same bed at the same steps."""

import re
from pathlib import Path

from millsim.scenes import load_all
from millsim.scenes.base import get_scene

DECKS = Path(__file__).resolve().parents[1] / "bench" / "liggghts"


def _deck(name):
    return (DECKS / name).read_text()


def _numbers(pattern, text):
    return [float(x) for x in re.search(pattern, text, re.M).groups()]


def test_the_box_defaults_are_the_liggghts_box_case():
    load_all()
    v = get_scene("packing").resolve({})
    settle, timed, common = _deck("in.box_settle"), _deck("in.box_bench"), _deck("common.in")
    # the stages: settling (its step count is the usage line's nsettle), then the timed run
    assert v["settle_dt"] == _numbers(r"^timestep\s+(\S+)", settle)[0]
    assert v["settle_steps"] == _numbers(r"-var nsettle (\d+)", settle)[0]
    assert v["dt"] == _numbers(r"^timestep\s+(\S+)", timed)[0]
    assert v["steps"] == _numbers(r"^run\s+(\d+)", timed)[0]
    # the bed: a simple-cubic lattice filling the box up to the fill region's top
    pitch = _numbers(r"^lattice\s+sc\s+(\S+)", settle)[0]
    x0, x1, y0, y1, z0, z1 = _numbers(r"^region\s+fill\s+block" + r"\s+(\S+)" * 6, settle)
    assert v["n"] == round((x1 - x0) / pitch) * round((y1 - y0) / pitch) * round((z1 - z0) / pitch)
    assert v["box_width"] == _numbers(r"^region\s+domain\s+block\s+\S+\s+(\S+)", settle)[0]
    assert 2.0 * v["radius"] == _numbers(r"^set\s+group all diameter\s+(\S+)", settle)[0]
    assert v["density"] == _numbers(r"^set\s+group all density\s+(\S+)", settle)[0]
    # the material and the contact law (no rolling friction model in the pair style)
    assert v["youngs_modulus"] == _numbers(r"youngsModulus peratomtype\s+(\S+)", common)[0]
    assert v["poisson_ratio"] == _numbers(r"poissonsRatio peratomtype\s+(\S+)", common)[0]
    assert v["restitution"] == _numbers(r"coefficientRestitution peratomtypepair 1\s+(\S+)",
                                        common)[0]
    assert v["friction"] == _numbers(r"coefficientFriction peratomtypepair 1\s+(\S+)", common)[0]
    pair_style = re.search(r"^pair_style.*$", common, re.M)[0]
    assert "rolling_friction" not in pair_style and v["rolling_friction"] == 0.0
    assert v["skin"] == _numbers(r"^neighbor\s+(\S+)", common)[0]
