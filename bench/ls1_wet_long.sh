#!/bin/bash
# One wet full LS1 case over several revolutions (issue 12, items 2-3: is the wet power steady
# after the study's 1.5 revolutions, and what is it?): config/paper.yaml's stirred-mill
# parameters, implicit lubrication, both threads of the 2-core VM, checkpoints (the same command
# resumes, on any thread count: THREADS=1 bash ...; CHECKPOINT_EVERY=SECONDS as millsim run's,
# whose copies bench/ls1_bed_state.py reads; SWIRL=S starts the beads at S of rigid rotation,
# default 0.1, files of other values end _swirlS). Defaults: 0.5 Pa s, 2500 rpm,
# 4 revolutions (the power study's 1.5-revolution case of these parameters gave 1250 +- 76 W).
#   bash bench/ls1_wet_long.sh OUTDIR [ETA_PA_S RPM REVOLUTIONS]
#   python bench/ls1_study.py OUTDIR/*.nc --json bench/out/full_ls1_wet_long.json
set -euo pipefail
out=${1:?usage: bash bench/ls1_wet_long.sh OUTDIR [ETA_PA_S RPM REVOLUTIONS]}
eta=${2:-0.5}
rpm=${3:-2500}
revolutions=${4:-4}
threads=${THREADS:-2}
suffix=""
[ "${SWIRL:-0.1}" = 0.1 ] || suffix="_swirl${SWIRL}"
mkdir -p "$out"
millsim run stirred_mill --set scale=1.0 --set slice=false --set bead_diameter_min=0.0018 \
    --set bead_diameter_max=0.0018 --set initial_swirl="${SWIRL:-0.1}" --set seed=1 \
    --set dt_factor=2.0 --set friction=0.3 --set eta="$eta" --set lubrication_scheme=implicit \
    --set max_overlap=0.75 \
    --set rpm="$rpm" --set revolutions="$revolutions" --set transient_revolutions=2 \
    --set ramp_revolutions=0.5 --threads "$threads" \
    --checkpoint-every "${CHECKPOINT_EVERY:-600}" \
    --out "$out/wet_eta${eta}_rpm${rpm}_${revolutions}rev${suffix}.nc"
