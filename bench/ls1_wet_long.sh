#!/bin/bash
# One wet full LS1 case over 4 revolutions (issue 12, item 2: is the wet power steady after the
# study's 1.5 revolutions?): config/paper.yaml's stirred-mill parameters at 0.5 Pa s and
# 2500 rpm, implicit lubrication, both threads of the 2-core VM, checkpoints (the same command
# resumes). Compare with the study's 1.5-revolution case of the same parameters (1250 +- 76 W):
#   bash bench/ls1_wet_long.sh OUTDIR
#   python bench/ls1_study.py OUTDIR/*.nc --json bench/out/full_ls1_wet_long.json
set -euo pipefail
out=${1:?usage: bash bench/ls1_wet_long.sh OUTDIR}
mkdir -p "$out"
millsim run stirred_mill --set scale=1.0 --set slice=false --set bead_diameter_min=0.0018 \
    --set bead_diameter_max=0.0018 --set initial_swirl=0.1 --set seed=1 --set dt_factor=2.0 \
    --set friction=0.3 --set eta=0.5 --set lubrication_scheme=implicit --set max_overlap=0.75 \
    --set rpm=2500 --set revolutions=4 --set transient_revolutions=2 --set ramp_revolutions=0.5 \
    --threads 2 --out "$out/wet_eta0.5_rpm2500_4rev.nc"
