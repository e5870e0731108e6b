#!/usr/bin/env bash
# Short cases of every scene and physics variant, for bit-identity checks across a restructuring:
#   git worktree add /tmp/old <commit>
#   tools/identity_cases.sh /tmp/old /tmp/ident/old && tools/identity_cases.sh . /tmp/ident/new
#   python tools/compare_cases.py /tmp/ident/old /tmp/ident/new
# (~3-4 min per tree on 2 cores with empty kernel caches; wall times always differ. THREADS=1
# where the cores are busy: the numbers do not depend on the thread count.)
set -euo pipefail
TREE=$(cd "$1" && pwd); OUT=$2
mkdir -p "$OUT"
PY=${PYTHON:-$(dirname "$0")/../.venv/bin/python}
run() { PYTHONPATH="$TREE/src" "$PY" -m millsim.cli run --quiet --threads "${THREADS:-2}" "$@"; }
run single_particle --set mode=drop_weight --set n_particles=10 --out "$OUT/sp.nc"
run single_particle --set n_particles=10 --out "$OUT/sp1.nc"
run packing --set n=500 --set settle_steps=2000 --set steps=2000 --out "$OUT/box.nc"
run packing --set n=500 --set settle_steps=2000 --set steps=2000 --set force_sum=colour \
    --out "$OUT/box_colour.nc"
run packing --set container=drum --set n=500 --set settle_steps=1000 --set spinup_steps=1000 \
    --set steps=2000 --out "$OUT/drum.nc"
for scheme in explicit implicit; do
    run stirred_mill --set scale=0.3 --set revolutions=0.05 --set transient_revolutions=0.0 \
        --set eta=0.1 --set lubrication_scheme=$scheme --out "$OUT/stir_$scheme.nc"
done
# a start-up ending inside a chunk: the shaft follows the agitator's ramp between chunks (scene code)
run stirred_mill --set scale=0.3 --set revolutions=0.1 --set transient_revolutions=0.05 \
    --set ramp_revolutions=0.045 --set eta=0.1 --out "$OUT/stir_ramp.nc"
run bed_impact --set rings=2 --set layers=3 --out "$OUT/bed.nc"
run ballmill2d --set duration=0.3 --set transient=0.1 --out "$OUT/bm.nc"
run collision --set restitution=0.4 --out "$OUT/coll.nc"
run ballmill3d --set drum_diameter=0.15 --set drum_length=0.05 --set stiffness_scale=1e-4 \
    --set d_min_ratio=0.2 --set pour_time=0.1 --set settle_time=0.1 --set revolutions=0.5 \
    --set transient_revolutions=0.2 --set liner= --out "$OUT/bm3d.nc"
