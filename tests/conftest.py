"""Fixtures shared by test files."""

import os
import shutil
from pathlib import Path

import pytest

from millsim.models.breakage import tavares_materials

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """A copy of the workflow (Snakefile, workflow/, config/) to run Snakemake in."""
    for name in ("Snakefile", "workflow", "config"):
        source = ROOT / name
        (shutil.copytree if source.is_dir() else shutil.copy)(source, tmp_path / name)
    monkeypatch.chdir(tmp_path)  # the API changes into its workdir; undone after the test
    monkeypatch.setenv("PATH", os.environ["PATH"])  # common.smk prepends the venv; undone too
    return tmp_path


# the Tavares materials (config/materials.yaml) with the truncation of the bed and of the
# single-particle verification, for the breakage tests (test_tavares_model.py has its own)
@pytest.fixture(scope="module")
def mats():
    return tavares_materials.load_materials(truncation="bed")


@pytest.fixture(scope="module")
def mats_sp():
    return tavares_materials.load_materials(truncation="single_particle")
