#!/usr/bin/env bash
# ffdkit, Blender's Lattice modifier and PyGeM's FFD side by side on the same
# random points and the same 5^3 lattice move, interleaved round by round.
#   bash bench/peers.sh [--points N] [--rounds R] [--build DIR] [--pygem CHECKOUT]
# Blender runs when `blender` is installed (Debian's blender; -t 2), PyGeM
# when --pygem names a checkout of https://github.com/mathLab/PyGeM (it needs
# NumPy and SciPy). Each figure is the median over the rounds; the ratios at
# the end are peer time / ffdkit time (> 1: ffdkit is faster).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
N=1000000 R=7 BUILD="$root/build" PYGEM=""
while [ $# -gt 0 ]; do
    case "$1" in
        --points) N=$2; shift 2 ;;
        --rounds) R=$2; shift 2 ;;
        --build) BUILD=$2; shift 2 ;;
        --pygem) PYGEM=$2; shift 2 ;;
        *) echo "usage: bash bench/peers.sh [--points N] [--rounds R] [--build DIR] [--pygem CHECKOUT]" >&2; exit 2 ;;
    esac
done
FFD="$BUILD/ffd" PEERS="$BUILD/bench_peers"
[ -x "$FFD" ] && [ -x "$PEERS" ] || { echo "peers.sh: build first (scripts/build.sh $BUILD)" >&2; exit 1; }
PY=/usr/bin/python3
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
"$PEERS" gen "$N" "$T"
HAVE_BLENDER=0; command -v blender >/dev/null 2>&1 && HAVE_BLENDER=1
[ -n "$PYGEM" ] && [ ! -d "$PYGEM/pygem" ] && { echo "peers.sh: $PYGEM is not a PyGeM checkout" >&2; exit 1; }

ms() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.3f", (b - a) / 1e6 }'; }
declare -A S
add() { S[$1]+="$2 "; }
for r in $(seq "$R"); do
    t0=$(date +%s%N); "$FFD" deform "$T/points.ply" -o "$T/out.ply" --rig "$T/rig-bspline.json" --quiet >/dev/null
    t1=$(date +%s%N); "$FFD" convert "$T/points.ply" "$T/copy.ply" --quiet >/dev/null
    t2=$(date +%s%N)
    add deform "$(ms "$t0" "$t1")"; add convert "$(ms "$t1" "$t2")"
    read -r _ be _ em < <("$PEERS" time "$T" bspline 3); add bind_bspline "$be"; add move_bspline "$em"
    read -r _ be _ em < <("$PEERS" time "$T" bernstein 3); add bind_bernstein "$be"; add move_bernstein "$em"
    if [ "$HAVE_BLENDER" = 1 ]; then
        line=$(blender -b --factory-startup -t 2 --python "$root/bench/peers_blender.py" -- "$T" 3 2>/dev/null | grep '^depsgraph_update')
        read -r _ bu _ bb _ <<<"$line"; add blender "$bu"; add blender_copy "$bb"
    fi
    if [ -n "$PYGEM" ]; then
        line=$("$PY" "$root/bench/peers_pygem.py" "$PYGEM" "$T" 1 | grep '^ffd_call')
        read -r _ pg _ <<<"$line"; add pygem "$pg"
    fi
done
med() { tr ' ' '\n' <<<"${S[$1]:-}" | { grep -v '^$' || true; } | sort -g | awk '{a[NR]=$1} END {if (NR) print a[int((NR+1)/2)]; else print "-"}'; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { if (a == "-" || b == "-") print "-"; else printf "%.1f", a / b }'; }
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //')
echo "$N points, 5^3 lattice, every control moved; median of $R interleaved rounds; $cpu, $(nproc) CPUs"
echo "ffdkit SIMD path: $("$PEERS" path 2>/dev/null || echo unknown)"
printf '%-48s %10s\n' "measure" "ms"
for k in deform convert bind_bspline move_bspline bind_bernstein move_bernstein blender blender_copy pygem; do
    printf '%-48s %10s\n' "$k" "$(med "$k")"
done
echo
B=$(med blender) P=$(med pygem)
printf 'whole ffd deform (binary PLY) vs Blender update:  %sx  (goal >= 3)\n' "$(ratio "$B" "$(med deform)")"
printf 'bind + evaluate (B-spline) vs Blender update:      %sx  (goal >= 10)\n' "$(ratio "$B" "$(med bind_bspline)")"
printf 'bind + evaluate (Bernstein) vs PyGeM FFD:          %sx  (goal >= 100)\n' "$(ratio "$P" "$(med bind_bernstein)")"
printf 'evaluate after a move (B-spline) vs Blender:       %sx  (goal >= 20)\n' "$(ratio "$B" "$(med move_bspline)")"
