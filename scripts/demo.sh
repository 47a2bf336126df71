#!/usr/bin/env bash
# The main job: install what is needed, build, and bend the bundled Stanford bunny
# with a cubic B-spline lattice, then pin two of its points with direct manipulation.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh" "$root/build"
mkdir -p "$root/out"
"$root/build/ffd" deform "$root/examples/lattice/bunny.obj" -o "$root/out/bunny-bent.obj" \
    --rig "$root/examples/lattice/bend.json"
"$root/build/ffd" deform "$root/examples/lattice/bunny.obj" -o "$root/out/bunny-pinned.obj" \
    --rig "$root/examples/lattice/pins.json" --report
echo "deformed meshes written to $root/out/bunny-bent.obj and $root/out/bunny-pinned.obj"
