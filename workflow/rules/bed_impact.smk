# Particle-bed impact (Tavares et al. 2021, Figs 20-23): a steel ball dropped on hexagonal beds
# of 5.5 mm particles that break by the Tavares model. Every case is one `millsim run bed_impact`;
# the cases of all `bed_impact.sweeps` blocks are stacked into results/aggregate/bed_breakage.nc.
#
# A case path names all five swept parameters, e.g.
# results/cases/bed_impact/material~copper_ore/rings~1/layers~1/impact_energy~3.05/seed~1/case.nc


localrules:
    aggregate_bed_impact,
    plot_bed_impact,


BED_IMPACT_OVER = ["material", "rings", "layers", "impact_energy", "seed"]
BED_IMPACT_FIGURES = figures("bed_breakage")


def bed_impact_study():
    """Union of the Cartesian products of the `bed_impact.sweeps` blocks, each case checked by
    the scene (fixed values: `bed_impact.parameters`)."""
    block = config["bed_impact"]
    fixed = dict(block.get("parameters") or {})
    rows = []
    for sweep in block["sweeps"]:
        values = {name: sweep[name] for name in BED_IMPACT_OVER}
        grid = pd.MultiIndex.from_product(
            [v if isinstance(v, list) else [v] for v in values.values()], names=BED_IMPACT_OVER
        ).to_frame(index=False)
        rows.append(grid)
    fixed = {k: param_text(v) for k, v in {**fixed, **scene_files("bed_impact")}.items()}
    given = pd.concat(rows, ignore_index=True)
    # the scene checks the values as given (a rings of 1.5 must be refused, not cast to 1) ...
    checked_study("bed_impact", "bed_impact", Study("bed_impact", Paramspace(given), fixed))
    # ... and the case paths write them in one form whatever the block (3 and 3.0 are one case)
    grid = given.astype(
        {"rings": int, "layers": int, "seed": int, "impact_energy": float}
    ).drop_duplicates(ignore_index=True)
    return Study("bed_impact", Paramspace(grid), fixed)


STUDIES["bed_impact"] = bed_impact_study()


# Cached between workflows (`--cache`) like the ball-mill cases; wall time in the case file.
rule simulate_bed_impact:
    input:
        case_inputs("bed_impact"),
    output:
        case=case_file("bed_impact"),
    log:
        case_log("simulate_bed_impact", "bed_impact"),
    cache: CACHE
    conda:
        MILLSIM_ENV
    threads: 1
    params:
        sets=case_sets("bed_impact"),
        engine=ENGINE,
    shell:
        "millsim run bed_impact {params.sets} --threads {threads} --out {output.case:q}"
        " > {log:q} 2>&1"


rule aggregate_bed_impact:
    input:
        cases=case_files("bed_impact"),
    output:
        "results/aggregate/bed_breakage.nc",
    log:
        "results/logs/aggregate_bed_impact.log",
    conda:
        MILLSIM_ENV
    params:
        over=" ".join(f"--over {k}" for k in BED_IMPACT_OVER),
    shell:
        "millsim aggregate bed_impact {input.cases:q} {params.over} --out {output:q} > {log:q} 2>&1"


rule plot_bed_impact:
    input:
        figure_input,
    output:
        report(
            "results/plots/{figure}.png",
            caption="../report/plot.rst",
            category="Bed impact 3D",
            labels={"figure": "{figure}"},
        ),
    log:
        "results/logs/plot_bed_impact/{figure}.log",
    wildcard_constraints:
        figure="|".join(BED_IMPACT_FIGURES),
    conda:
        MILLSIM_ENV
    params:
        caption=figure_caption,
    shell:
        "millsim plot {wildcards.figure:q} {input:q} --out {output:q} > {log:q} 2>&1"


def bed_impact_targets():
    """What `rule all` asks of this scene."""
    return [
        "results/aggregate/bed_breakage.nc",
        *(f"results/plots/{figure}.png" for figure in BED_IMPACT_FIGURES),
    ]


SCENE_TARGETS.append(bed_impact_targets)


# `snakemake --cores 2 bed_impact`: this scene's part of `rule all` alone.
localrules:
    bed_impact,


rule bed_impact:
    input:
        bed_impact_targets(),
