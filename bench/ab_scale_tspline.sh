#!/bin/sh
# ab_scale_tspline.sh OLD NEW [N] [ROUNDS] — A/B of two bench_scale_tspline
# builds (e.g. one built from the previous commit), interleaved round by
# round so that machine noise hits both alike; prints each one's medians of
# the rig path's bind, evaluate and bind + evaluate (ms, wall) and CPU time
# (ms, all threads), the whole program's CPU seconds,
# and the output checksum (equal checksums: equal bits).
set -eu
old=$1 new=$2 n=${3:-100000} rounds=${4:-7}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
i=0
while [ "$i" -lt "$rounds" ]; do
    for which in old new; do
        eval bin=\$$which
        /usr/bin/time -f "%U %S" -o "$tmp/t" "$bin" "$n" --rounds 1 | tail -1 >>"$tmp/$which"
        awk '{print $1 + $2}' "$tmp/t" >>"$tmp/$which.cpu"
    done
    i=$((i + 1))
done
for which in old new; do
    # columns of a row: | N | faces | cells | bind | eval | jac | fold | total | us | sum | rig bind | rig eval | rig total | rig us |
    awk -F'|' -v w="$which" '{gsub(/[ *]/, ""); b[NR] = $12; e[NR] = $13; t[NR] = $14; c[NR] = $16; s = $11}
        function med(a, n,   i, j, x) { for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (a[j] < a[i]) { x = a[i]; a[i] = a[j]; a[j] = x } return a[int((n + 1) / 2)] }
        END { printf "%s: rig bind %s ms, rig evaluate %s ms, rig bind + evaluate %s ms, rig CPU %s ms (medians of %d), checksum %s\n", w, med(b, NR), med(e, NR), med(t, NR), med(c, NR), NR, s }' "$tmp/$which"
    sort -n "$tmp/$which.cpu" | awk -v w="$which" '{a[NR] = $1} END {printf "%s: CPU seconds per run (whole program, median) %s\n", w, a[int((NR + 1) / 2)]}'
done
