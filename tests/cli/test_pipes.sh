#!/usr/bin/env bash
# '-' for standard input and output (docs/cli.md "Pipes"): a deform or a
# convert through pipes gives the bytes the same command gives with files; a
# rig can come from standard input; the refusals (no --format for '-', two
# inputs on standard input, --report with -o -, binary to a terminal); a
# failing run with -o - writes nothing on standard output; --progress and
# --quiet.
# usage: bash test_pipes.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$1" "$2"
DATA=$SRC/tests/data
RIG=$DATA/rig/pull.json
PLY=$DATA/mesh/cube_ble.ply # binary little-endian PLY
OBJ=$DATA/rig/cube.obj

# same_bytes NAME A B
same_bytes() { cmp -s "$2" "$3" || fail "$1: $2 and $3 differ"; }

# deform: files versus pipes, byte for byte (binary PLY, OBJ)
for M in "$PLY" "$OBJ"; do
    ext=${M##*.}
    ok deform "$M" -o "$T/file.$ext" --rig "$RIG"
    "$FFD" deform - -o - --rig "$RIG" --format "$ext" <"$M" >"$T/pipe.$ext" 2>"$T/stderr" ||
        fail "deform - -o - ($ext) exited $?: $(cat "$T/stderr")"
    same_bytes "deform $ext via stdin/stdout" "$T/file.$ext" "$T/pipe.$ext"
    has stderr "wrote <stdout>"
    # -o - without --format: the format of IN's extension
    "$FFD" deform "$M" -o - --rig "$RIG" >"$T/pipe2.$ext" 2>"$T/stderr" || fail "deform IN -o - ($ext)"
    same_bytes "deform $ext to stdout" "$T/file.$ext" "$T/pipe2.$ext"
    # the rig from standard input
    "$FFD" deform "$M" -o "$T/rigpipe.$ext" --rig - <"$RIG" 2>"$T/stderr" || fail "--rig - ($ext)"
    same_bytes "deform $ext with --rig -" "$T/file.$ext" "$T/rigpipe.$ext"
done
# the input mesh is not changed by a pipe (no --in-place semantics for '-')
grep -q "^ply" "$T/pipe.ply" || fail "the piped PLY has no header"

# convert through pipes: same bytes as with files
ok convert "$PLY" "$T/conv.obj"
"$FFD" convert - -o - --format ply <"$PLY" >"$T/same.ply" 2>/dev/null || fail "convert - -o -"
same_bytes "convert ply to ply via pipes (untouched round trip)" "$PLY" "$T/same.ply"
"$FFD" convert "$PLY" - --format obj >"$T/conv2.obj" 2>/dev/null || fail "convert IN - --format obj"
same_bytes "convert ply to obj on stdout" "$T/conv.obj" "$T/conv2.obj"
"$FFD" convert - "$T/conv3.obj" --format ply <"$PLY" 2>/dev/null || fail "convert - OUT --format ply"
same_bytes "convert from stdin" "$T/conv.obj" "$T/conv3.obj"
# info reads standard input too
"$FFD" info - --format ply <"$PLY" >"$T/stdout" 2>"$T/stderr" || fail "info -"
has stdout "<stdin> (ply)"

# the methods' commands read their mesh (and tspline its rig) from standard input too
EL=$SRC/examples/pbffd/elephant.off
ok pbffd place "$EL" -o "$T/place1.json"
"$FFD" pbffd place - -o "$T/place2.json" --format off <"$EL" 2>/dev/null || fail "pbffd place -"
same_bytes "pbffd place from stdin" "$T/place1.json" "$T/place2.json"
printf '{"deformer": "tspline", "resolution": [5, 5, 5]}\n' >"$T/ts.json"
ok tspline proxy "$OBJ" -o "$T/proxy1.obj" --rig "$T/ts.json"
"$FFD" tspline proxy - -o "$T/proxy2.obj" --rig "$T/ts.json" --format obj <"$OBJ" 2>/dev/null || fail "tspline proxy -"
same_bytes "tspline proxy from stdin" "$T/proxy1.obj" "$T/proxy2.obj"
"$FFD" tspline proxy "$OBJ" -o "$T/proxy3.obj" --rig - <"$T/ts.json" 2>/dev/null || fail "tspline proxy --rig -"
same_bytes "tspline proxy, rig from stdin" "$T/proxy1.obj" "$T/proxy3.obj"

# refusals: exit 2, a message, nothing on stdout
refused() { # refused FRAGMENT ARGS... (stdin: the PLY)
    local fragment=$1
    shift
    "$FFD" "$@" <"$PLY" >"$T/stdout" 2>"$T/stderr"
    local rc=$?
    [ "$rc" -eq 2 ] || fail "ffd $* exited $rc, expected 2: $(cat "$T/stderr")"
    has stderr "$fragment"
    [ -s "$T/stdout" ] && fail "ffd $*: wrote to stdout"
}
refused "needs --format FMT" deform - -o "$T/x.ply" --rig "$RIG"
refused "needs --format FMT" convert - "$T/x.ply"
refused "needs --format FMT" info -
refused "both read standard input" deform - -o - --rig - --format ply
refused "unknown format" deform - -o - --rig "$RIG" --format fbx
refused "--report prints on standard output" deform "$PLY" -o - --rig "$RIG" --report
refused "only the mesh (-o) can go to standard output" deform "$PLY" -o "$T/y.ply" --rig "$RIG" --lattice-out -
refused "--in-place: standard input" deform - --in-place --rig "$RIG" --format ply
refused "this command writes files only" pbffd place "$EL" -o -
refused "this command writes files only" tspline proxy "$OBJ" -o "$T/x.obj" --lattice -
refused "both read standard input" tspline proxy - -o "$T/x.obj" --rig - --format obj
# the formats the messages list are the mesh codec table's, and every
# command's --help lists the same
refused "needs --format FMT" info -
formats=$(sed -n "s/.*needs --format FMT (\(.*\))$/\1/p" "$T/stderr")
[ -n "$formats" ] && case "$formats" in *gltf*glb*) ;; *) false ;; esac ||
    fail "the formats of the --format message lack glTF: $(cat "$T/stderr")"
for cmd in info convert deform "pbffd place" "tspline proxy"; do
    # shellcheck disable=SC2086
    "$FFD" $cmd --help | tr -s ' \n' ' ' | grep -qF "$formats" ||
        fail "ffd $cmd --help does not list the formats ($formats)"
    args=(-o "$T/x.obj")
    case $cmd in info) args=() ;; deform) args+=(--rig "$RIG") ;; esac
    # shellcheck disable=SC2086
    "$FFD" $cmd - "${args[@]}" --format fbx >/dev/null 2>"$T/stderr"
    has stderr "--format 'fbx': unknown format (expected $formats)"
done
[ -e "$T/x.obj" ] && fail "a refused tspline proxy wrote its proxy"
[ -e "$T/x.ply" ] || [ -e "$T/y.ply" ] && fail "a refused command wrote a file"

# a failing deform with -o - leaves stdout empty (a constraint on a vertex the mesh lacks)
printf '{"version": 1, "resolution": [2, 2, 2], "constraints": [{"vertex": 99, "target": [0, 0, 0]}]}\n' >"$T/badrig.json"
"$FFD" deform "$PLY" -o - --rig "$T/badrig.json" >"$T/stdout" 2>"$T/stderr"
rc=$?
[ "$rc" -eq 1 ] || fail "failing deform -o - exited $rc, expected 1: $(cat "$T/stderr")"
[ -s "$T/stdout" ] && fail "failing deform -o - wrote $(wc -c <"$T/stdout") bytes to stdout"
# a malformed piped mesh: an error naming <stdin>, nothing on stdout
printf 'ply\nformat ascii 1.0\nelement vertex 3\nend_header\n1 2\n' | "$FFD" deform - -o - --rig "$RIG" --format ply >"$T/stdout" 2>"$T/stderr"
[ $? -eq 1 ] || fail "malformed piped mesh: expected exit 1"
has stderr "<stdin>"
[ -s "$T/stdout" ] && fail "malformed piped mesh: wrote to stdout"

# binary to a terminal (script(1) gives the command a terminal)
if command -v script >/dev/null 2>&1; then
    script -qec "'$FFD' deform '$PLY' -o - --rig '$RIG'" /dev/null >"$T/tty" 2>&1
    grep -qF "refusing to write binary PLY to a terminal" "$T/tty" ||
        fail "binary PLY to a terminal not refused: $(head -c 300 "$T/tty")"
    script -qec "'$FFD' convert '$DATA/mesh/cube_nodes.glb' -" /dev/null >"$T/tty" 2>&1
    grep -qF "refusing to write binary glTF to a terminal" "$T/tty" ||
        fail "binary glTF to a terminal not refused by name: $(head -c 300 "$T/tty")"
    # a stage shorter than a second draws no progress bar on a terminal
    script -qec "'$FFD' convert '$OBJ' '$T/tty.obj'" /dev/null >"$T/tty" 2>&1
    grep -q "%" "$T/tty" && fail "a progress bar for an 8-vertex mesh: $(tr '\r' '\n' <"$T/tty" | head -5)"
    grep -q "wrote $T/tty.obj" "$T/tty" || fail "convert on a terminal: $(head -c 300 "$T/tty")"
    # text is fine on a terminal
    script -qec "'$FFD' deform '$OBJ' -o - --rig '$RIG' --quiet" /dev/null >"$T/tty" 2>&1
    grep -q "^v " "$T/tty" || fail "OBJ to a terminal: no vertex lines"
else
    echo "note: script(1) not installed: the terminal check is skipped"
fi

# --progress: plain lines on a stderr that is not a terminal; none without it
ok pbffd place "$EL" -o "$T/ctl.json" --progress
grep -qE "^ffd: placement: [0-9]+%$" "$T/stderr" || fail "--progress: no placement lines: $(cat "$T/stderr")"
has stderr "ffd: placement: 100%"
ok pbffd place "$EL" -o "$T/ctl.json"
grep -q "%" "$T/stderr" && fail "progress printed without --progress on a non-terminal"
# --quiet: no notes; errors still printed
ok deform "$OBJ" -o "$T/q.obj" --rig "$RIG" --quiet
[ -s "$T/stderr" ] && fail "--quiet: stderr not empty: $(cat "$T/stderr")"
bad 1 deform "$T/missing.obj" -o "$T/q2.obj" --rig "$RIG" --quiet
has stderr "ffd: "

[ "$failures" -eq 0 ] && echo "cli pipes: all passed"
exit $((failures > 0))
