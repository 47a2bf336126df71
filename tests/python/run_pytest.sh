#!/usr/bin/env bash
# The Python package's tests (python/tests, pytest) against the module built
# in BUILD_DIR/python. In a sanitizer build the module carries ASan+UBSan,
# whose runtime must be loaded first (LD_PRELOAD of the compiler's libasan;
# leak detection off: CPython keeps its own allocations to exit).
# usage: bash run_pytest.sh PYTHON BUILD_DIR SOURCE_DIR [SANITIZER_FLAGS|none] [PYTEST_ARGS...]
# PYTEST_ARGS (default python/tests) selects the files: CMake runs the suite as
# three tests (python_tests, python_tests_methods, python_tests_volume) so that
# ctest -j spreads it over the cores.
# exit 77 (skipped) when pytest or numpy is missing.
set -u
PY=$1
BUILD=$(cd "$2" && pwd)
SRC=$(cd "$3" && pwd)
SAN=${4:-}
[ "$SAN" = none ] && SAN= # CMake's placeholder for no sanitizer flags
shift $(( $# < 4 ? $# : 4 ))
[ $# -gt 0 ] || set -- python/tests
if ! "$PY" -c "import pytest, numpy" 2>/dev/null; then
    echo "SKIP: $PY lacks pytest or numpy (Debian: python3-pytest python3-numpy; bash scripts/setup.sh --test)"
    exit 77
fi
export PYTHONPATH=$BUILD/python
export PYTHONDONTWRITEBYTECODE=1
export FFDKIT_SOURCE_DIR=$SRC
# one OpenMP thread unless told otherwise: on a loaded machine the library's
# spinning worker threads make each small call milliseconds long (the
# results are the same for any thread count)
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
if [ -n "$SAN" ]; then
    asan=$(${CC:-cc} -print-file-name=libasan.so)
    [ -e "$asan" ] || { echo "FAIL: no libasan.so for the sanitizer build ($asan)"; exit 1; }
    export LD_PRELOAD=$asan
    export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1
    export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
    export FFDKIT_TEST_SANITIZED=1
fi
cd "$SRC"
exec "$PY" -m pytest -q -p no:cacheprovider "$@"
