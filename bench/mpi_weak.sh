#!/usr/bin/env bash
# Weak scaling of a distributed morph on this machine (docs/scaling.md): bench_mpi
# with 1, 2, 3, 4 ranks and the same points per rank, each run's table in turn.
# usage: bash bench/mpi_weak.sh [BUILD_DIR] [bench_mpi options...]
#   e.g. bash bench/mpi_weak.sh build --points 1000000 --reps 5
#        bash bench/mpi_weak.sh build --case pbffd --points 250000 --surface 100
# Ranks beyond the cores share them (--oversubscribe): on a 2-core machine the
# 3- and 4-rank rows measure oversubscription, not scaling (say so with the numbers).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-"$root/build"}
shift || true
bin=$build/bench_mpi
[ -x "$bin" ] || { echo "no $bin (configure with an MPI for C: libopenmpi-dev)"; exit 1; }
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# one OpenMP thread per rank: ranks are the parallelism measured here
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
echo "# $(date -u +%FT%TZ) $(uname -m), $(nproc --all) cores: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
echo "# load before: $(cut -d' ' -f1-3 /proc/loadavg); OMP_NUM_THREADS=$OMP_NUM_THREADS"
for np in ${RANKS:-1 2 3 4}; do
    timeout 900 mpirun --oversubscribe -np "$np" -x OMP_NUM_THREADS "$bin" "$@"
done
