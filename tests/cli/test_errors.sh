#!/usr/bin/env bash
# Bad command lines that need links, and the happy path next to them: exit
# code, message, an existing output never damaged, the input never modified,
# no temporary file left behind. Every other bad input is a case of the
# corpus tests/bad/ (test_bad.sh).
# usage: bash test_errors.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
DATA=$SRC/tests/data/rig

# expect CODE FRAGMENT ARGS...: runs ffd ARGS, checks the exit code and that
# stderr holds FRAGMENT (and starts with "ffd: ").
expect() {
    local code=$1 fragment=$2
    shift 2
    "$FFD" "$@" >"$T/stdout" 2>"$T/stderr"
    local rc=$?
    if [ "$rc" -ne "$code" ]; then
        fail "ffd $* exited $rc, expected $code; stderr: $(cat "$T/stderr")"
    elif ! grep -qF -- "$fragment" "$T/stderr"; then
        fail "ffd $*: stderr lacks '$fragment': $(cat "$T/stderr")"
    elif ! head -n 1 "$T/stderr" | grep -q '^ffd: '; then
        fail "ffd $*: stderr does not start with 'ffd: ': $(cat "$T/stderr")"
    fi
}

cp "$DATA/cube.obj" "$T/in.obj"
IN_SUM=$(cksum <"$T/in.obj")
printf 'sentinel: must survive every failed run\n' >"$T/out.obj"
OUT_SUM=$(cksum <"$T/out.obj")

rig() { # rig NAME JSON: writes $T/NAME
    printf '%s\n' "$2" >"$T/$1"
}
rig good.json '{"resolution": [3, 3, 3], "moves": [{"index": [2, 2, 2], "delta": [0.1, 0, 0]}]}'

# Single bad inputs (meshes, rigs, .prm files, usage errors) live in the
# corpus tests/bad/, run by test_bad.sh. Here: what needs links or several runs.

# ---- the output is the input, through links ----
ln "$T/in.obj" "$T/hardlink.obj"
expect 2 "the output is the input file" deform "$T/in.obj" -o "$T/hardlink.obj" --rig "$T/good.json"
ln -s in.obj "$T/symlink.obj"
expect 2 "the output is the input file" deform "$T/symlink.obj" -o "$T/in.obj" --rig "$T/good.json"
expect 2 "the output is the input file" convert "$T/in.obj" "$T/./in.obj"

# ---- nothing was damaged ----
[ "$(cksum <"$T/in.obj")" = "$IN_SUM" ] || fail "the input was modified"
[ "$(cksum <"$T/out.obj")" = "$OUT_SUM" ] || fail "an existing output was damaged by a failed run"
leftovers=$(find "$T" -name '*.tmp*')
[ -z "$leftovers" ] || fail "temporary files left behind: $leftovers"

# The happy path still works, and --in-place is the only way to overwrite the input.
"$FFD" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/good.json" 2>/dev/null || fail "good rig failed"
cmp -s "$T/out.obj" "$T/in.obj" && fail "good rig did not change the mesh"
cp "$T/in.obj" "$T/inplace.obj"
"$FFD" deform "$T/inplace.obj" --in-place --rig "$T/good.json" 2>/dev/null || fail "--in-place failed"
cmp -s "$T/inplace.obj" "$T/out.obj" || fail "--in-place result differs from -o result"
expect 2 "--in-place: $T/out.obj is not the input file" deform "$T/in.obj" --in-place -o "$T/out.obj" --rig "$T/good.json"

# Errors about a mesh name the mesh (and the rig) and say what is wrong with
# it: a valid mesh 2e300 across, a valid cube 2e-300 across (run from $T so
# that the names in the message are the short ones given).
B=$SRC/tests/bad
(
    cd "$T" || exit 1
    cp "$B/proxy-huge-mesh/huge.obj" "$B/rig-auto-box-tiny-mesh/tiny.obj" \
        "$B/rig-auto-box-tiny-mesh/auto.json" "$B/tspline-huge-mesh/ts.json" \
        "$B/pbffd-auto-tiny-mesh/pb.json" .
    failures=0
    expect 1 "ffd: huge.obj: the default --resolution 6,6,6: tspline: the bounding box (extent 2e+300 x 2e+300 x 2e+300) is too large for a T-spline lattice (extents up to 1e+100)" \
        tspline proxy huge.obj -o p.obj
    expect 1 "ffd: huge.obj: --resolution 5,5,5: tspline: the bounding box (extent 2e+300" \
        tspline proxy huge.obj -o p.obj --resolution 5
    expect 1 "ffd: huge.obj: ts.json: tspline: the bounding box (extent 2e+300" \
        deform huge.obj -o o.obj --rig ts.json
    expect 1 "ffd: tiny.obj: auto.json: box \"auto\": the bounding box is degenerate (extent 2e-300 x 2e-300 x 2e-300): too small for a lattice box (extents from 1e-100)" \
        deform tiny.obj -o o.obj --rig auto.json
    expect 1 "ffd: huge.obj: auto.json: box \"auto\": the bounding box (extent 2e+300 x 2e+300 x 2e+300) is too large for a lattice box (extents up to 1e+100)" \
        deform huge.obj -o o.obj --rig auto.json
    expect 1 "ffd: tiny.obj: pb.json: controls (automatic placement): placement: the mesh is too small (bounding-box diagonal 3.4641e-300" \
        deform tiny.obj -o o.obj --rig pb.json
    expect 1 "ffd: tiny.obj: placement: the mesh is too small (bounding-box diagonal 3.4641e-300" \
        pbffd place tiny.obj -o c.json
    [ ! -e p.obj ] && [ ! -e o.obj ] && [ ! -e c.json ] || fail "a refused run wrote an output"
    exit "$failures"
) || failures=$((failures + $?))

if [ "$failures" -ne 0 ]; then
    echo "$failures failure(s)"
    exit 1
fi
echo "all error cases pass"
