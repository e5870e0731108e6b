# Ball mill 3D (issue 52): power, charge shape, impact spectra and breakage rates against speed
# (fraction of critical) x filling, with Morrell's (1996) charge-shape and power model beside them
# (millsim.analysis.ballmill3d). Every case is one `millsim run ballmill3d`; the cases are stacked
# over n_over_nc x filling into results/aggregate/ballmill3d.nc.


localrules:
    aggregate_ballmill3d,
    plot_ballmill3d,


# stacked over both even when one value is given: the figures and references need both dims
STUDIES["ballmill3d"] = make_study(
    "ballmill3d", "ballmill3d", config["ballmill3d"]["parameters"], ["n_over_nc", "filling"]
)
BALLMILL3D_FIGURES = figures("ballmill3d")


# Cached between workflows (`--cache`) like the other scenes' cases; wall time in the case file.
rule simulate_ballmill3d:
    input:
        case_inputs("ballmill3d"),
    output:
        case=case_file("ballmill3d"),
    log:
        case_log("simulate_ballmill3d", "ballmill3d"),
    cache: CACHE
    conda:
        MILLSIM_ENV
    threads: 1
    params:
        sets=case_sets("ballmill3d"),
        engine=ENGINE,
    shell:
        "millsim run ballmill3d {params.sets} --threads {threads} --out {output.case:q}"
        " > {log:q} 2>&1"


rule aggregate_ballmill3d:
    input:
        cases=case_files("ballmill3d"),
    output:
        "results/aggregate/ballmill3d.nc",
    log:
        "results/logs/aggregate_ballmill3d.log",
    conda:
        MILLSIM_ENV
    params:
        over=stack_over("ballmill3d"),
    shell:
        "millsim aggregate ballmill3d {input.cases:q} {params.over} --out {output:q} > {log:q} 2>&1"


rule plot_ballmill3d:
    input:
        figure_input,
    output:
        report(
            "results/plots/{figure}.png",
            caption="../report/plot.rst",
            category="Ball mill 3D",
            labels={"figure": "{figure}"},
        ),
    log:
        "results/logs/plot_ballmill3d/{figure}.log",
    wildcard_constraints:
        figure="|".join(BALLMILL3D_FIGURES),
    conda:
        MILLSIM_ENV
    params:
        caption=figure_caption,
    shell:
        "millsim plot {wildcards.figure:q} {input:q} --out {output:q} > {log:q} 2>&1"


def ballmill3d_targets():
    """What `rule all` asks of this scene."""
    return [
        "results/aggregate/ballmill3d.nc",
        *(f"results/plots/{figure}.png" for figure in BALLMILL3D_FIGURES),
    ]


SCENE_TARGETS.append(ballmill3d_targets)


# `snakemake --cores 2 ballmill3d`: this scene's part of `rule all` alone.
localrules:
    ballmill3d,


rule ballmill3d:
    input:
        ballmill3d_targets(),
