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
# 10^8 points: ~12 GB; skipped (named in the output) on a machine with less than 20 GiB
if [ "$(awk '/MemTotal/ {print int($2 / 1048576)}' /proc/meminfo)" -ge 20 ]; then
    run lattice_scale_1e8 "$BUILD/bench_lattice_scale" --sizes 100000000 --reps 2
else
    echo "skipped: 10^8 points need ~12 GB" >"$OUT/lattice_scale_1e8.txt"
fi
run mesh_io "$BUILD/bench_mesh_io" 1000000 "$R"
run blas_threads "$BUILD/bench_blas_threads"
run tspline_scale "$BUILD/bench_scale_tspline" "$root/data" 10000 100000 437000
run tspline "$BUILD/bench_tspline" "$root/data"
# the whole `ffd tspline proxy` command on the 437K-vertex subdivided elephant
proxy_cmd() {
    local ply="$OUT/elephant437k.ply"
    "$BUILD/bench_scale_tspline" "$root/data" --write 437000 "$ply"
    for i in 1 2 3; do
        /usr/bin/time -f "tspline proxy 437K: %e s wall, %U s user, %S s sys, %M KB peak" \
            "$BUILD/ffd" tspline proxy "$ply" -o "$OUT/proxy437k.obj" --resolution 12 --quiet
    done
    rm -f "$ply" "$OUT/proxy437k.obj"
}
run tspline_proxy proxy_cmd
run pbffd "$BUILD/bench_pbffd" "$root/data" $QUICK
run placement "$BUILD/bench_placement" "$root/data" $QUICK
run gffd "$BUILD/bench_gffd"
run session "$BUILD/bench_session" "$root/data"
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)" >>"$OUT/machine.txt"
