#!/usr/bin/env bash
# ffd deform --max-memory / --no-limits (docs/rig.md "Limits"): the same rig is
# accepted under the defaults, refused under a lower memory limit with a
# message naming the key, the estimate and the limit, and accepted again
# with --no-limits; malformed sizes are usage errors. The cases over the
# default limits themselves are in tests/bad (tspline-limit-*, gffd-limit-*).
set -u
source "$(dirname "$0")/lib.sh" "$@"
BUNNY=$SRC/examples/tspline/bunny.obj
CUBE=$SRC/tests/data/rig/cube.obj

# three proxy refinements: about 7,700 cells (62 MB estimated)
cat >"$T/refine.json" <<'JSON'
{"version": 1, "deformer": "tspline", "resolution": [5, 5, 5],
 "steps": [{"refine": [{"cells": "proxy"}]}, {"refine": [{"cells": "proxy"}]}]}
JSON
ok deform "$BUNNY" -o "$T/a.obj" --rig "$T/refine.json"
bad 1 deform "$BUNNY" -o "$T/b.obj" --rig "$T/refine.json" --max-memory 4M
has stderr "refine.json: steps[1].refine: refining"
has stderr "of memory (limit 4 MiB; --max-memory or --no-limits to raise)"
[ ! -e "$T/b.obj" ] || fail "a refused rig wrote its output"
ok deform "$BUNNY" -o "$T/c.obj" --rig "$T/refine.json" --max-memory 4M --no-limits
cmp -s "$T/a.obj" "$T/c.obj" || fail "--no-limits changed the result"
ok deform "$BUNNY" -o "$T/d.obj" --rig "$T/refine.json" --max-memory 8G
cmp -s "$T/a.obj" "$T/d.obj" || fail "--max-memory 8G changed the result"

# a GFFD field of about 4,000 samples: a 128 MB matrix
cat >"$T/field.json" <<'JSON'
{"version": 1, "deformer": "gffd",
 "skeleton": [{"type": "polyline", "vertices": [[0, 0, 0], [79, 0, 0]], "radius": 1}],
 "edits": [{"primitive": 0, "translate": [0, 0.5, 0]}]}
JSON
bad 1 deform "$CUBE" -o "$T/e.obj" --rig "$T/field.json" --max-memory 64M
has stderr "field.json: skeleton[0]: a field of about"
has stderr "(max_samples 4000)"
has stderr "(limit 64 MiB; --max-memory or --no-limits to raise)"

# a direct-manipulation solve: 3 constraints are cheap
cat >"$T/pins.json" <<'JSON'
{"version": 1, "resolution": [4, 4, 4],
 "constraints": [{"vertex": 0, "target": [0, 0, 0.1]}]}
JSON
ok deform "$CUBE" -o "$T/f.obj" --rig "$T/pins.json"

for size in 0 -1 8X 1e30 "" G 1.5Q; do
    bad 2 deform "$CUBE" -o "$T/g.obj" --rig "$T/pins.json" --max-memory "$size"
    has stderr "--max-memory"
done
ok deform "$CUBE" -o "$T/h.obj" --rig "$T/pins.json" --max-memory 512MiB
ok deform "$CUBE" -o "$T/h.obj" --rig "$T/pins.json" --max-memory 3000000000

[ "$failures" -eq 0 ] || exit 1
echo "cli limits: ok"
