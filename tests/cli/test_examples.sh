#!/usr/bin/env bash
# Runs every JSON rig in examples/lattice/ on the example mesh and checks that
# the output differs from the input in positions only: same counts and
# topology (ffd info --json), same non-vertex lines, at least one moved vertex.
# usage: bash test_examples.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
EX=$SRC/examples/lattice
MESH=$EX/bunny.obj

# info --json without the file name and the bounding box: what must not change.
topology() {
    "$FFD" info --json "$1" | sed -e 's/"file": "[^"]*", //' -e 's/, "bbox": .*//'
}

IN_SUM=$(cksum <"$MESH")
"$FFD" info --json "$MESH" >"$T/info.json" || fail "ffd info $MESH failed"
grep -q '"vertices": 1839, "faces": 3674' "$T/info.json" || fail "unexpected example mesh: $(cat "$T/info.json")"
want=$(topology "$MESH")
count=0
for rig in "$EX"/*.json; do
    name=$(basename "$rig" .json)
    out=$T/$name.obj
    count=$((count + 1))
    if ! "$FFD" deform "$MESH" -o "$out" --rig "$rig" --report >"$T/$name.report" 2>"$T/$name.err"; then
        fail "$name: ffd deform failed: $(cat "$T/$name.err")"
        continue
    fi
    [ -s "$out" ] || { fail "$name: no output"; continue; }
    grep -qF "wrote $out (1839 vertices, 3674 faces)" "$T/$name.err" || fail "$name: no 'wrote' line: $(cat "$T/$name.err")"
    grep -q '"max_residual"' "$T/$name.report" || fail "$name: --report printed no JSON report"
    [ "$(topology "$out")" = "$want" ] || fail "$name: counts or topology changed: $(topology "$out")"
    diff <(grep -v '^v ' "$MESH") <(grep -v '^v ' "$out") >/dev/null || fail "$name: non-vertex lines changed"
    [ "$(grep -c '^v ' "$out")" = 1839 ] || fail "$name: vertex line count changed"
    cmp -s <(grep '^v ' "$MESH") <(grep '^v ' "$out") && fail "$name: no vertex moved"
done
[ "$count" -ge 3 ] || fail "expected at least 3 example rigs, found $count"

# The direct-manipulation example reaches its pins.
if [ -f "$EX/pins.json" ]; then
    sed -e 's/.*"max_residual": \([^,]*\),.*/\1/' "$T/pins.report" >"$T/maxres"
    awk '{ exit !($1 <= 1e-9) }' "$T/maxres" || fail "pins.json: max_residual $(cat "$T/maxres") > 1e-9"
fi

[ "$(cksum <"$MESH")" = "$IN_SUM" ] || fail "the example mesh was modified"
if [ "$failures" -ne 0 ]; then
    echo "$failures failure(s)"
    exit 1
fi
echo "$count example rigs pass"
