#!/bin/sh
# bench_deform_rss — peak resident memory and wall time of `ffd deform` on
# generated random points (binary little-endian PLY of doubles, x y z only)
# with a 5x5x5 B-spline lattice rig (examples/lattice/bend.json).
#
# usage: bench/bench_deform_rss.sh [FFD] [POINTS...]
#   FFD      the ffd binary (default build/ffd)
#   POINTS   point counts (default 1000000 10000000)
# Prints, per count: peak RSS (kB), bytes per point, wall seconds.
# Needs GNU time (/usr/bin/time) and python3; files go to a temporary folder.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
ffd=${1:-build/ffd}
[ $# -gt 0 ] && shift
counts=${*:-1000000 10000000}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for n in $counts; do
    python3 - "$n" "$tmp/p$n.ply" <<'PY'
import random, struct, sys
n = int(sys.argv[1])
random.seed(17)
with open(sys.argv[2], "wb") as f:
    f.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\n"
             "property double x\nproperty double y\nproperty double z\nend_header\n" % n).encode())
    chunk = 1 << 16
    for s in range(0, n, chunk):
        k = min(chunk, n - s)
        f.write(struct.pack("<%dd" % (3 * k), *[random.random() for _ in range(3 * k)]))
PY
    /usr/bin/time -f "%M %e" -o "$tmp/t" "$ffd" deform "$tmp/p$n.ply" -o "$tmp/o$n.ply" \
        --rig "$here/../examples/lattice/bend.json" --no-limits 2>/dev/null >/dev/null
    read -r kb sec < "$tmp/t"
    echo "$n points: peak RSS $kb kB, $(( kb * 1024 / n )) bytes/point, ${sec} s"
    rm -f "$tmp/p$n.ply" "$tmp/o$n.ply"
done
