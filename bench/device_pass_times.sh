#!/bin/bash
# Issue 13 on a lent 16-core machine (the device tool): each parallel pass timed alone at 1-16
# threads (bench/pass_times.py), then the OpenMP placement and wait policy at 4 and 16 threads.
# Runs from the repository root with the image's python3 and .lg/site/trimesh carried (see
# bench/device_scaling_16core.sh); results into $OUT.
set -u
export PYTHONPATH=$PWD/src:$PWD/.lg/site PYTHONUNBUFFERED=1
T0=$(date +%s); N=${N:-100000}; TH=${TH:-1 2 4 8 16}; TV=${TV:-4 16}
{ nproc; lscpu | grep -E "Model name|Thread|Core|L3"; cat /proc/loadavg
  python3 -c "import numba, numpy; print('numba', numba.__version__, 'numpy', numpy.__version__)"; } > $OUT/env.txt 2>&1
cat $OUT/env.txt
# compile the three loops at once (the disk cache serves the later processes)
for ph in ballmill2d hertz_tavares beads_lubrication; do
  python3 bench/pass_times.py --physics $ph --n 3000 --steps 5 --threads 1 2 --json /tmp/warm_$ph.json > /dev/null 2> $OUT/warm_$ph.err &
done
wait; echo "compiled after $(( $(date +%s) - T0 )) s"; tail -n 3 $OUT/warm_*.err
for ph in ${PHYS:-ballmill2d hertz_tavares beads_lubrication}; do
  timeout 110 python3 bench/pass_times.py --physics $ph --n $N --threads $TH --json $OUT/pass_times_$ph.json 2>&1 | grep -v '^{'
  echo "$ph done after $(( $(date +%s) - T0 )) s"
done
for v in "OMP_PROC_BIND=close OMP_PLACES=cores" "OMP_WAIT_POLICY=active"; do
  name=$(echo $v | cut -d= -f1)
  env $v timeout 120 python3 bench/pass_times.py --n $N --threads $TV --json $OUT/pass_times_$name.json 2>&1 | grep -v '^{'
  echo "$v done after $(( $(date +%s) - T0 )) s"
done
