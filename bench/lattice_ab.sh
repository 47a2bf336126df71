#!/bin/bash
# A/B of two builds of bench_lattice_scale (old and new library), interleaved:
# ROUNDS rounds of (A, B), each a bench run of its own (--reps medians inside),
# then the median over rounds of each column. The machine is shared and noisy:
# only the interleaved medians mean anything.
# Usage: bench/lattice_ab.sh A_BIN B_BIN [ROUNDS] [bench options...]
#   e.g. bench/lattice_ab.sh /tmp/old/bench_lattice_scale build/bench_lattice_scale 7 \
#          --sizes 1000000 --basis bspline --res 8 --reps 5
set -euo pipefail
A=$1 B=$2 ROUNDS=${3:-7}
shift 3 || shift $#
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for r in $(seq "$ROUNDS"); do
  "$A" "$@" | grep '^| [0-9]' >>"$out/A"
  "$B" "$@" | grep '^| [0-9]' >>"$out/B"
done
median() { sort -g | awk '{v[NR]=$1} END {print v[int((NR+1)/2)]}'; }
echo "options: $* ; $ROUNDS interleaved rounds; medians over rounds"
echo "| build | points | bind ms | evaluate ms | RSS growth at bind B/point |"
echo "|---|---:|---:|---:|---:|"
for side in A B; do
  bin=$A; [ $side = B ] && bin=$B
  for n in $(awk -F'|' '{print $2}' "$out/$side" | sort -gu); do
    rows=$(awk -F'|' -v n="$n" '$2+0 == n+0' "$out/$side")
    bind=$(echo "$rows" | awk -F'|' '{print $3}' | median)
    eval_=$(echo "$rows" | awk -F'|' '{print $5}' | median)
    grow=$(echo "$rows" | awk -F'|' '{print $8}' | median)
    echo "| $side ($bin) | $n | $bind | $eval_ | $grow |"
  done
done
