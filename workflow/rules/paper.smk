# Paper-scale studies (issue 48, item 3): one target per seed study, each writing its results page
# results/pages/<study>.md with `millsim results-page` from the study's aggregate (tables, engine
# hash, cost, links to the figures in results/plots). Run with the paper's config:
#
#   snakemake paper_ballmill --cores 2 --configfile config/paper.yaml          (also bed_impact,
#       single_particle)
#   snakemake paper_stirred_mill --cores 2 --configfile config/paper.yaml config/ls1_power.yaml
#   snakemake paper_ballmill3d --cores 2 --configfile config/paper.yaml \
#       config/ballmill3d_lab_power.yaml
#   snakemake paper --cores 2 --configfile config/paper.yaml config/ls1_power.yaml \
#       config/ballmill3d_lab_power.yaml                                           (all five)
#
# The stirred mill's page is that of its power study only (aggregate and figures, not the
# calibration); the 3D ball mill's runs the 2-core cut of config/ballmill3d_lab_power.yaml (without
# it, paper.yaml's 24 lab cases: 24-60 h on 2 cores). Costs and publishing to docs/results:
# docs/pipeline.md, "Paper-scale studies".
# Included after the scenes: it asks for their targets.


def _stirred_power_targets():
    return [
        "results/aggregate/stirred_mill.nc",
        *(f"results/plots/{figure}.png" for figure in figures("stirred_mill")),
    ]


# study -> (its config block, its aggregate, what the page needs: aggregate(s) and figures)
PAGE_STUDIES = {
    "ballmill": ("ballmill", "results/aggregate/ballmill.nc", ballmill_targets),
    "ballmill3d": (
        "ballmill3d",
        "results/aggregate/ballmill3d.nc",
        lambda: ballmill3d_targets(),
    ),
    "bed_impact": ("bed_impact", "results/aggregate/bed_breakage.nc", lambda: bed_impact_targets()),
    "single_particle": (
        "single_particle",
        "results/aggregate/tavares_verification.nc",
        lambda: single_particle_targets(),
    ),
    "stirred_mill": ("stirred_mill", "results/aggregate/stirred_mill.nc", _stirred_power_targets),
}
PAGES = [study for study, (block, _, _) in PAGE_STUDIES.items() if block in config]


localrules:
    results_page,
    paper,


rule results_page:
    input:
        aggregate=lambda wildcards: PAGE_STUDIES[wildcards.study][1],
        needs=lambda wildcards: PAGE_STUDIES[wildcards.study][2](),
    output:
        "results/pages/{study}.md",
    log:
        "results/logs/results_page/{study}.log",
    wildcard_constraints:
        study="|".join(PAGES),
    conda:
        MILLSIM_ENV
    shell:
        "millsim results-page {wildcards.study:q} {input.aggregate:q} --figures results/plots"
        " --out {output:q} > {log:q} 2>&1"


for _study in PAGES:

    rule:
        name:
            f"paper_{_study}"
        input:
            f"results/pages/{_study}.md",
        localrule: True


rule paper:
    input:
        [f"results/pages/{study}.md" for study in PAGES],
