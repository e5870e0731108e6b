#!/bin/bash
# Issue 13 on a lent 16-core machine that has no network (the device tool): strong scaling (1-16
# threads, LIGGGHTS beside millsim on the box) and the concurrent check, results into $OUT.
#
# It runs from the repository root with the image's python3 (numba, numpy, scipy, xarray, h5py)
# and two things carried in .lg/ (ignored by git), made on the 2-core Debian 12 VM:
#   .lg/site/trimesh: copied from .venv/lib/python3*/site-packages/trimesh (not in that image);
#   .lg/liggghts_bookworm.tar.xz: LIGGGHTS 3.8 and Open MPI 4.1 of Debian 12, unpacked into / with
#     --skip-old-files (the image's own libraries win): the files of the packages liggghts,
#     libliggghts3, openmpi-bin, libopenmpi3, openmpi-common, the pmix2/openmpi plugin trees, and
#     every library `ldd` lists for them except glibc's, libstdc++ and libgcc_s (12 MB).
# Carried beside them: bench/out/liggghts/box_1 and bench/out/millsim_box_state.csv (the box).
# Timeouts: 330 s and 120 s, so that the whole call fits one 10-minute device command.
set -u
export PYTHONPATH=$PWD/src:$PWD/.lg/site PYTHONUNBUFFERED=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
T0=$(date +%s)
{ nproc; lscpu | grep -E "Model name|Socket|Thread|Core|NUMA|L3|MHz"; free -g | head -2; cat /proc/loadavg
  python3 -c "import numba, numpy, scipy, xarray, h5py; print('numba', numba.__version__, 'numpy', numpy.__version__)"
  which mpirun liggghts; } > $OUT/env.txt 2>&1
# LIGGGHTS 3.8 + Open MPI 4.1 of Debian 12 (package files and the libraries they load), where the image lacks them
tar --skip-old-files -xJf .lg/liggghts_bookworm.tar.xz -C / 2>>$OUT/env.txt; ldconfig
{ which mpirun liggghts; liggghts -h 2>&1 | grep -m1 Version
  echo "mpirun -np 2:"; mpirun --allow-run-as-root --oversubscribe -np 2 liggghts -h 2>&1 | grep -c Version; } >> $OUT/env.txt 2>&1
cat $OUT/env.txt
# compile once, all at once (the kernel cache serves every later process)
for ph in ballmill2d hertz_tavares beads_lubrication; do
  python3 bench/scaling.py --child $ph 3000 5 1.0 1 0.1 1000.0 > /dev/null 2> $OUT/warm_$ph.err &
done
python3 -c "import sys; sys.path.insert(0, 'bench'); import engine_throughput as e; print(e.run_millsim({'container': 'box', 'init_file': 'bench/out/millsim_box_state.csv', 'dt': 1e-6, 'skin': 2e-4, 'convention': 'unclipped'}, 0, 1, None))" 2> $OUT/warm_box.err
wait; echo "compiled after $(( $(date +%s) - T0 )) s"; tail -n 2 $OUT/warm_*.err
timeout 330 python3 bench/strong_scaling.py --n 100000 --steps 200 --box-steps 5000 --json $OUT/strong_scaling_16.json > $OUT/strong.log 2>&1
echo "strong scaling done after $(( $(date +%s) - T0 )) s"; cat $OUT/strong.log
timeout 120 python3 bench/strong_scaling.py --cores 1 --n 100000 --steps 200 --no-box --concurrent 16 --json $OUT/concurrent_16.json > $OUT/concurrent.log 2>&1
echo "all done after $(( $(date +%s) - T0 )) s"; tail -n 25 $OUT/concurrent.log
