#!/usr/bin/env bash
# Configures and builds ffdkit. Usage: scripts/build.sh [BUILD_DIR] [extra cmake args...]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
dir=${1:-"$root/build"}
shift || true
# the tests, benchmarks and fuzz targets are optional in CMake; the scripts build them all.
# The Python package is built for Debian's python3 (python3-numpy), never another one first on PATH.
py=()
if [ -x /usr/bin/python3 ]; then py=(-DPython3_EXECUTABLE=/usr/bin/python3); fi
cmake -S "$root" -B "$dir" -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=ON -DFFD_BUILD_BENCH=ON \
    -DFFD_BUILD_FUZZ=ON "${py[@]}" "$@" >/dev/null
cmake --build "$dir" -j"$(nproc)" >/dev/null
# The editor's page (three.js, bundled by esbuild) when its npm packages are installed.
if [ -d "$root/web/node_modules" ]; then
  (cd "$root/web" && npm run --silent build >/dev/null)
fi
