# Error against run time (work-precision, issue 6): for each scene, ladders of time steps x
# seeds against a converged reference. Target:  snakemake --cores 2 accuracy
# (about 30 min on 2 cores from scratch, hence not part of `rule all`).
#
# Config block `accuracy` (config/config.yaml): per scene name (ballmill, single_particle,
# bed_impact, stirred_mill) fixed `parameters`, `seed` (repeated at every step), and `series`:
# each series sets a few parameters (`set`, e.g. the integrator or eta) and sweeps one step
# parameter (`ladder`: dt_factor, which moves with the engine's limit, or dt in seconds, which a
# moved limit can leave above it); `reference: <series>` compares it with another series'
# converged value (Verlet against Gear). Cases, one `millsim run` each, cached:
#   results/cases/accuracy_<name>_<series>/<ladder>~<v>/seed~<s>/case.nc
# then one table per series (results/accuracy/<name>/<series>.csv), the aggregate
# results/aggregate/accuracy.nc (+ results/accuracy/summary.md), and one figure per scene
# results/plots/error_vs_runtime_<name>.png. The analysis: `millsim analyse accuracy`
# (millsim.analysis.accuracy); the figures: `millsim plot error_vs_runtime_<name>`.

import json

ACCURACY = config.get("accuracy") or {}
ACCURACY_TOLERANCE = ACCURACY.get("tolerance", 0.01)
ACCURACY_LIMIT_FRACTION = ACCURACY.get("limit_fraction", 1.0)
# config name -> scene
ACCURACY_SCENES = {
    "ballmill": "ballmill2d",
    "single_particle": "single_particle",
    "bed_impact": "bed_impact",
    "stirred_mill": "stirred_mill",
}
ACCURACY_NAMES = [n for n in ACCURACY_SCENES if n in ACCURACY]
# study -> (name, series, scene, ladder parameter)
ACCURACY_STUDIES = {}

for _name in ACCURACY_NAMES:
    _block = ACCURACY[_name]
    for _series, _spec in _block["series"].items():
        (_ladder,) = _spec["ladder"]
        if _spec.get("reference") and _spec["reference"] not in _block["series"]:
            raise ValueError(
                f"config accuracy.{_name}.series.{_series}.reference: "
                f"{_spec['reference']!r} is not a series of {_name}"
            )
        _study = f"accuracy_{_name}_{_series}"
        STUDIES[_study] = make_study(
            f"accuracy.{_name}.series.{_series}",
            ACCURACY_SCENES[_name],
            {
                **(_block.get("parameters") or {}),
                **(_spec.get("set") or {}),
                **_spec["ladder"],
                "seed": _spec.get("seed", _block["seed"]),
            },
            [_ladder, "seed"],
        )
        ACCURACY_STUDIES[_study] = (_name, _series, ACCURACY_SCENES[_name], _ladder)


def accuracy_tables():
    return [
        f"results/accuracy/{name}/{series}.csv" for name, series, _, _ in ACCURACY_STUDIES.values()
    ]


def accuracy_options():
    """`aggregate` options: borrowed references, reference methods, deciding observables; each
    value shell-quoted (series names come from the config)."""
    opts = []
    for name in ACCURACY_NAMES:
        block = ACCURACY[name]
        for series, spec in block["series"].items():
            if spec.get("reference"):
                opts += ["--reference", f"{name}/{series}={spec['reference']}"]
        if block.get("extrapolation"):
            opts += ["--method", f"{name}={block['extrapolation']}"]
        if block.get("decide_on"):
            opts += ["--decide", f"{name}={','.join(block['decide_on'])}"]
    return shlex.join(opts)


def accuracy_targets():
    """What the `accuracy` rule asks for (not part of `rule all`: ~30 min on 2 cores)."""
    if not ACCURACY_NAMES:
        return []
    return [
        "results/aggregate/accuracy.nc",
        *(f"results/plots/error_vs_runtime_{name}.png" for name in ACCURACY_NAMES),
    ]


localrules:
    accuracy,
    accuracy_collect,
    aggregate_accuracy,
    plot_accuracy,


# One simulate rule per ladder (its case paths have their own wildcards); cached between
# workflows (`--cache`) like every other case; wall time and dt are in the case file.
for _study, (_name, _series, _scene, _ladder) in ACCURACY_STUDIES.items():

    rule:
        name:
            f"simulate_{_study}"
        input:
            case_inputs(_scene),
        output:
            case=case_file(_study),
        log:
            case_log(f"simulate_{_study}", _study),
        cache: CACHE
        conda:
            MILLSIM_ENV
        threads: 1
        params:
            scene=_scene,
            sets=case_sets(_study),
            engine=ENGINE,
        shell:
            "millsim run {params.scene:q} {params.sets} --threads {threads} --out {output.case:q}"
            " > {log:q} 2>&1"


rule accuracy_collect:
    input:
        cases=lambda wc: case_files(f"accuracy_{wc.subject}_{wc.series}"),
    output:
        "results/accuracy/{subject}/{series}.csv",
    log:
        "results/logs/accuracy_collect/{subject}/{series}.log",
    wildcard_constraints:
        subject="|".join(ACCURACY_NAMES) or "none",
    conda:
        MILLSIM_ENV
    params:
        ladder=lambda wc: ACCURACY_STUDIES[f"accuracy_{wc.subject}_{wc.series}"][3],
    shell:
        "millsim analyse accuracy collect {input.cases:q} --name {wildcards.subject:q}"
        " --series {wildcards.series:q} --ladder {params.ladder:q} --out {output:q} > {log:q} 2>&1"


rule aggregate_accuracy:
    input:
        accuracy_tables(),
    output:
        data="results/aggregate/accuracy.nc",
        summary="results/accuracy/summary.md",
    log:
        "results/logs/aggregate_accuracy.log",
    conda:
        MILLSIM_ENV
    params:
        tolerance=ACCURACY_TOLERANCE,
        limit_fraction=ACCURACY_LIMIT_FRACTION,
        options=accuracy_options(),
        config=shlex.quote(json.dumps(ACCURACY, sort_keys=True)),
    shell:
        "millsim analyse accuracy aggregate {input:q} --tolerance {params.tolerance:q}"
        " --limit-fraction {params.limit_fraction:q} {params.options}"
        " --config-json {params.config} --out {output.data:q}"
        " --summary {output.summary:q} > {log:q} 2>&1"


# one figure per name, of the registry's family error_vs_runtime_{name}
ACCURACY_FIGURE = "error_vs_runtime_{name}"
if ACCURACY_FIGURE not in PLOTS:
    raise ValueError(f"`millsim plot --list` has no {ACCURACY_FIGURE!r}")


def accuracy_caption(wildcards):
    """Params function of plot_accuracy: what this figure's study is (from its config block),
    then the family's caption; one caption per figure."""
    block = ACCURACY[wildcards.subject]
    fixed = ", ".join(f"{k} = {v}" for k, v in (block.get("parameters") or {}).items())
    series = "; ".join(
        f"{name}: {', '.join(f'{k} = {v}' for k, v in (spec.get('set') or {}).items()) or 'scene defaults'}"
        f", {' '.join(f'{k} in {v}' for k, v in spec['ladder'].items())}"
        for name, spec in block["series"].items()
    )
    return (
        f"Accuracy study {wildcards.subject} (scene {ACCURACY_SCENES[wildcards.subject]}; "
        f"config accuracy.{wildcards.subject}): {fixed or 'scene defaults'}; seeds "
        f"{block['seed']}; series {series}. " + PLOTS[ACCURACY_FIGURE].caption
    )


rule plot_accuracy:
    input:
        "results/aggregate/accuracy.nc",
    output:
        report(
            "results/plots/error_vs_runtime_{subject}.png",
            caption="../report/plot.rst",
            category="Accuracy: error against run time",
            labels={"scene": "{subject}"},
        ),
    log:
        "results/logs/plot_accuracy/{subject}.log",
    wildcard_constraints:
        subject="|".join(ACCURACY_NAMES) or "none",
    conda:
        MILLSIM_ENV
    params:
        caption=accuracy_caption,
    shell:
        "millsim plot error_vs_runtime_{wildcards.subject:q} {input:q} --out {output:q}"
        " > {log:q} 2>&1"


rule accuracy:
    input:
        accuracy_targets(),
