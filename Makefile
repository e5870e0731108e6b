# One command for the main job, one for the tests; both create .venv and install what they need.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
CORES ?= 2

.PHONY: run test bench clean-results help

help:
	@echo "make run    - install into .venv and run the default quick study (all scenes, plots, report)"
	@echo "make test   - install into .venv (with the test extra) and run the test suite"
	@echo "make bench  - engine throughput benchmark against LIGGGHTS (box case, 1 core)"

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[test]"
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/snakemake --cores $(CORES)
	$(BIN)/snakemake --report results/report.html

test: $(STAMP)
	$(BIN)/python -m pytest

bench: $(STAMP)
	$(BIN)/python bench/engine_throughput.py --case box --cores 1 --json bench/out/box_1.json

clean-results:
	rm -rf results/cases results/aggregate results/plots results/logs results/report.html
