#!/usr/bin/env bash
# Cage deformation from the command line (docs/cage.md): every example rig in
# examples/cage/ runs on the bunny with a JSON report, --lattice-out (the
# cage's vertices and edges) and --proxy-out (the deformed cage, its 80
# triangles); the rig's cage file is an input the outputs may not overwrite;
# "deformed" (a moved copy of the cage) gives the same result as the moves;
# an STL cage (no shared vertices) is welded.
# usage: bash test_cage.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
case $FFD in /*) ;; *) FFD=$(cd "$(dirname "$FFD")" && pwd)/$(basename "$FFD") ;; esac
EX=$(cd "$SRC/examples/cage" && pwd)

for name in bunny-mvc bunny-harmonic bunny-drag bunny-auto; do
    if ! "$FFD" deform "$EX/bunny.obj" -o "$T/$name.obj" --rig "$EX/$name.json" --report \
        --lattice-out "$T/$name.cage-lines.obj" --proxy-out "$T/$name.cage.obj" \
        >"$T/$name.report" 2>"$T/$name.err"; then
        fail "$name: ffd deform failed: $(cat "$T/$name.err")"
        continue
    fi
    grep -q -e 'Sanitizer' -e 'runtime error' "$T/$name.err" && fail "$name: $(cat "$T/$name.err")"
    grep -qF '"method": "cage"' "$T/$name.report" || fail "$name: report: $(cat "$T/$name.report")"
    grep -qF '"outside": 0' "$T/$name.report" || fail "$name: vertices outside the cage"
    nv=42 nf=80
    [ "$name" = bunny-auto ] && nv=8 nf=12
    [ "$(grep -c '^v ' "$T/$name.cage.obj")" -eq "$nv" ] || fail "$name: --proxy-out: not $nv vertices"
    [ "$(grep -c '^f ' "$T/$name.cage.obj")" -eq "$nf" ] || fail "$name: --proxy-out: not $nf faces"
    [ "$(grep -c '^l ' "$T/$name.cage-lines.obj")" -eq $((3 * nf / 2)) ] ||
        fail "$name: --lattice-out: not $((3 * nf / 2)) edges"
    cmp -s "$T/$name.obj" "$EX/bunny.obj" && fail "$name: nothing moved"
done
grep -qF '"coordinates": "harmonic"' "$T/bunny-harmonic.report" || fail "harmonic: no coordinates in the report"
sed -n -e 's/.*"max_residual": \([-0-9.eE+]*\).*/\1/p' "$T/bunny-drag.report" |
    awk '{ exit !($1 < 1e-9) }' || fail "bunny-drag: residual $(cat "$T/bunny-drag.report")"

# the cage file is an input: no output may overwrite it
cp "$EX/bunny-cage.obj" "$EX/bunny-mvc.json" "$T/"
bad 2 deform "$EX/bunny.obj" -o "$T/bunny-cage.obj" --rig "$T/bunny-mvc.json"
has stderr "refusing to overwrite an input"
cmp -s "$T/bunny-cage.obj" "$EX/bunny-cage.obj" || fail "the cage file was overwritten"

# "deformed": the cage moved by the rig's own moves, written by --proxy-out
cat >"$T/deformed.json" <<JSON
{"version": 1, "deformer": "cage", "cage": "bunny-cage.obj", "deformed": "bunny-mvc.cage.obj"}
JSON
ok deform "$EX/bunny.obj" -o "$T/deformed.obj" --rig "$T/deformed.json"
cmp -s "$T/deformed.obj" "$T/bunny-mvc.obj" || fail "deformed: not the moves' result"

# an STL cage: the corners of its facets welded into the cage's vertices
ok convert "$EX/bunny-cage.obj" "$T/cage.stl"
sed -e "s/bunny-cage.obj/cage.stl/" "$EX/bunny-mvc.json" >"$T/stl.json"
ok deform "$EX/bunny.obj" -o "$T/stl.obj" --rig "$T/stl.json" --report
has stdout '"controls": 42'

if [ "$failures" -ne 0 ]; then
    echo "$failures failure(s)"
    exit 1
fi
echo "cage example rigs, reports, cage outputs, deformed cages and STL cages pass"
