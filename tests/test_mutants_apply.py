"""Every curated mutant of tools/mutants.yaml still applies to the code and names test files that
exist. ``make mutate`` reports a stale mutant, but it is not part of CI: a reformatted line once
left one testing nothing for two sessions unnoticed."""

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _mutate_tool():
    spec = importlib.util.spec_from_file_location("mutate_tool", ROOT / "tools" / "mutate.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


MUTATE = _mutate_tool()
MUTANTS = MUTATE.load_mutants()


@pytest.mark.parametrize("mutant", MUTANTS, ids=[m["id"] for m in MUTANTS])
def test_mutant_applies_and_names_existing_tests(mutant):
    assert MUTATE.staleness(mutant, (ROOT / mutant["file"]).read_text()) is None
    assert mutant["find"] != mutant["replace"]
    missing = [t for t in mutant["tests"] if not (ROOT / t.split("::")[0]).exists()]
    assert not missing, f"{mutant['id']} names missing test files {missing}"
