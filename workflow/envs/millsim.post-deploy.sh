#!/usr/bin/env bash
# Runs once, inside the new conda environment of workflow/envs/millsim.yaml, in the directory
# Snakemake runs in: the repository root (where the Snakefile is).
set -euo pipefail
if ! grep -qs '^name = "millsim"' pyproject.toml; then
    echo "millsim.post-deploy.sh: run snakemake from the millsim repository root" \
        "(no millsim pyproject.toml in $(pwd))" >&2
    exit 1
fi
python -m pip install --no-input --quiet -c requirements/constraints.txt -e .
