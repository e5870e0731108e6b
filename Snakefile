# millsim pipeline: config -> cases (`millsim run`) -> aggregates -> plots -> report.
# `snakemake --cores 2` runs the study in config/config.yaml; see README.md.

from snakemake.utils import min_version

min_version("9.19")


configfile: "config/config.yaml"


report: "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/ballmill.smk"


# The other scenes' rules exist only when the config has their block.
if "stirred_mill" in config:

    include: "workflow/rules/stirred_mill.smk"


if "bed_impact" in config:

    include: "workflow/rules/bed_impact.smk"


if "single_particle" in config:

    include: "workflow/rules/single_particle.smk"


# Error against run time (issue 6): `snakemake --cores 2 accuracy`; not part of `rule all`
# (about 30 min on 2 cores from scratch). Included after the scenes: it adds studies of their
# scenes.
if "accuracy" in config:

    include: "workflow/rules/accuracy.smk"


localrules:
    all,


rule all:
    default_target: True
    input:
        all_targets(),
