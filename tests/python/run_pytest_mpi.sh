#!/usr/bin/env bash
# ffdkit.mpi's tests (python/tests/test_mpi.py) under Open MPI: every rank runs
# pytest on the same file, for 1, 2, 3 and 4 ranks (--oversubscribe: more
# ranks than cores), each run under a timeout so that a hang fails the test.
# usage: bash run_pytest_mpi.sh PYTHON BUILD_DIR SOURCE_DIR [SANITIZER_FLAGS|none] [RANKS...]
# exit 77 (skipped) without mpirun or when PYTHON lacks mpi4py, pytest or numpy.
set -u
PY=$1
BUILD=$(cd "$2" && pwd)
SRC=$(cd "$3" && pwd)
SAN=${4:-}
[ "$SAN" = none ] && SAN=
shift $(( $# < 4 ? $# : 4 ))
[ $# -gt 0 ] || set -- 1 2 3 4
if ! command -v mpirun >/dev/null; then
    echo "SKIP: no mpirun (Debian: openmpi-bin)"
    exit 77
fi
if ! "$PY" -c "import mpi4py, pytest, numpy" 2>/dev/null; then
    echo "SKIP: $PY lacks mpi4py, pytest or numpy (Debian: python3-mpi4py python3-pytest python3-numpy)"
    exit 77
fi
export PYTHONPATH=$BUILD/python
export PYTHONDONTWRITEBYTECODE=1
export FFDKIT_SOURCE_DIR=$SRC
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
# as root (containers, CI), Open MPI wants to be told
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
envs=(-x PYTHONPATH -x PYTHONDONTWRITEBYTECODE -x FFDKIT_SOURCE_DIR -x OMP_NUM_THREADS)
if [ -n "$SAN" ]; then
    asan=$(${CC:-cc} -print-file-name=libasan.so)
    [ -e "$asan" ] || { echo "FAIL: no libasan.so for the sanitizer build ($asan)"; exit 1; }
    # preloaded into the ranks only (-x NAME=VALUE), not into mpirun itself
    export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1
    export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 FFDKIT_TEST_SANITIZED=1
    envs+=(-x "LD_PRELOAD=$asan" -x ASAN_OPTIONS -x UBSAN_OPTIONS -x FFDKIT_TEST_SANITIZED)
fi
cd "$SRC"
status=0
for np in "$@"; do
    echo "== mpirun -np $np"
    timeout 120 mpirun --oversubscribe -np "$np" "${envs[@]}" \
        "$PY" -m pytest -q -p no:cacheprovider --color=no python/tests/test_mpi.py
    rc=$?
    if [ $rc -ne 0 ]; then
        [ $rc -eq 124 ] && echo "FAIL: -np $np did not finish within 120 s (a rank waits)"
        status=1
    fi
done
exit $status
