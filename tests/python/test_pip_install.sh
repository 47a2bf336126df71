#!/usr/bin/env bash
# `pip install --no-build-isolation ./python` (README, docs/python.md): a venv
# made with --system-site-packages (numpy from Debian), pip building the
# package from a copy of python/ (FFDKIT_SOURCE_DIR names the repository for
# its CMake build), no package index; then a fresh interpreter in another
# directory imports ffdkit and deforms points. Nothing outside a temporary
# directory is touched. usage: bash test_pip_install.sh PYTHON SOURCE_DIR
set -u
PY=$1
SRC=$(cd "$2" && pwd)
source "$SRC/tests/install/lib.sh"
"$PY" -c "import venv, pip, numpy, setuptools" 2>/dev/null ||
    { echo "SKIP: $PY lacks venv, pip, setuptools or numpy (bash scripts/setup.sh)"; exit 77; }
"$PY" -m venv --system-site-packages "$T/venv" >"$T/venv.log" 2>&1 || { fail "venv: $(cat "$T/venv.log")"; exit 1; }
mkdir -p "$T/pkg"
(cd "$SRC/python" && tar --exclude=./build --exclude='*.egg-info' --exclude=__pycache__ -cf - .) |
    (cd "$T/pkg" && tar -xf -)
FFDKIT_SOURCE_DIR=$SRC CMAKE_BUILD_PARALLEL_LEVEL=${CMAKE_BUILD_PARALLEL_LEVEL:-2} \
    "$T/venv/bin/pip" install --no-build-isolation --no-index --no-cache-dir "$T/pkg" >"$T/pip.log" 2>&1 ||
    { fail "pip install: $(tail -40 "$T/pip.log")"; exit 1; }
mkdir -p "$T/elsewhere"
cd "$T/elsewhere" || exit 1
env -u PYTHONPATH "$T/venv/bin/python" - "$SRC" >"$T/run.log" 2>&1 <<'PYEOF' || fail "import: $(cat "$T/run.log")"
import sys, pathlib
import numpy as np
import ffdkit
src = pathlib.Path(sys.argv[1])
where = pathlib.Path(ffdkit.__file__).resolve()
assert "site-packages" in str(where), where
assert not str(where).startswith(str(src)), where
assert ffdkit.__version__ == "0.1.0", ffdkit.__version__
rig = ffdkit.Rig.load(src / "examples/lattice/bend.json")
mesh = ffdkit.read_mesh(src / "examples/lattice/bunny.obj")
moved = rig.apply(mesh.points)
assert moved.shape == mesh.points.shape and np.abs(moved - mesh.points).max() > 0
print("ok", where)
PYEOF
grep -q '^ok ' "$T/run.log" || fail "the installed package did not run: $(cat "$T/run.log")"
[ "$failures" -eq 0 ] || exit 1
echo "python_pip_install: ok"
