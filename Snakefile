# millsim pipeline: config -> cases (`millsim run`) -> aggregates -> plots -> report.
# `snakemake --cores 2` runs the study in config/config.yaml; see README.md.

import os

from snakemake.utils import min_version

min_version("9.19")


configfile: "config/config.yaml"


# The landing page includes the summary of `millsim report` (workflow/rules/report.smk); before
# the study has run there is none, and the report says so instead.
REPORT_PAGE = (
    "workflow/report/workflow.rst"
    if os.path.exists("results/report/landing.rst")
    else "workflow/report/not_run.rst"
)


report: REPORT_PAGE


include: "workflow/rules/common.smk"
include: "workflow/rules/ballmill.smk"


# The other scenes' rules exist only when the config has their block.
if "stirred_mill" in config:

    include: "workflow/rules/stirred_mill.smk"


if "bed_impact" in config:

    include: "workflow/rules/bed_impact.smk"


if "single_particle" in config:

    include: "workflow/rules/single_particle.smk"


if "ballmill3d" in config:

    include: "workflow/rules/ballmill3d.smk"


include: "workflow/rules/report.smk"
# `snakemake paper_<study>` / `paper`: the results pages of the paper-scale studies (issue 48);
# not part of `rule all`
include: "workflow/rules/paper.smk"


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
