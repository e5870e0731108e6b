# Ball mill 2D (Buchholtz et al. 2000): comminution rate vs rotation speed, fragment sizes, fracture
# and pressure maps, force chains, and animated cases. Every case is one `millsim run ballmill2d`.
#
# Every rule names the workflow's one conda environment (MILLSIM_ENV, common.smk), used with
# `--use-conda`; without it the rules run the `millsim` of the Python that runs Snakemake.


localrules:
    aggregate_ballmill,
    aggregate_ballmill_forcechain,
    plot_ballmill,
    animate_ballmill,


# Cached between workflows (`--cache`), hence no benchmark: directive; the wall time of each
# run is in its case file (attribute wall_time_s).
rule simulate_ballmill:
    output:
        case=case_file("ballmill"),
    log:
        case_log("simulate_ballmill", "ballmill"),
    cache: CACHE
    conda:
        MILLSIM_ENV
    threads: 1
    params:
        sets=case_sets("ballmill"),
        engine=ENGINE,
    shell:
        "millsim run ballmill2d {params.sets} --threads {threads} --out {output.case:q}"
        " > {log:q} 2>&1"


use rule simulate_ballmill as simulate_ballmill_forcechain with:
    output:
        case=case_file("ballmill_forcechain"),
    log:
        case_log("simulate_ballmill_forcechain", "ballmill_forcechain"),
    cache: CACHE  # not inherited
    params:
        sets=case_sets("ballmill_forcechain"),
        engine=ENGINE,


rule simulate_ballmill_snapshots:
    output:
        case=case_file("ballmill_animation"),
        snapshots=case_file("ballmill_animation", "snapshots.h5"),
        xdmf=case_file("ballmill_animation", "snapshots.xdmf"),
    log:
        case_log("simulate_ballmill_snapshots", "ballmill_animation"),
    cache: CACHE
    conda:
        MILLSIM_ENV
    threads: 1
    params:
        sets=case_sets("ballmill_animation"),
        engine=ENGINE,
    shell:
        "millsim run ballmill2d {params.sets} --threads {threads} --out {output.case:q}"
        " --snapshots {output.snapshots:q} > {log:q} 2>&1"


rule aggregate_ballmill:
    input:
        cases=case_files("ballmill"),
    output:
        "results/aggregate/ballmill.nc",
    log:
        "results/logs/aggregate_ballmill.log",
    conda:
        MILLSIM_ENV
    params:
        over=stack_over("ballmill"),
    shell:
        "millsim aggregate ballmill2d {input.cases:q} {params.over} --out {output:q} > {log:q} 2>&1"


use rule aggregate_ballmill as aggregate_ballmill_forcechain with:
    input:
        cases=case_files("ballmill_forcechain"),
    output:
        "results/aggregate/ballmill_forcechain.nc",
    log:
        "results/logs/aggregate_ballmill_forcechain.log",
    params:
        over=stack_over("ballmill_forcechain"),


# figures of the registry drawn from the two ball-mill aggregates (results/plots/<figure>.png)
BALLMILL_FIGURES = figures("ballmill", "ballmill_forcechain")


rule plot_ballmill:
    input:
        figure_input,
    output:
        report(
            "results/plots/{figure}.png",
            caption="../report/plot.rst",
            category="Ball mill 2D",
            labels={"figure": "{figure}"},
        ),
    log:
        "results/logs/plot_ballmill/{figure}.log",
    wildcard_constraints:
        figure="|".join(BALLMILL_FIGURES),
    conda:
        MILLSIM_ENV
    params:
        caption=figure_caption,
    shell:
        "millsim plot {wildcards.figure:q} {input:q} --out {output:q} > {log:q} 2>&1"


rule animate_ballmill:
    input:
        case_file("ballmill_animation", "snapshots.h5"),
    output:
        report(
            f"results/plots/ballmill_animation/{case_label('ballmill_animation')}.gif",
            caption="../report/plot.rst",
            category="Ball mill 2D",
            labels={"figure": "animation", "case": case_label("ballmill_animation")},
        ),
    log:
        case_log("animate_ballmill", "ballmill_animation"),
    conda:
        MILLSIM_ENV
    params:
        caption=PLOTS["animation"].caption,
    shell:
        "millsim plot animation {input:q} --out {output:q} > {log:q} 2>&1"


# `snakemake --cores 2 ballmill`: this scene's part of `rule all` alone.
localrules:
    ballmill,


rule ballmill:
    input:
        ballmill_targets(),
