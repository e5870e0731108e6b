# One command for the main job, one for the tests; both create .venv and install what they need.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
CORES ?= 2
CONSTRAINTS := requirements/constraints.txt

.PHONY: run test lint lint-fix bench mutate lock clean-results help

help:
	@echo "make run    - install into .venv and run the default quick study (all scenes, plots, report)"
	@echo "make test   - install into .venv (with the test extra), lint, and run the test suite"
	@echo "make lint   - the lint step of make test alone: ruff check, snakefmt --check"
	@echo "make lint-fix - what ruff and snakefmt fix themselves (ruff check --fix, snakefmt)"
	@echo "make bench  - engine throughput benchmark against LIGGGHTS (box case, 1 core)"
	@echo "make mutate - curated physics mutants against the tests, kill rate per module (~1 h)"
	@echo "make lock   - re-resolve the newest allowed dependency versions into $(CONSTRAINTS)"

$(STAMP): pyproject.toml $(CONSTRAINTS)
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -c $(CONSTRAINTS) -e ".[test]"
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/snakemake --cores $(CORES)
	$(BIN)/snakemake --report results/report.html

# Lint first (seconds; settings in pyproject.toml), then the test files in parallel, one worker
# per core (compiling each physics variant dominates; the workers share the on-disk kernel cache).
test: lint
	$(BIN)/python -m pytest -n auto --dist worksteal

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/snakefmt --check Snakefile workflow

lint-fix: $(STAMP)
	$(BIN)/ruff check --fix .
	$(BIN)/snakefmt Snakefile workflow

bench: $(STAMP)
	$(BIN)/python bench/engine_throughput.py --case box --cores 1 --json bench/out/box_1.json

mutate: $(STAMP)
	$(BIN)/python tools/mutate.py --out results/mutation.md --json results/mutation.json

# A fresh environment with the newest versions pyproject.toml allows, frozen as constraints.
lock:
	rm -rf .lock-venv
	$(PYTHON) -m venv .lock-venv
	.lock-venv/bin/pip install --quiet --upgrade pip
	.lock-venv/bin/pip install --quiet -e ".[test]"
	{ head -2 $(CONSTRAINTS); echo "# Python 3.11, Linux x86_64. Generated $$(date -u +%Y-%m-%d)."; \
	  .lock-venv/bin/pip freeze --exclude-editable | grep -v '^millsim'; } > $(CONSTRAINTS).new
	mv $(CONSTRAINTS).new $(CONSTRAINTS)
	rm -rf .lock-venv

clean-results:
	rm -rf results/cases results/aggregate results/plots results/logs results/report.html
