#!/bin/bash
# Dry full LS1 over several revolutions (issue 12, item 2: start and steady state on the full
# chamber): config/paper.yaml's stirred-mill parameters, one thread per case, checkpoints every
# 10 min (the same command resumes). Results: docs/results/stirred_mill.md, "Steady state on the
# full chamber".
#   bash bench/ls1_long.sh OUTDIR
set -euo pipefail
out=${1:?usage: bash bench/ls1_long.sh OUTDIR}
mkdir -p "$out"
common=(--set scale=1.0 --set slice=false --set bead_diameter_min=0.0018
        --set bead_diameter_max=0.0018 --set initial_swirl=0.1 --set seed=1 --set dt_factor=2.0
        --set friction=0.3 --set eta=0 --threads 1)
# 8 revolutions, the first 4 discarded (the LabStar LS1 paper: steady state after 5-10 rotations)
millsim run stirred_mill "${common[@]}" --set rpm=3000 --set revolutions=8 \
    --set transient_revolutions=4 --set ramp_revolutions=0.5 --out "$out/dry_rpm3000_8rev.nc" &
# 4000 rpm: half a revolution of ramp stops on the overlap guard 2 ms after it; one revolution
millsim run stirred_mill "${common[@]}" --set rpm=4000 --set revolutions=5 \
    --set transient_revolutions=2.5 --set ramp_revolutions=1 --out "$out/dry_rpm4000_5rev_ramp1.nc" &
wait
# ... which stops on the guard 2.2 revolutions after the ramp (a bead chain pinched by a disk):
# the same case with the guard at the scene's largest max_overlap, 1.0 of a radius, over 10
# revolutions, the second half averaged (the LabStar LS1 paper: steady state after 5-10
# rotations). Its first 5 revolutions stand in for the earlier 5-revolution run
# (dry_rpm4000_5rev_ramp1_guard1.nc, --set revolutions=5 --set transient_revolutions=2.5), whose
# revolution means they match within 2 W; running both would repeat those 5 revolutions.
millsim run stirred_mill "${common[@]}" --set rpm=4000 --set revolutions=10 \
    --set transient_revolutions=5 --set ramp_revolutions=1 --set max_overlap=1.0 \
    --out "$out/dry_rpm4000_10rev_ramp1_guard1.nc"
