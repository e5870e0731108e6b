# Stirred media mill with pairwise lubrication (the LabStar LS1 paper): power vs speed x viscosity,
# and the three-stage power-draw calibration (friction, viscosity, prediction) against
# config/reference/stirred_mill_power.csv. Every case is one `millsim run stirred_mill`, cached;
# the calibration stages are rules over those cases (stages 1 and 2 are checkpoints: the cases of
# the next stage depend on the value they pick). Re-run only the calibration after replacing the
# reference data:  snakemake --cores 2 -R stirred_mill_friction
# (stages 2 and 3, the figures and any newly needed cases follow).

import json

import numpy as np

from millsim.analysis.stirred_mill import DRY, read_reference

STIRRED = config.get("stirred_mill")


def _union(*lists):
    out = []
    for values in lists:
        for v in values if isinstance(values, list) else [values]:
            if not any(np.isclose(v, o) for o in out):
                out.append(v)
    return sorted(out)


def _calibration_seeds(stirred):
    """The random seeds of every calibration case (replicates), checked: a non-empty list of
    distinct integers >= 0; default: the parameters' one seed."""
    base = stirred["parameters"].get("seed", 1)
    if isinstance(base, list):
        raise ValueError(
            "config stirred_mill: parameters: seed: one seed (the power study's); replicate "
            "seeds of the calibration go in calibration: seeds"
        )
    seeds = stirred["calibration"].get("seeds", [base])
    if (
        not isinstance(seeds, list)
        or not seeds
        or any(isinstance(s, bool) or not isinstance(s, int) or s < 0 for s in seeds)
        or len(set(seeds)) != len(seeds)
    ):
        raise ValueError(
            f"config stirred_mill: calibration: seeds: {seeds!r}: give a list of distinct "
            "integers >= 0 (one per replicate)"
        )
    return base, seeds


if STIRRED:
    _SP, _CAL = STIRRED["power"], STIRRED["calibration"]
    _SEED, _CAL_SEEDS = _calibration_seeds(STIRRED)
    _ALL_SEEDS = sorted({_SEED, *_CAL_SEEDS})
    # one space of cases holds the power study and every calibration stage, so that shared
    # (friction, eta, rpm, seed) points are simulated once
    STUDIES["stirred_mill"] = make_study(
        "stirred_mill",
        "stirred_mill",
        {
            **STIRRED["parameters"],
            "friction": _union(_SP["friction"], _CAL["friction"]),
            "eta": _union(_SP["eta"], 0.0, _CAL["eta"]),
            "rpm": _union(_SP["rpm"], _CAL["rpm"], _CAL["eta_rpm"]),
            "seed": _ALL_SEEDS if len(_ALL_SEEDS) > 1 else _SEED,
        },
        ["friction", "eta", "rpm"],
    )
    STIRRED_REFERENCE = _CAL["reference"]


def checked_reference(path, rpms, eta_rpm):
    """Refuse, before any job, a reference table the calibration could not use: read as its
    stages read it, with rows, numbers in every row, a dry power at a stage-1 speed and a wet
    fluid's power at the stage-2 speed (else it fails only after the calibration's cases ran)."""
    try:
        ref = read_reference(path)
        if ref.empty:
            raise ValueError(f"{path}: no rows")
        blank = ref[["rpm", "eta_exp", "net_power", "net_power_ci"]].isna().any()
        if blank.any():
            raise ValueError(f"{path}: empty cells in column(s) {list(blank[blank].index)}")
        dry = ref["fluid"] == DRY
        if not np.isclose(ref.loc[dry, "rpm"].to_numpy()[:, None], rpms).any():
            raise ValueError(
                f"{path}: no row with fluid = {DRY!r} at a calibration speed {rpms} rpm "
                "(stage 1 fits the friction to them)"
            )
        if not np.isclose(ref.loc[~dry, "rpm"], eta_rpm).any():
            raise ValueError(
                f"{path}: no wet fluid's row at eta_rpm = {eta_rpm} rpm (stage 2 fits each "
                "fluid's viscosity there)"
            )
    except ValueError as exc:
        raise ValueError(f"config stirred_mill: calibration: reference: {exc}") from None


if STIRRED:
    checked_reference(STIRRED_REFERENCE, _CAL["rpm"], _CAL["eta_rpm"])


def stirred_case(friction, eta, rpm, seed=None):
    """Case file of the point (friction, eta, rpm) with random ``seed`` (default: the power
    study's) of the stirred-mill space."""
    space = STUDIES["stirred_mill"].space
    df = space.dataframe
    seed = _SEED if seed is None else seed
    for pattern, row in zip(space.instance_patterns, df.itertuples(index=False)):
        if (
            np.isclose(row.friction, friction)
            and np.isclose(row.eta, eta)
            and np.isclose(row.rpm, rpm)
            and ("seed" not in df.columns or int(row.seed) == seed)
        ):
            return f"results/cases/stirred_mill/{pattern}/case.nc"
    raise ValueError(
        f"stirred_mill: ({friction}, {eta}, {rpm}, seed {seed}) is not in the case space"
    )


def stirred_power_cases():
    return [stirred_case(_SP["friction"], e, r) for e in _SP["eta"] for r in _SP["rpm"]]


# Calibration cases: every point once per replicate seed (the analysis pools them).
def stirred_stage1_cases():
    return [
        stirred_case(mu, 0.0, r, s)
        for mu in _CAL["friction"]
        for r in _CAL["rpm"]
        for s in _CAL_SEEDS
    ]


def stirred_stage2_cases(wildcards):
    choice = checkpoints.stirred_mill_friction.get().output.choice
    mu = json.load(open(choice))["friction"]
    return [stirred_case(mu, e, _CAL["eta_rpm"], s) for e in _CAL["eta"] for s in _CAL_SEEDS]


def stirred_stage3_cases(wildcards):
    choice = json.load(open(checkpoints.stirred_mill_viscosity.get().output.choice))
    mu = choice["friction"]
    etas = [0.0] + [c["eta_sim"] for c in choice["fluids"].values()]
    return sorted(
        {stirred_case(mu, e, r, s) for e in etas for r in _CAL["rpm"] for s in _CAL_SEEDS}
    )


# figures of the registry drawn from the power aggregate and the calibration tables
STIRRED_FIGURES = figures(
    "stirred_mill",
    "stirred_mill_friction",
    "stirred_mill_viscosity",
    "stirred_mill_prediction",
)


def stirred_mill_targets():
    if not STIRRED:
        return []
    return [
        "results/aggregate/stirred_mill.nc",
        *(f"results/plots/{figure}.png" for figure in STIRRED_FIGURES),
        "results/calibration/stirred_mill_prediction.csv",
    ]


if STIRRED:

    localrules:
        aggregate_stirred_mill,
        plot_stirred_mill,
        stirred_mill_friction,
        stirred_mill_viscosity,
        stirred_mill_predict,

    # Cached between workflows (`--cache`); wall time and steps are in the case file.
    rule simulate_stirred_mill:
        output:
            case=case_file("stirred_mill"),
        log:
            case_log("simulate_stirred_mill", "stirred_mill"),
        cache: CACHE
        conda:
            MILLSIM_ENV
        threads: 1
        params:
            sets=case_sets("stirred_mill"),
            engine=ENGINE,
        shell:
            "millsim run stirred_mill {params.sets} --threads {threads} --out {output.case:q}"
            " > {log:q} 2>&1"

    rule aggregate_stirred_mill:
        input:
            cases=stirred_power_cases(),
        output:
            "results/aggregate/stirred_mill.nc",
        log:
            "results/logs/aggregate_stirred_mill.log",
        conda:
            MILLSIM_ENV
        shell:
            "millsim aggregate stirred_mill {input.cases:q} --over eta --over rpm --out {output:q}"
            " > {log:q} 2>&1"

    rule plot_stirred_mill:
        input:
            figure_input,
        output:
            report(
                "results/plots/{figure}.png",
                caption="../report/plot.rst",
                category="Stirred mill",
                labels={"figure": "{figure}"},
            ),
        log:
            "results/logs/plot_stirred_mill/{figure}.log",
        wildcard_constraints:
            figure="|".join(STIRRED_FIGURES),
        conda:
            MILLSIM_ENV
        params:
            caption=figure_caption,
        shell:
            "millsim plot {wildcards.figure:q} {input:q} --out {output:q} > {log:q} 2>&1"

    checkpoint stirred_mill_friction:
        input:
            cases=stirred_stage1_cases(),
            reference=STIRRED_REFERENCE,
        output:
            table="results/calibration/stirred_mill_friction.csv",
            summary="results/calibration/stirred_mill_friction_ssr.csv",
            choice="results/calibration/stirred_mill_friction.json",
        log:
            "results/logs/stirred_mill_friction.log",
        conda:
            MILLSIM_ENV
        shell:
            "millsim analyse stirred-mill friction {input.cases:q}"
            " --reference {input.reference:q} --table {output.table:q}"
            " --summary {output.summary:q} --choice {output.choice:q} > {log:q} 2>&1"

    checkpoint stirred_mill_viscosity:
        input:
            cases=stirred_stage2_cases,
            reference=STIRRED_REFERENCE,
            friction="results/calibration/stirred_mill_friction.json",
        output:
            table="results/calibration/stirred_mill_viscosity.csv",
            choice="results/calibration/stirred_mill_viscosity.json",
        log:
            "results/logs/stirred_mill_viscosity.log",
        conda:
            MILLSIM_ENV
        params:
            rpm=_CAL["eta_rpm"] if STIRRED else 0,
        shell:
            "millsim analyse stirred-mill viscosity {input.cases:q}"
            " --reference {input.reference:q} --friction {input.friction:q} --rpm {params.rpm:q}"
            " --table {output.table:q} --choice {output.choice:q} > {log:q} 2>&1"

    rule stirred_mill_predict:
        input:
            cases=stirred_stage3_cases,
            reference=STIRRED_REFERENCE,
            viscosity="results/calibration/stirred_mill_viscosity.json",
        output:
            table="results/calibration/stirred_mill_prediction.csv",
        log:
            "results/logs/stirred_mill_predict.log",
        conda:
            MILLSIM_ENV
        shell:
            "millsim analyse stirred-mill predict {input.cases:q}"
            " --reference {input.reference:q} --viscosity {input.viscosity:q}"
            " --table {output.table:q} > {log:q} 2>&1"


SCENE_TARGETS.append(stirred_mill_targets)


# `snakemake --cores 2 stirred_mill`: this scene's part of `rule all` alone.
localrules:
    stirred_mill,


rule stirred_mill:
    input:
        stirred_mill_targets(),
