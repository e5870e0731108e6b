"""Fixtures shared by test files."""

import os
import shutil
from pathlib import Path

import pytest

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
