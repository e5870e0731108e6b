# millsim pipeline: config -> cases (`millsim run`) -> aggregates -> plots -> report.
# `snakemake --cores 2` runs the study in config/config.yaml; see README.md.

from snakemake.utils import min_version

min_version("9.19")


configfile: "config/config.yaml"


report: "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/ballmill.smk"


localrules:
    all,


rule all:
    default_target: True
    input:
        all_targets(),
