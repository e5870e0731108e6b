#!/bin/bash
# The Python packages millsim needs that the lent device machine's image lacks (netCDF4, cftime,
# trimesh; it has numba, numpy, scipy, xarray, pandas, h5py, pyyaml), as CPython 3.12 wheels in
# .whl/ (ignored through .git/info/exclude), for the device scripts that name .whl in `carry`.
# Versions: the ones this project's .venv resolved. Run here, where pip reaches the index.
set -euo pipefail
grep -qx '/.whl/' .git/info/exclude 2>/dev/null || echo /.whl/ >> .git/info/exclude
mkdir -p .whl
python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
    --platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 \
    --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 --platform manylinux1_x86_64 \
    -d .whl netCDF4==1.7.5.1.post1 cftime==1.6.6.1 trimesh==4.12.2 certifi
ls -la .whl
