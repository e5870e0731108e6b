"""Configuration: validation, the cases of every study, the figures, and the paths the rules share.

A study is one scene run over a parameter space: fixed parameters plus the Cartesian product of
the swept ones (those given as lists). Case paths encode the swept values, e.g.
results/cases/ballmill/n_over_nc~0.5/case.nc; fixed parameters reach the jobs as params, so a
change of either re-runs exactly the affected cases.

Parameter ranges are declared once, by the scenes: the schema checks only the config's structure,
and every case of every study is resolved by its scene (`millsim scenes NAME` lists the ranges)
before any job starts; so are a value given twice in one sweep, and, for every case Snakemake
schedules, a time step above the stability limit (the case is built, as `millsim run` would).
The figures and their captions come from the plot registry (`millsim plot --list`); figure NAME
is results/plots/NAME.png.
"""

import atexit
import json
import os
import shlex
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
from snakemake.exceptions import WorkflowError
from snakemake.utils import Paramspace, validate

import millsim
from millsim.io import atomic_target
from millsim.scenes.base import get_scene

validate(config, schema="../schemas/config.schema.yaml")

# A run killed outright leaves Snakemake's lock, and the same command would refuse to start:
# removed here when no Snakemake process on this machine runs in the directory (millsim.workflow).
if config.get("stale_locks", "remove") == "remove":
    from millsim.workflow import remove_stale_locks

    remove_stale_locks(say=lambda line: print(line, file=sys.stderr))

# The rules call `millsim`; the one beside this Python comes first, so that a virtual
# environment works without being activated.
os.environ.update(
    PATH=os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")])
)

# A simulate rule's param: Snakemake's code trigger does not see the imported package. The
# version too: `millsim aggregate` refuses cases of two versions, so a new one re-runs them.
ENGINE = f"{millsim.provenance_hash()}-{millsim.__version__}"

# The software of every rule under `--use-conda` (relative to the rule files); without it the
# rules run the `millsim` beside this Python.
MILLSIM_ENV = "../envs/millsim.yaml"

# The simulate rules are cached between workflows only when `--cache` is given: marked always,
# Snakemake said so in a line per rule on every run without it ("eligible for caching").
CACHE = workflow.workflow_settings.cache is not None


@dataclass(frozen=True)
class Study:
    scene: str
    space: Paramspace  # swept parameters, one row per case
    fixed: dict  # parameter -> command-line string, the same for every case


# The Tavares scenes' materials file (config `materials_file`, docs/materials.md): the same for
# every case of the scenes that take one, and an input of their cases, so that editing it
# re-runs them.
MATERIALS_FILE = config["materials_file"]


def scene_files(scene):
    """Parameters of ``scene`` that the config sets once for all its cases: {materials_file}
    for the scenes that take one."""
    takes = "materials_file" in {p.name for p in get_scene(scene).params}
    return {"materials_file": MATERIALS_FILE} if takes else {}


def case_inputs(scene):
    """Input files of a case of ``scene`` (its materials file, if it takes one)."""
    return list(scene_files(scene).values())


def make_study(block, scene, values, stack_over, **pinned):
    """The study of ``scene`` with ``values`` (lists are swept), each case checked by the scene.

    ``stack_over`` are swept even when given one value: the aggregate needs them as dimensions.
    ``pinned`` are set by the study itself, whatever the config says.
    """
    values = {**values, **scene_files(scene), **pinned}
    params = {p.name: p for p in get_scene(scene).params}
    swept = [
        *stack_over,
        *(
            k
            for k, v in values.items()
            if isinstance(v, list) and k not in stack_over and sweepable(params.get(k))
        ),
    ]
    grid = pd.MultiIndex.from_product(
        [values[k] if isinstance(values[k], list) else [values[k]] for k in swept],
        names=swept,
    ).to_frame(index=False)
    study = checked_study(
        block,
        scene,
        Study(
            scene, Paramspace(grid), {k: param_text(v) for k, v in values.items() if k not in swept}
        ),
    )
    refuse_repeats(block, scene, values)
    return study


def sweepable(param):
    """Whether a list given for ``param`` sweeps it (the walls' list is one value; an unknown
    key is the scene's to refuse)."""
    return param is None or param.sweepable


def param_text(value):
    """A fixed parameter as `--set` text: a list (the walls) as JSON, which is YAML."""
    return json.dumps(value) if isinstance(value, list) else str(value)


def refuse_repeats(block, scene, values):
    """Refuse a value given twice in one swept list (0.5 and 0.50 alike): the same case twice,
    which the aggregate would refuse only after every case had run."""
    params = {p.name: p for p in get_scene(scene).params}
    for key, given in values.items():
        if not isinstance(given, list) or not sweepable(params.get(key)):
            continue
        seen = {}
        for value in given:
            parsed = params[key].parse(str(value))
            if parsed in seen:
                raise ValueError(
                    f"config {block}: {key}: {value!r} repeats {seen[parsed]!r} in the sweep "
                    f"{given}; give each value once (replicates: sweep seed)"
                )
            seen[parsed] = value


def checked_study(block, scene, study):
    """``study`` once its scene has resolved every case (the parameter ranges live there)."""
    cases = len(study.space.dataframe)
    if cases >= 1000:  # ~2 ms a case: a large sweep takes a while before the first job
        print(f"[millsim] config {block}: checking {cases} cases", file=sys.stderr, flush=True)
    # str() of each value, exactly as Paramspace writes it into the case path
    for row in study.space.dataframe.itertuples(index=False):
        try:
            get_scene(scene).resolve(
                {**study.fixed, **{k: str(v) for k, v in row._asdict().items()}}
            )
        except (ValueError, FileNotFoundError) as exc:
            raise ValueError(f"config {block}: {exc}") from None
    return study


# Cases whose time step was found within the stability limit, per code version: building a case
# takes up to seconds (a full-scale stirred mill ~7 s), so each is built once.
STEP_CHECKS = Path(".snakemake", "millsim", f"step-checks-{ENGINE}.json")
try:
    STEPS_CHECKED = set(json.loads(STEP_CHECKS.read_text()))
except (OSError, ValueError):
    STEPS_CHECKED = set()


def check_step(study, sets):
    """Build the case of ``study`` with parameters ``sets`` as `millsim run` does before it
    compiles anything, where a step above the stability limit is refused. Called for the cases
    Snakemake schedules (a study's space may hold many more), while it builds the jobs, before
    any runs. Only a case whose step can exceed the limit is built: an absolute dt, or dt_factor
    above 1 (the engine recommends a step below the limit of every interaction)."""
    scene = get_scene(STUDIES[study].scene)
    # the two step parameters alone first: resolving every case again costs seconds
    step = {
        p.name: p.parse(sets[p.name]) if p.name in sets else p.default
        for p in scene.params
        if p.name in ("dt", "dt_factor")
    }
    if not (step.get("dt", 0.0) > 0 or step.get("dt_factor", 1.0) > 1):
        return
    values = scene.resolve(sets)
    key = json.dumps([scene.name, values], sort_keys=True)
    if key in STEPS_CHECKED:
        return
    try:
        scene.build(values)
    except ValueError as exc:
        raise WorkflowError(f"config {study}: {exc}") from None
    STEPS_CHECKED.add(key)
    step_progress()


# A sweep of thousands of cases builds each for the step check (1-7 s a case): progress on stderr
# every STEP_PROGRESS_S, and the cache saved as often and at exit, not after every case (rewriting
# the whole file per case grows as the square of the cases: hours for 20,000).
STEP_PROGRESS_S = 30.0
STEP_BUILDS = {"built": 0, "start": None, "said": 0.0}


def save_step_checks():
    with atomic_target(STEP_CHECKS) as tmp:
        tmp.write_text(json.dumps(sorted(STEPS_CHECKED)))
    for old in STEP_CHECKS.parent.glob("step-checks-*.json"):
        if old != STEP_CHECKS:  # of other code versions
            old.unlink(missing_ok=True)


def step_progress():
    """Count one case built by check_step; say how far on stderr, save the cache."""
    now = time.monotonic()
    if STEP_BUILDS["start"] is None:
        STEP_BUILDS.update(start=now, said=now)
        atexit.register(save_step_checks)
    STEP_BUILDS["built"] += 1
    if now - STEP_BUILDS["said"] < STEP_PROGRESS_S:
        return
    STEP_BUILDS["said"] = now
    save_step_checks()
    built = STEP_BUILDS["built"]
    cases = sum(len(study.space.dataframe) for study in STUDIES.values())
    print(
        f"[millsim] step check: {built} cases built ({(now - STEP_BUILDS['start']) / built:.2g} s "
        f"each) of at most {cases}; kept in {STEP_CHECKS} for the next run",
        file=sys.stderr,
        flush=True,
    )


BALLMILL = config["ballmill"]


def ballmill_study(block, fragmentation):
    """`ballmill.parameters` overridden by `ballmill.<block>`, stacked over n/n_c."""
    values = {**BALLMILL["parameters"], **BALLMILL[block]}
    return make_study(
        f"ballmill.{block}",
        "ballmill2d",
        values,
        ["n_over_nc"],
        fragmentation=fragmentation,
    )


STUDIES = {
    "ballmill": ballmill_study("parameters", fragmentation=True),
    "ballmill_forcechain": ballmill_study("forcechain", fragmentation=False),
    "ballmill_animation": ballmill_study("animation", fragmentation=True),
}


def case_file(study, name="case.nc"):
    """Path pattern of one file of a case, with one wildcard per swept parameter."""
    return f"results/cases/{study}/{STUDIES[study].space.wildcard_pattern}/{name}"


def case_files(study, name="case.nc"):
    return [
        f"results/cases/{study}/{case}/{name}" for case in STUDIES[study].space.instance_patterns
    ]


def case_log(rule, study):
    return f"results/logs/{rule}/{STUDIES[study].space.wildcard_pattern}.log"


def case_label(study):
    return STUDIES[study].space.wildcard_pattern


def case_sets(study):
    """Params function: the case's parameters as `--set key=value` arguments of `millsim run`,
    once its time step is checked (check_step)."""

    def sets(wildcards):
        swept = {k: wildcards[k] for k in STUDIES[study].space.dataframe.columns}
        values = {**STUDIES[study].fixed, **swept}
        check_step(study, values)
        # sorted: reordering the config must not look like a change of parameters
        return " ".join(f"--set {shlex.quote(f'{k}={v}')}" for k, v in sorted(values.items()))

    return sets


def stack_over(study):
    """`millsim aggregate` arguments naming the dimensions: the swept parameters."""
    return " ".join(f"--over {k}" for k in STUDIES[study].space.dataframe.columns)


@dataclass(frozen=True)
class Figure:
    input: str  # aggregate:<dataset> | table:<dataset> | snapshots
    caption: str


def plot_registry():
    """The plot registry as `millsim plot --list` prints it: figure name -> Figure."""
    run = subprocess.run(["millsim", "plot", "--list"], capture_output=True, text=True)
    if run.returncode:
        raise WorkflowError(f"`millsim plot --list` failed: {run.stderr.strip()}")
    listing = run.stdout
    return {
        name: Figure(source, caption)
        for name, source, caption in (line.split("\t", 2) for line in listing.splitlines() if line)
    }


PLOTS = plot_registry()
# where the pipeline keeps what a figure is drawn from
PLOT_INPUTS = {
    "aggregate": "results/aggregate/{}.nc",
    "table": "results/calibration/{}.csv",
}


def figures(*datasets):
    """Names of the figures drawn from ``datasets`` (those of a family excluded)."""
    return [
        name
        for name, fig in PLOTS.items()
        if fig.input.partition(":")[2] in datasets and "{" not in name
    ]


def figure_input(wildcards):
    """Input function of a plot rule: the file figure ``wildcards.figure`` is drawn from."""
    kind, _, dataset = PLOTS[wildcards.figure].input.partition(":")
    return PLOT_INPUTS[kind].format(dataset)


def figure_caption(wildcards):
    """Params function of a plot rule: the registry's caption (workflow/report/plot.rst)."""
    return PLOTS[wildcards.figure].caption


# Each further scene's rules file appends the function listing what `rule all` asks of it.
SCENE_TARGETS = []


def ballmill_targets():
    """What `rule all` asks of the ball mill."""
    return [
        "results/aggregate/ballmill.nc",
        "results/aggregate/ballmill_forcechain.nc",
        *(f"results/plots/{figure}.png" for figure in BALLMILL_FIGURES),
        *(
            f"results/plots/ballmill_animation/{case}.gif"
            for case in STUDIES["ballmill_animation"].space.instance_patterns
        ),
    ]


def all_targets():
    return [
        *ballmill_targets(),
        *(target for targets in SCENE_TARGETS for target in targets()),
    ]
