#!/usr/bin/env bash
# Every bad input the `ffd` command can meet: exit code, message (file name and
# what was wrong), an existing output never damaged, the input never modified,
# no temporary file left behind.
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

# ---- meshes ----
expect 1 "nope.obj" deform "$T/nope.obj" -o "$T/out.obj" --rig "$T/good.json"
mkdir "$T/dir.obj"
expect 1 "dir.obj" deform "$T/dir.obj" -o "$T/out.obj" --rig "$T/good.json"
expect 1 "directory" deform "$T/dir.obj" -o "$T/out.obj" --rig "$T/good.json"
: >"$T/empty.off"
expect 1 "empty.off" deform "$T/empty.off" -o "$T/out.obj" --rig "$T/good.json"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n' >"$T/badface.obj"
expect 1 "badface.obj" deform "$T/badface.obj" -o "$T/out.obj" --rig "$T/good.json"
expect 1 "nope.obj" info "$T/nope.obj"
expect 1 "dir.obj" info "$T/dir.obj" --json
expect 1 "nope.obj" convert "$T/nope.obj" "$T/out.obj"

# ---- rigs ----
expect 1 "missing.json" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/missing.json"
mkdir "$T/rigdir.json"
expect 1 "rigdir.json: is a directory" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/rigdir.json"
: >"$T/empty.json"
expect 1 "empty.json: empty file" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/empty.json"
rig syntax.json '{
  "resolution": [3, 3, 3],
  "margin": ,
}'
expect 1 "syntax.json:3:13: invalid JSON" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/syntax.json"
rig unknown.json '{"resolution": [3, 3, 3], "colour": "red"}'
expect 1 "unknown.json: colour: unknown key" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/unknown.json"
rig unknown2.json '{"moves": [{"index": [0, 0, 0], "delta": [0, 0, 0], "speed": 2}]}'
expect 1 "unknown2.json: moves[0].speed: unknown key" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/unknown2.json"
rig type.json '{"moves": [{"index": [0, 0, 0], "delta": [0, 0, 0]}, {"index": [1, 1, 1], "delta": "up"}]}'
expect 1 "type.json: moves[1].delta: expected an array of 3 finite numbers" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/type.json"
rig type2.json '{"basis": 3}'
expect 1 "type2.json: basis: expected" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/type2.json"
rig type3.json '{"resolution": "big"}'
expect 1 "type3.json: resolution: expected an array of 3 non-negative integers" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/type3.json"
rig top.json '[1, 2, 3]'
expect 1 "top.json: expected a JSON object" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/top.json"
rig nonfinite.json '{"constraints": [{"vertex": 1, "target": [1e999, 0, 0]}]}'
expect 1 "nonfinite.json: constraints[0].target[0]: expected a finite number" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/nonfinite.json"
rig range.json '{"constraints": [{"vertex": 1, "target": [0, 0, 0]}, {"vertex": 9001, "target": [0, 0, 0]}]}'
expect 1 "range.json: constraints[1].vertex: 9001 out of range (mesh has 8 vertices)" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/range.json"
rig lowres.json '{"resolution": [5, 1, 5]}'
expect 1 "lowres.json: resolution[1]: 1 is below the minimum 2" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/lowres.json"
rig highres.json '{"resolution": [5, 5, 4096]}'
expect 1 "highres.json: resolution[2]: 4096 is above the maximum 1024" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/highres.json"
rig zero.json '{"box": {"origin": [0, 0, 0], "axes": [[1, 0, 0], [0, 1, 0], [1, 1, 0]]}}'
expect 1 "zero.json: box: " deform "$T/in.obj" -o "$T/out.obj" --rig "$T/zero.json"
rig moverange.json '{"resolution": [3, 3, 3], "moves": [{"index": [0, 3, 0], "delta": [1, 0, 0]}]}'
expect 1 "moverange.json: moves[0].index: [0, 3, 0] out of range" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/moverange.json"
rig outside.json '{"constraints": [{"point": [5, 5, 5], "target": [0, 0, 0]}]}'
expect 1 "outside.json: constraints[0].point: [5, 5, 5] is outside the lattice box" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/outside.json"
rig both.json '{"constraints": [{"vertex": 1, "point": [0, 0, 0], "target": [0, 0, 0]}]}'
expect 1 "both.json: constraints[0]: expected either" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/both.json"
deep=$(printf '%0.s[' $(seq 100))$(printf '%0.s]' $(seq 100))
rig deep.json "{\"moves\": $deep}"
expect 1 "deep.json:1:" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/deep.json"

# ---- the command line ----
expect 2 "the output is the input file" deform "$T/in.obj" -o "$T/in.obj" --rig "$T/good.json"
ln "$T/in.obj" "$T/hardlink.obj"
expect 2 "the output is the input file" deform "$T/in.obj" -o "$T/hardlink.obj" --rig "$T/good.json"
ln -s in.obj "$T/symlink.obj"
expect 2 "the output is the input file" deform "$T/symlink.obj" -o "$T/in.obj" --rig "$T/good.json"
expect 2 "the output is the input file" convert "$T/in.obj" "$T/./in.obj"
expect 2 "unknown option '--frobnicate'" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/good.json" --frobnicate
expect 2 "'-o' given twice" deform "$T/in.obj" -o "$T/a.obj" -o "$T/b.obj" --rig "$T/good.json"
expect 2 "unknown option '-x'" info "$T/in.obj" -x
expect 2 "unknown option '--binary-le'" convert "$T/in.obj" "$T/x.ply" --binary-le
expect 2 "missing --rig" deform "$T/in.obj" -o "$T/out.obj"
expect 2 "missing -o OUT" deform "$T/in.obj" --rig "$T/good.json"
expect 2 "missing input mesh" deform -o "$T/out.obj" --rig "$T/good.json"
expect 2 "'--rig' needs a value" deform "$T/in.obj" -o "$T/out.obj" --rig
expect 2 "'-o' needs a value" deform "$T/in.obj" --rig "$T/good.json" -o
expect 2 "conflicts" deform "$T/in.obj" -o "$T/out.ply" --rig "$T/good.json" --ascii --binary
expect 2 "unknown output format" deform "$T/in.obj" -o "$T/out.xyz" --rig "$T/good.json"
expect 2 "unexpected argument" deform "$T/in.obj" "$T/other.obj" -o "$T/out.obj" --rig "$T/good.json"
expect 2 "expected IN and OUT" convert "$T/in.obj"
expect 2 "missing MESH" info
expect 2 "unknown command 'squash'" squash "$T/in.obj"
expect 2 "missing command" 
expect 2 "unknown option '--frobnicate'" --frobnicate

# ---- nothing was damaged ----
[ "$(cksum <"$T/in.obj")" = "$IN_SUM" ] || fail "the input was modified"
[ "$(cksum <"$T/out.obj")" = "$OUT_SUM" ] || fail "an existing output was damaged by a failed run"
[ ! -e "$T/out.xyz" ] && [ ! -e "$T/out.ply" ] || fail "a failed run created an output file"
leftovers=$(find "$T" -name '*.tmp*')
[ -z "$leftovers" ] || fail "temporary files left behind: $leftovers"

# A failed write (the output's directory does not exist) is an input error too.
expect 1 "nodir" deform "$T/in.obj" -o "$T/nodir/out.obj" --rig "$T/good.json"

# The happy path still works, and --in-place is the only way to overwrite the input.
"$FFD" deform "$T/in.obj" -o "$T/out.obj" --rig "$T/good.json" 2>/dev/null || fail "good rig failed"
cmp -s "$T/out.obj" "$T/in.obj" && fail "good rig did not change the mesh"
cp "$T/in.obj" "$T/inplace.obj"
"$FFD" deform "$T/inplace.obj" --in-place --rig "$T/good.json" 2>/dev/null || fail "--in-place failed"
cmp -s "$T/inplace.obj" "$T/out.obj" || fail "--in-place result differs from -o result"
expect 2 "--in-place: $T/out.obj is not the input file" deform "$T/in.obj" --in-place -o "$T/out.obj" --rig "$T/good.json"

if [ "$failures" -ne 0 ]; then
    echo "$failures failure(s)"
    exit 1
fi
echo "all error cases pass"
