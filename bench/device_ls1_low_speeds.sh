#!/bin/bash
# Issue 12, item 2 on a lent 16-core machine (the device tool): the dry full LS1 at 1500 and
# 1000 rpm, config/paper.yaml's stirred-mill parameters as bench/ls1_dry_speeds.sh, half a
# revolution of ramp, 4 revolutions, the last 2 averaged, 16 threads, one case after the other.
# The 2-core development VM needs about 0.7 h (1500 rpm) and 1 h (1000 rpm) of one idle core
# for these; 16 threads should take 4-7 min each, so the 1000 rpm case may not finish inside one
# 10-minute call: it checkpoints every 30 s, and what its last checkpoint holds is read on the
# machine (bench/ls1_checkpoint_series.py) before the call ends.
#
# Before the call, here: `bash bench/device_wheels.sh` (netCDF4, cftime and trimesh as wheels in
# .whl/). The call: run(command="bash bench/device_ls1_low_speeds.sh", carry=[".whl"],
# timeout_s=600). Afterwards, here: `python bench/ls1_study.py <files_at>/*.nc --json
# bench/out/full_ls1_dry_low_speeds.json`. Thread count does not change the numbers; another
# numba or numpy version may change the last bits (the case files record the versions).
set -u
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
    --target /tmp/site .whl/*.whl || exit 1
export PYTHONPATH=$PWD/src:/tmp/site PYTHONUNBUFFERED=1
T0=$(date +%s); BUDGET=${BUDGET:-560}; REVOLUTIONS=${REVOLUTIONS:-4}; SPEEDS=${SPEEDS:-1500 1000}
{ nproc; lscpu | grep -E "Model name|Thread|Core|L3"; cat /proc/loadavg
  python3 -c "import numba, numpy, netCDF4, trimesh, yaml; print('numba', numba.__version__, 'numpy', numpy.__version__)"; } > $OUT/env.txt 2>&1
cat $OUT/env.txt
for rpm in $SPEEDS; do
  left=$(( BUDGET - ($(date +%s) - T0) ))
  [ $left -gt 60 ] || { echo "no time left for $rpm rpm"; break; }
  out=$OUT/dry_rpm${rpm}_${REVOLUTIONS}rev.nc
  timeout $(( left - 25 )) python3 -m millsim.cli run stirred_mill --set scale=1.0 --set slice=false \
      --set bead_diameter_min=0.0018 --set bead_diameter_max=0.0018 --set initial_swirl=0.1 \
      --set seed=1 --set dt_factor=2.0 --set friction=0.3 --set eta=0 --set rpm=$rpm \
      --set revolutions=$REVOLUTIONS --set transient_revolutions=$(( REVOLUTIONS / 2 )) \
      --set ramp_revolutions=0.5 --threads ${THREADS:-16} --checkpoint-every 30 ${EXTRA:-} \
      --out $out 2>&1 | tail -n 4
  if [ -f $out.ckpt ]; then  # stopped by the timeout: the power its last checkpoint holds
    python3 bench/ls1_checkpoint_series.py $out.ckpt --json $OUT/dry_rpm${rpm}_partial.json
  fi
  echo "$rpm rpm done after $(( $(date +%s) - T0 )) s"
done
ls -la $OUT
