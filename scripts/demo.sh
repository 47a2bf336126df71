#!/usr/bin/env bash
# The main job: install what is needed, build, and bend the bundled Stanford bunny
# with a cubic B-spline lattice, then pin two of its points with direct manipulation;
# install the Python package (pip, in .venv) and drag the bunny from Python.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh" "$root/build"
mkdir -p "$root/out"
"$root/build/ffd" deform "$root/examples/lattice/bunny.obj" -o "$root/out/bunny-bent.obj" \
    --rig "$root/examples/lattice/bend.json"
"$root/build/ffd" deform "$root/examples/lattice/bunny.obj" -o "$root/out/bunny-pinned.obj" \
    --rig "$root/examples/lattice/pins.json" --report
# The Python package, installed into a venv that sees Debian's NumPy (no package index):
# then a direct-manipulation loop on the bunny from Python.
PY=/usr/bin/python3  # Debian's, which has the NumPy setup.sh installed
[ -x "$PY" ] || PY=python3
"$PY" -m venv --system-site-packages "$root/.venv"
CMAKE_BUILD_PARALLEL_LEVEL=${CMAKE_BUILD_PARALLEL_LEVEL:-2} \
    "$root/.venv/bin/pip" install --quiet --no-build-isolation --no-index "$root/python"
(cd "$root/out" && "$root/.venv/bin/python" "$root/examples/python/direct_manipulation.py" \
    "$root/out/bunny-dragged.obj")
echo "deformed meshes written to $root/out/bunny-bent.obj and $root/out/bunny-pinned.obj"
echo "Python: the package ffdkit is installed in $root/.venv ($root/.venv/bin/python -c 'import ffdkit');"
echo "        examples/python/direct_manipulation.py wrote $root/out/bunny-dragged.obj"
