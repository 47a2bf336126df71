#!/usr/bin/env bash
# Installs every Debian package ffdkit needs. Idempotent: re-running installs nothing new.
# The Python package (python/, docs/python.md) is built with the rest: its
# headers, NumPy, and pip/setuptools/venv for `pip install ./python`.
# Open MPI builds ffd-mpi and runs its tests (docs/mpi.md); mpi4py is ffdkit.mpi's.
# With --test also the packages only the tests use: Blender (a real glTF client
# that imports what ffd writes), pytest, and SciPy and meshio (the Python
# package's optional sparse matrices and meshio interop).
set -euo pipefail
PKGS=(build-essential cmake pkg-config
      liblapacke-dev libopenblas-dev libcjson-dev
      clang libclang-rt-14-dev
      libqhull-dev libsuitesparse-dev zlib1g-dev
      libmicrohttpd-dev chromium curl libomp-dev valgrind
      groff-base dpkg-dev file binutils
      python3-dev python3-numpy python3-pip python3-setuptools python3-venv
      libopenmpi-dev openmpi-bin python3-mpi4py)
if [ "${1:-}" = "--test" ]; then
  PKGS+=(blender python3-pytest python3-scipy python3-meshio)
fi
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  echo "setup: installing ${missing[*]}" >&2
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
# Node.js and npm build the editor's page (three.js) and drive its browser tests
# (playwright-core with Debian's chromium). Debian's nodejs/npm unless a Node.js is already there.
if ! command -v npm >/dev/null 2>&1; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  echo "setup: installing nodejs npm" >&2
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null
fi
root=$(cd "$(dirname "$0")/.." && pwd)
if [ -f "$root/web/package-lock.json" ] && \
   { [ ! -d "$root/web/node_modules" ] || [ "$root/web/package-lock.json" -nt "$root/web/node_modules/.package-lock.json" ]; }; then
  echo "setup: installing the editor's npm packages" >&2
  (cd "$root/web" && npm ci --no-audit --no-fund --loglevel=error >/dev/null)
fi
