#!/bin/bash
# Dry full LS1 over several revolutions at several speeds (issue 12, item 3: the dry row of the
# full-LS1 power table from steady windows, beside bench/ls1_long.sh's 3000 rpm): the power
# study's parameters, half a revolution of ramp, the second half of the revolutions averaged,
# one thread per case (THREADS=N: N), all speeds at once, checkpoints (the same command resumes,
# on any thread count). SWIRL=S starts the beads at S of rigid rotation (default 0.1, the power
# study's; files of other values end _swirlS): dry, 0.1 holds the bed at the wall above about
# 2000 rpm, and it then takes many revolutions to sink (docs/results/stirred_mill.md, "The dry
# bed sinks"); SWIRL=0 starts it where it ends up (at 4000 rpm over 12 revolutions, average from
# the 8th: ls1_study.py --window-from). RAMP=R revolutions of ramp (default 0.5; _rampR),
# GUARD=G max_overlap in radii (default the scene's; _guardG), CHECKPOINT_EVERY=SECONDS as
# millsim run's. 4000 rpm wants RAMP=1 GUARD=1.0 (docs/stirred_mill.md, Start-up).
# Defaults: 4 revolutions at 2000 and 2500 rpm (2000 rpm was still rising: 8 revolutions).
#   bash bench/ls1_dry_speeds.sh OUTDIR [REVOLUTIONS [RPM ...]]
#   python bench/ls1_study.py OUTDIR/*.nc --json bench/out/full_ls1_dry_speeds.json
set -euo pipefail
out=${1:?usage: bash bench/ls1_dry_speeds.sh OUTDIR}
revolutions=${2:-4}
speeds=("${@:3}")
[ ${#speeds[@]} -gt 0 ] || speeds=(2000 2500)
mkdir -p "$out"
common=(--set scale=1.0 --set slice=false --set bead_diameter_min=0.0018
        --set bead_diameter_max=0.0018 --set initial_swirl=${SWIRL:-0.1} --set seed=1
        --set dt_factor=2.0 --set friction=0.3 --set eta=0 --set revolutions=$revolutions
        --set transient_revolutions=$(python3 -c "print($revolutions / 2)")
        --set ramp_revolutions=${RAMP:-0.5} --threads "${THREADS:-1}"
        --checkpoint-every "${CHECKPOINT_EVERY:-600}")
suffix=""
[ "${SWIRL:-0.1}" = 0.1 ] || suffix+="_swirl${SWIRL}"
[ "${RAMP:-0.5}" = 0.5 ] || suffix+="_ramp${RAMP}"
[ -z "${GUARD:-}" ] || { common+=(--set max_overlap=$GUARD); suffix+="_guard${GUARD}"; }
for rpm in "${speeds[@]}"; do
    millsim run stirred_mill "${common[@]}" --set rpm=$rpm \
        --out "$out/dry_rpm${rpm}_${revolutions}rev${suffix}.nc" &
done
wait
