#!/bin/bash
# Quick-slice checks behind issue 12 (docs/results/stirred_mill.md, "Start and steady state"):
# 1. config/config.yaml's slice at 1000 and 4000 rpm, dry and at 1 Pa s (implicit), from the
#    lattice start without a ramp: does it start and settle at the ends of the LabStar LS1
#    paper's range?
# 2. the slice at 1 Pa s, 2500 rpm, implicit, at config/paper.yaml's step (dt_factor 2, t_c/25)
#    against the quick study's (1, t_c/50), seeds 1-2 paired: is the full-LS1 study's step
#    accurate enough for the wet power?
# Usage: bash bench/stirred_slice_checks.sh OUTDIR, then
#        python bench/ls1_study.py OUTDIR/*.nc --json bench/out/slice_speeds.json
# (one thread per case, one case at a time: ~30 core-minutes on the 2-core VM)
set -e
out=${1:?usage: bench/stirred_slice_checks.sh OUTDIR}
mkdir -p "$out"
slice="--set scale=0.45 --set slice=true --set revolutions=4 --set transient_revolutions=2
       --set initial_swirl=0.1 --set friction=0.3 --set lubrication_scheme=implicit"
run() {  # name, then --set options
  local name=$1; shift
  [ -f "$out/$name.nc" ] || millsim run stirred_mill $slice "$@" --threads 1 --quiet \
    --out "$out/$name.nc" > "$out/$name.log" 2>&1 || echo "FAILED $name (see $out/$name.log)"
}
for rpm in 4000 1000; do for eta in 0 1.0; do
  run slice_rpm${rpm}_eta${eta} --set seed=1 --set dt_factor=1.0 --set rpm=$rpm --set eta=$eta
done; done
for seed in 1 2; do for f in 2.0 1.0; do
  run slice_eta1_dtf${f}_seed${seed} --set seed=$seed --set dt_factor=$f --set rpm=2500 --set eta=1.0
done; done
