#!/bin/bash
# A/B of two builds of a benchmark that prints a table whose rows start with
# "| <points> |" (bench_pbffd --curve, bench_gffd N --curve), interleaved:
# ROUNDS rounds of (A, B), then per build and per first column the median of
# every other column over the rounds. The machine is shared and noisy: only
# the interleaved medians mean anything.
# Usage: bench/curve_ab.sh A_BIN B_BIN ROUNDS [bench arguments...]
#   e.g. bench/curve_ab.sh /tmp/old/bench_pbffd build/bench_pbffd 7 data --curve
#        bench/curve_ab.sh /tmp/old/bench_gffd build/bench_gffd 7 100000 --curve
set -euo pipefail
A=$1 B=$2 ROUNDS=$3
shift 3
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for r in $(seq "$ROUNDS"); do
  "$A" "$@" | grep '^| [0-9]' >>"$out/A"
  "$B" "$@" | grep '^| [0-9]' >>"$out/B"
done
echo "arguments: $* ; $ROUNDS interleaved rounds; medians over rounds of each column"
for side in A B; do
  bin=$A; [ "$side" = B ] && bin=$B
  echo "$side: $bin"
  awk -F'|' '{ key = $2 + 0; if (!(key in seen)) { seen[key] = 1; order[++nk] = key }
               cols = NF - 2; for (c = 3; c < NF; c++) v[key, c, ++cnt[key, c]] = $c + 0 }
       END { for (k = 1; k <= nk; k++) { key = order[k]; line = "| " key " |"
               for (c = 3; c < cols + 2; c++) { n = cnt[key, c]
                 for (i = 1; i <= n; i++) a[i] = v[key, c, i]
                 for (i = 2; i <= n; i++) { t = a[i]; j = i - 1
                   while (j >= 1 && a[j] > t) { a[j + 1] = a[j]; j-- } a[j + 1] = t }
                 line = line " " a[int((n + 1) / 2)] " |" }
               print line } }' "$out/$side"
done
