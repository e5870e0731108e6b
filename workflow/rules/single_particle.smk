# Single-particle verification of the Tavares model (Tavares et al. 2021, section 4.1): simulations
# of N particles per condition against the analytic model. Every case is one `millsim run
# single_particle`; three studies from config `single_particle`:
#
#   single_particle_probability    Fig. 8: breakage probability, mode x material x energy_ratio
#   single_particle_repeated       Fig. 11: fraction broken after each of n impacts, x gamma
#   single_particle_fragmentation  Figs 13-16: product t10 and size distributions (replacement)
#
# e.g. results/cases/single_particle_probability/mode~single/material~copper_ore/energy_ratio~1.0/case.nc
# All cases go into results/aggregate/tavares_verification.nc (with the pass-rule results as
# attributes, printed in the aggregate's log) and the figures results/plots/tavares_*.png.


localrules:
    aggregate_single_particle,
    plot_single_particle,


SINGLE_PARTICLE = config["single_particle"]
TAVARES_FIGURES = figures("tavares_verification")


def single_particle_study(block, stack_over):
    """`single_particle.parameters` overridden by `single_particle.<block>`."""
    values = {**(SINGLE_PARTICLE.get("parameters") or {}), **SINGLE_PARTICLE[block]}
    return make_study(f"single_particle.{block}", "single_particle", values, stack_over)


STUDIES["single_particle_probability"] = single_particle_study(
    "probability", ["mode", "material", "energy_ratio"]
)
STUDIES["single_particle_repeated"] = single_particle_study("repeated", ["gamma"])
STUDIES["single_particle_fragmentation"] = single_particle_study(
    "fragmentation", ["mode", "material", "energy_ratio"]
)
SINGLE_PARTICLE_STUDIES = [
    "single_particle_probability",
    "single_particle_repeated",
    "single_particle_fragmentation",
]


# Cached between workflows (`--cache`) like the ball-mill cases; wall time in the case file.
rule simulate_single_particle_probability:
    input:
        case_inputs("single_particle"),
    output:
        case=case_file("single_particle_probability"),
    log:
        case_log("simulate_single_particle_probability", "single_particle_probability"),
    cache: CACHE
    conda:
        MILLSIM_ENV
    threads: 1
    params:
        sets=case_sets("single_particle_probability"),
        engine=ENGINE,
    shell:
        "millsim run single_particle {params.sets} --threads {threads} --out {output.case:q}"
        " > {log:q} 2>&1"


use rule simulate_single_particle_probability as simulate_single_particle_repeated with:
    output:
        case=case_file("single_particle_repeated"),
    log:
        case_log("simulate_single_particle_repeated", "single_particle_repeated"),
    cache: CACHE  # not inherited
    params:
        sets=case_sets("single_particle_repeated"),
        engine=ENGINE,


use rule simulate_single_particle_probability as simulate_single_particle_fragmentation with:
    output:
        case=case_file("single_particle_fragmentation"),
    log:
        case_log("simulate_single_particle_fragmentation", "single_particle_fragmentation"),
    cache: CACHE  # not inherited
    params:
        sets=case_sets("single_particle_fragmentation"),
        engine=ENGINE,


rule aggregate_single_particle:
    input:
        cases=[f for study in SINGLE_PARTICLE_STUDIES for f in case_files(study)],
    output:
        "results/aggregate/tavares_verification.nc",
    log:
        "results/logs/aggregate_single_particle.log",
    conda:
        MILLSIM_ENV
    shell:
        "millsim analyse tavares aggregate {input.cases:q} --out {output:q} > {log:q} 2>&1"


rule plot_single_particle:
    input:
        figure_input,
    output:
        report(
            "results/plots/{figure}.png",
            caption="../report/plot.rst",
            category="Tavares single-particle verification",
            labels={"figure": "{figure}"},
        ),
    log:
        "results/logs/plot_single_particle/{figure}.log",
    wildcard_constraints:
        figure="|".join(TAVARES_FIGURES),
    conda:
        MILLSIM_ENV
    params:
        caption=figure_caption,
    shell:
        "millsim plot {wildcards.figure:q} {input:q} --out {output:q} > {log:q} 2>&1"


def single_particle_targets():
    """What `rule all` asks of this scene (common.smk all_targets)."""
    return [
        "results/aggregate/tavares_verification.nc",
        *(f"results/plots/{figure}.png" for figure in TAVARES_FIGURES),
    ]


SCENE_TARGETS.append(single_particle_targets)


# `snakemake --cores 2 single_particle`: this scene's part of `rule all` alone.
localrules:
    single_particle,


rule single_particle:
    input:
        single_particle_targets(),
