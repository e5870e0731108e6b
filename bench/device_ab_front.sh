#!/bin/bash
# Issue 13 on a lent 16-core machine: the list rebuild's front (bounding box, size levels, cell
# binning) serial (old: .lg/ab_old/src, the tree before: `git archive a2cbf64 src | tar -x -C
# .lg/ab_old`) against blocked-parallel (new: src),
# bench/scaling.py's child in alternating order. Prints one JSON line per run.
set -u
export PYTHONUNBUFFERED=1
T0=$(date +%s)
run() {  # tree physics threads
  PYTHONPATH=$1:$PWD/.lg/site NUMBA_NUM_THREADS=16 python3 bench/scaling.py --child $2 ${N:-100000} 200 1.0 $3 0.1 1000.0 2>/dev/null | tail -1 | python3 -c "
import json, sys; r = json.loads(sys.stdin.read()); print(json.dumps(dict(tree='$1'.split('/')[-2], physics=r['physics'], threads=r['threads_used'], loop_s=round(r['loop_s'], 4), rebuild_s=round(r['rebuild_s'], 4), rebuilds=r['list_rebuilds'], rate=r['particle_steps_per_s'], load=r['loadavg'])))"
}
for tree in $PWD/.lg/ab_old/src $PWD/src; do for ph in ballmill2d beads_lubrication; do
  (N=3000 run $tree $ph 1 > /dev/null) &
done; done; wait; echo "compiled after $(( $(date +%s) - T0 )) s"
for t in 16 16 1; do for tree in $PWD/.lg/ab_old/src $PWD/src; do run $tree ballmill2d $t; done; done
echo "ballmill2d after $(( $(date +%s) - T0 )) s"
for t in 16; do for tree in $PWD/.lg/ab_old/src $PWD/src $PWD/.lg/ab_old/src $PWD/src; do run $tree beads_lubrication $t; done; done
echo "done after $(( $(date +%s) - T0 )) s"
