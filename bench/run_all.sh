#!/usr/bin/env bash
# Runs every benchmark of bench/ once, in turn, on a quiet machine, and keeps
# each one's output in OUT/NAME.txt (with the machine and the SIMD path in
# OUT/machine.txt) for docs/benchmarks.md.
#   bash bench/run_all.sh [--build DIR] [--out DIR] [--quick]
# --quick: fewer rounds (a smoke run; not for the docs).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
BUILD="$root/build" OUT="$root/build/bench-results" QUICK=""
while [ $# -gt 0 ]; do
    case "$1" in
        --build) BUILD=$2; shift 2 ;;
        --out) OUT=$2; shift 2 ;;
        --quick) QUICK=--quick; shift ;;
        *) echo "usage: bash bench/run_all.sh [--build DIR] [--out DIR] [--quick]" >&2; exit 2 ;;
    esac
done
mkdir -p "$OUT"
{
    date -u +"%Y-%m-%d %H:%M UTC"
    grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'
    echo "$(nproc) CPUs, $(awk '/MemTotal/ {printf "%.0f GiB", $2 / 1048576}' /proc/meminfo)"
    echo "lattice SIMD path: $("$BUILD/bench_peers" path)"
    echo "load before: $(cut -d' ' -f1-3 /proc/loadavg)"
    gcc --version | head -1
} >"$OUT/machine.txt"
cat "$OUT/machine.txt"
run() {
    local name=$1; shift
    local t0=$SECONDS
    echo "== $name: $*" >&2
    "$@" >"$OUT/$name.txt" 2>&1 || echo "$name FAILED (see $OUT/$name.txt)" >&2
    echo "   $((SECONDS - t0)) s" >&2
}
R=7; [ -n "$QUICK" ] && R=2
run peers bash "$root/bench/peers.sh" --build "$BUILD" --rounds "$R"
run lattice "$BUILD/bench_lattice" $QUICK
run lattice_scale "$BUILD/bench_lattice_scale" --max 10000000
run mesh_io "$BUILD/bench_mesh_io" 1000000 "$R"
run blas_threads "$BUILD/bench_blas_threads"
run tspline_scale "$BUILD/bench_scale_tspline" "$root/data" 10000 100000 437000
run tspline "$BUILD/bench_tspline" "$root/data"
run pbffd "$BUILD/bench_pbffd" "$root/data" $QUICK
run placement "$BUILD/bench_placement" "$root/data" $QUICK
run gffd "$BUILD/bench_gffd"
run session "$BUILD/bench_session" "$root/data"
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)" >>"$OUT/machine.txt"
