# The report's landing page (workflow/report/workflow.rst includes it): headline numbers of every
# study in the config, the verification verdicts with their rules, the calibrated values with
# their intervals and the synthetic-reference flag, from `millsim report`. `millsim verdicts
# results/report/summary.json` prints the verdicts, failed first (the end of `make run`).

REPORT_SUMMARY = "results/report/summary.json"


def report_inputs(wildcards=None):
    """`millsim report` option -> input file(s), for the studies the config has."""
    inputs = {
        "ballmill": "results/aggregate/ballmill.nc",
        "forcechain": "results/aggregate/ballmill_forcechain.nc",
    }
    if "bed_impact" in config:
        inputs["bed"] = "results/aggregate/bed_breakage.nc"
    if "single_particle" in config:
        inputs["tavares"] = "results/aggregate/tavares_verification.nc"
    if "ballmill3d" in config:
        inputs["ballmill3d"] = "results/aggregate/ballmill3d.nc"
    if "stirred_mill" in config:
        inputs["stirred"] = "results/aggregate/stirred_mill.nc"
        inputs["calibration"] = [
            "results/calibration/stirred_mill_friction.json",
            "results/calibration/stirred_mill_viscosity.json",
            "results/calibration/stirred_mill_prediction.csv",
            config["stirred_mill"]["calibration"]["reference"],
        ]
    return inputs


def report_arguments(wildcards, input):
    """The input options of `millsim report`, shell-quoted (the reference path is the config's)."""
    args = []
    for option in report_inputs():
        value = getattr(input, option)
        args += [f"--{option}", *(value if option == "calibration" else [value])]
    return shlex.join(args)


localrules:
    report_summary,


rule report_summary:
    input:
        unpack(report_inputs),
    output:
        json=REPORT_SUMMARY,
        rst="results/report/landing.rst",
    log:
        "results/logs/report_summary.log",
    conda:
        MILLSIM_ENV
    params:
        args=report_arguments,
    shell:
        "millsim report {params.args} --json {output.json:q} --rst {output.rst:q} > {log:q} 2>&1"


SCENE_TARGETS.append(lambda: [REPORT_SUMMARY])
