#!/usr/bin/env bash
# GFFD from the command line: every example rig in examples/gffd/ runs on its
# mesh (OBJ and OFF outputs, a JSON report, the skeleton with --lattice-out);
# resampling adds vertices and the result reads back; skeleton files resolve
# next to the rig; bad rigs give exit 1, a message naming the rig and the JSON
# path, an untouched input and no output.
# usage: bash test_gffd.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
# absolute paths: some runs below change directory
case $FFD in /*) ;; *) FFD=$(cd "$(dirname "$FFD")" && pwd)/$(basename "$FFD") ;; esac
EX=$(cd "$SRC/examples/gffd" && pwd)

# field FILE KEY: the number after "KEY": in FILE (first occurrence)
field() {
    sed -n -e "s/.*\"$2\": \([-0-9.eE+]*\).*/\1/p" "$1" | head -n 1
}
vertices() { # vertices MESH: the vertex count from ffd info --json
    "$FFD" info --json "$1" | sed -n -e 's/.*"vertices": \([0-9]*\),.*/\1/p'
}
positions() { # positions MESH: its v lines (through an OBJ copy), one per vertex, in order
    "$FFD" convert "$1" "$T/positions.obj" >/dev/null 2>&1 || { echo "cannot convert $1"; return; }
    grep '^v ' "$T/positions.obj"
}

# ---- the examples ----
run_example() { # run_example RIG MESH OUT_EXTENSION
    local name=$1 mesh=$EX/$2 out=$T/$1.$3
    local sum
    sum=$(cksum <"$mesh")
    if ! "$FFD" deform "$mesh" -o "$out" --rig "$EX/$name.json" --report \
        --lattice-out "$T/$name.skeleton.obj" >"$T/$name.report" 2>"$T/$name.err"; then
        fail "$name: ffd deform failed: $(cat "$T/$name.err")"
        return
    fi
    [ -s "$out" ] || fail "$name: no output $out"
    grep -q -e 'Sanitizer' -e 'runtime error' "$T/$name.err" && fail "$name: $(cat "$T/$name.err")"
    grep -qF "wrote $out (" "$T/$name.err" || fail "$name: no 'wrote' line: $(cat "$T/$name.err")"
    for key in '"influenced": ' '"unit": ' '"tracked": ' '"converged": ' '"not_converged": ' \
        '"failed": [' '"max_field_error": ' '"regularised": false'; do
        grep -qF "$key" "$T/$name.report" || fail "$name: report lacks $key: $(cat "$T/$name.report")"
    done
    [ "$(wc -l <"$T/$name.report")" -eq 1 ] || fail "$name: the report is not one JSON line"
    case $(head -c 1 "$T/$name.report") in "{") ;; *) fail "$name: the report is not a JSON object" ;; esac
    local influenced tracked converged not_converged
    influenced=$(field "$T/$name.report" influenced)
    tracked=$(field "$T/$name.report" tracked)
    converged=$(field "$T/$name.report" converged)
    not_converged=$(field "$T/$name.report" not_converged)
    [ "${influenced:-0}" -gt 0 ] || fail "$name: influenced '$influenced'"
    [ "${tracked:-0}" -gt 0 ] || fail "$name: tracked '$tracked'"
    [ $((converged + not_converged)) -eq "$tracked" ] ||
        fail "$name: converged $converged + not_converged $not_converged != tracked $tracked"
    awk -v u="$(field "$T/$name.report" unit)" 'BEGIN { exit !(u > 0) }' || fail "$name: unit not > 0"
    [ "$(cksum <"$mesh")" = "$sum" ] || fail "$name: the input mesh was modified"
    "$FFD" info "$out" >/dev/null 2>&1 || fail "$name: the output does not read back"
    # some of the input's vertices moved (resampling appends vertices after them)
    local n moved
    n=$(vertices "$mesh")
    positions "$mesh" >"$T/$name.before"
    positions "$out" | head -n "$n" >"$T/$name.after"
    [ "$(wc -l <"$T/$name.after")" -eq "$n" ] || fail "$name: the output has fewer vertices"
    moved=$(diff "$T/$name.before" "$T/$name.after" | grep -c '^>')
    [ "$moved" -gt 0 ] || fail "$name: no vertex moved"
    echo "$moved" >"$T/$name.moved"
    # the skeleton: one v line per skeleton vertex, nothing else but comments
    [ -s "$T/$name.skeleton.obj" ] || fail "$name: --lattice-out wrote nothing"
    [ "$(grep -cv -e '^v ' -e '^#' "$T/$name.skeleton.obj")" -eq 0 ] ||
        fail "$name: --lattice-out wrote more than v lines: $(cat "$T/$name.skeleton.obj")"
    [ "$(grep -c '^v ' "$T/$name.skeleton.obj")" -eq "$(field "$T/$name.report" controls)" ] ||
        fail "$name: --lattice-out v lines differ from the report's controls"
}

run_example bend elephant.off off
run_example twist bunny.obj obj
run_example replace cow.off obj
# the trunk's and the head's edits leave most of the elephant and the bunny alone
[ "$(cat "$T/bend.moved")" -lt $(($(vertices "$EX/elephant.off") / 2)) ] || fail "bend: $(cat "$T/bend.moved") vertices moved"
[ "$(cat "$T/twist.moved")" -lt 1839 ] || fail "twist: every vertex moved"

# bend: the trunk (5 vertices), its tip moved by the edit, resampled
[ "$(grep -c '^v ' "$T/bend.skeleton.obj")" -eq 5 ] || fail "bend: skeleton has $(grep -c '^v ' "$T/bend.skeleton.obj") vertices"
grep -qx 'v 0.23000000000000001 0.16 0.089999999999999997' "$T/bend.skeleton.obj" ||
    fail "bend: the trunk's base moved: $(cat "$T/bend.skeleton.obj")"
tail -n 1 "$T/bend.skeleton.obj" | awk '{ exit !($1 == "v" && ($2 - 0.04)^2 < 1e-20 && ($3 - 0.40)^2 < 1e-20 && $4 == 0.12) }' ||
    fail "bend: the trunk's tip is not where the edits put it: $(tail -n 1 "$T/bend.skeleton.obj")"
grep -q '"resample": {"rounds": ' "$T/bend.report" || fail "bend: no resample report: $(cat "$T/bend.report")"
in_v=$(vertices "$EX/elephant.off")
out_v=$(vertices "$T/bend.off")
added=$(field "$T/bend.report" added_vertices)
[ -n "$out_v" ] && [ "$out_v" -gt "$in_v" ] || fail "bend: resampled output has $out_v vertices, input $in_v"
[ "$out_v" = $((in_v + added)) ] || fail "bend: $out_v vertices != $in_v + added $added"
grep -qF "wrote $T/bend.off ($out_v vertices," "$T/bend.err" || fail "bend: 'wrote' line disagrees: $(cat "$T/bend.err")"
"$FFD" info --json "$T/bend.off" | grep -q '"boundary_edges": 0, "nonmanifold_edges": 0, "closed": true' ||
    fail "bend: the resampled elephant is no longer closed: $("$FFD" info --json "$T/bend.off")"
# twist: the band where the ears' influence ends is resampled, no edge left long
grep -q '"resample": {"rounds": ' "$T/twist.report" || fail "twist: no resample report: $(cat "$T/twist.report")"
[ "$(field "$T/twist.report" long_edges)" = 0 ] || fail "twist: long edges left: $(cat "$T/twist.report")"
[ "$(vertices "$T/twist.obj")" = $((1839 + $(field "$T/twist.report" added_vertices))) ] ||
    fail "twist: vertex count is not 1839 + added"
[ "$(field "$T/twist.report" not_converged)" = 0 ] || fail "twist: vertices did not converge: $(cat "$T/twist.report")"
# replace keeps the topology: same counts, same non-vertex lines
[ "$(grep -c '^v ' "$T/twist.skeleton.obj")" -eq 11 ] || fail "twist: skeleton has $(grep -c '^v ' "$T/twist.skeleton.obj") vertices"
[ "$(vertices "$T/replace.obj")" = "$(vertices "$EX/cow.off")" ] || fail "replace: vertex count changed"
[ "$(grep -c '^v ' "$T/replace.skeleton.obj")" -eq 4 ] || fail "replace: the report's skeleton is not the replacement"
grep -qx 'v 0.10000000000000001 0 0' "$T/replace.skeleton.obj" || fail "replace: not the arched spine: $(cat "$T/replace.skeleton.obj")"

# ---- a rotation of the whole skeleton reaches every vertex, whatever the skeleton ----
# One point, two points, a straight polyline (whose vertices cannot show a
# turn about themselves) and a patch, turned 0.7 rad about an off-centre
# point and about their own centroid; the radius covers the cow, deeper than
# the influence band, so every vertex turns exactly (1e-12).
rotated_ok() { # rotated_ok NAME SKELETON EDITS CX CY CZ: every vertex of the cow turned 0.7 rad about z through C
    printf '{"deformer": "gffd", "tracking": "gradient", "skeleton": [%s], "edits": [%s]}' "$2" "$3" >"$T/$1.json"
    if ! "$FFD" deform "$EX/cow.off" -o "$T/$1.obj" --rig "$T/$1.json" >"$T/stdout" 2>"$T/stderr"; then
        fail "$1: $(cat "$T/stderr")"
        return
    fi
    positions "$EX/cow.off" >"$T/rot.before"
    positions "$T/$1.obj" >"$T/rot.after"
    paste -d ' ' "$T/rot.before" "$T/rot.after" | awk -v cx="$4" -v cy="$5" -v cz="$6" '
        function abs(x) { return x < 0 ? -x : x }
        { c = cos(0.7); s = sin(0.7); dx = $2 - cx; dy = $3 - cy
          wx = cx + c * dx - s * dy; wy = cy + s * dx + c * dy; wz = $4
          e = abs($6 - wx) + abs($7 - wy) + abs($8 - wz); if (e > worst) worst = e; n++ }
        END { if (n != 2904 || !(worst <= 1e-12)) { print n " vertices, " worst " off the rotation"; exit 1 } }' \
        >"$T/rot.err" || fail "$1: $(cat "$T/rot.err")"
}
ROT='"rotate": {"axis": [0, 0, 1], "angle": 0.7}'
POINT='{"type": "point", "position": [0.1, 0.05, 0], "radius": 3}'
rotated_ok point-off "$POINT" "{\"primitive\": 0, $ROT, \"center\": [1.5, -1, 0.4]}" 1.5 -1 0.4
rotated_ok point-self "$POINT" "{\"primitive\": 0, $ROT}" 0.1 0.05 0
TWO='{"type": "point", "position": [-0.3, 0, 0], "radius": 3}, {"type": "point", "position": [0.3, 0.1, 0], "radius": 3}'
rotated_ok points-off "$TWO" "{\"primitive\": \"all\", $ROT, \"center\": [1.5, -1, 0.4]}" 1.5 -1 0.4
rotated_ok points-self "$TWO" "{\"primitive\": \"all\", $ROT}" 0 0.05 0
LINE3='{"type": "polyline", "vertices": [[-0.4, 0, 0], [0, 0, 0], [0.4, 0, 0]], "radius": 3}'
rotated_ok line-off "$LINE3" "{\"primitive\": 0, $ROT, \"center\": [1.5, -1, 0.4]}" 1.5 -1 0.4
rotated_ok line-self "$LINE3" "{\"primitive\": 0, $ROT}" 0 0 0
PATCH='{"type": "patch", "vertices": [[-0.4, -0.2, 0], [0.4, -0.2, 0], [0.4, 0.2, 0], [-0.4, 0.2, 0]], "faces": [[0, 1, 2, 3]], "radius": 3}'
rotated_ok patch-off "$PATCH" "{\"primitive\": 0, $ROT, \"center\": [1.5, -1, 0.4]}" 1.5 -1 0.4

# ---- a point moved beside a still one: every tracked vertex converges ----
# (before: 2,817 of 7,475 tracked vertices, most of them added by resampling
# near the edge of the region, were left unconverged)
printf '{"deformer": "gffd", "tracking": "warp", "resample": true, "skeleton": [%s, %s], "edits": [%s]}' \
    '{"type": "point", "position": [0.3, 0.1, 0], "radius": 0.3}' \
    '{"type": "point", "position": [-0.4, 0, 0], "radius": 0.2}' \
    '{"primitive": 0, "translate": [0.15, 0.1, 0]}' >"$T/moved-point.json"
ok deform "$EX/cow.off" -o "$T/moved-point.off" --rig "$T/moved-point.json" --report
has stdout '"not_converged": 0, "failed": []'
has stdout '"long_edges": 0, "capped": false'

# ---- skeleton files resolve next to the rig, from any working directory ----
mkdir -p "$T/rigs" "$T/elsewhere"
cp "$EX/bend.json" "$EX/trunk.obj" "$T/rigs/"
printf 'v 9 9 9\nv 9 9 10\n' >"$T/elsewhere/trunk.obj" # a decoy in the working directory
(cd "$T/elsewhere" && "$FFD" deform "$EX/elephant.off" -o ../rel.off --rig ../rigs/bend.json) \
    >"$T/stdout" 2>"$T/stderr" || fail "relative rig path failed: $(cat "$T/stderr")"
cmp -s "$T/rel.off" "$T/bend.off" || fail "the rig read from another directory gave another result"
rm "$T/rigs/trunk.obj"
(cd "$T/elsewhere" && "$FFD" deform "$EX/elephant.off" -o ../rel2.off --rig ../rigs/bend.json) \
    >"$T/stdout" 2>"$T/stderr"
rc=$?
[ "$rc" -eq 1 ] || fail "a missing skeleton file exited $rc"
has stderr "../rigs/bend.json: skeleton[0].file: ../rigs/trunk.obj"
[ -e "$T/rel2.off" ] && fail "a failed deform wrote its output"

# ---- an unedited rig changes nothing ----
printf '{"deformer": "gffd", "skeleton": [{"type": "polyline", "file": "%s", "radius": 0.12}], "tracking": "warp"}' \
    "$EX/trunk.obj" >"$T/still.json"
ok deform "$EX/elephant.off" -o "$T/still.off" --rig "$T/still.json" --report
cmp -s "$EX/elephant.off" "$T/still.off" || fail "an unedited skeleton changed the elephant"
has stdout '"tracked": 0, "converged": 0, "not_converged": 0'

# ---- bad rigs: exit 1, the rig and the JSON path named, input untouched, no output ----
cp "$EX/cow.off" "$T/in.off"
bad_rig() { # bad_rig NAME JSON FRAGMENT: FRAGMENT follows "$T/NAME.json: " in the message
    local rig=$T/$1.json
    printf '%s' "$2" >"$rig"
    rm -f "$T/out.off" "$T/skel.obj"
    bad 1 deform "$T/in.off" -o "$T/out.off" --rig "$rig" --lattice-out "$T/skel.obj"
    has stderr "$rig: $3"
    grep -q -e 'Sanitizer' -e 'runtime error' "$T/stderr" && fail "$1: $(cat "$T/stderr")"
    [ -e "$T/out.off" ] && fail "$1: a failed deform wrote its output"
    [ -e "$T/skel.obj" ] && fail "$1: a failed deform wrote its skeleton"
    cmp -s "$T/in.off" "$EX/cow.off" || fail "$1: the input mesh changed"
    # --in-place too leaves the input as it was
    bad 1 deform "$T/in.off" --in-place --rig "$rig"
    has stderr "$rig: $3"
    cmp -s "$T/in.off" "$EX/cow.off" || fail "$1: --in-place changed the input on failure"
}
LINE='{"type": "polyline", "vertices": [[-0.4,0,0],[0,0,0],[0.3,0.1,0]], "radius": 0.5}'
bad_rig radius '{"deformer": "gffd", "skeleton": [{"type": "point", "position": [0,0,0], "radius": 0}]}' \
    'skeleton[0].radius: 0: expected a number > 0'
bad_rig noradius '{"deformer": "gffd", "skeleton": [{"type": "point", "position": [0,0,0]}]}' \
    'skeleton[0].radius: expected the influence radius r_s > 0 (missing)'
bad_rig segment '{"deformer": "gffd", "skeleton": [{"type": "polyline", "vertices": [[0,0,0],[0.2,0,0],[0.2,0,0]], "radius": 0.5}]}' \
    'skeleton: skeleton[0]: zero-length segment between vertices 1 and 2'
bad_rig vanish '{"deformer": "gffd", "skeleton": ['"$LINE"'], "edits": [{"primitive": 0, "translate": [0,0.01,0]}, {"primitive": 0, "vertex": 2, "move": [-0.3,-0.1,0]}]}' \
    'edits[1]: skeleton[0]: zero-length segment between vertices 1 and 2'
bad_rig open '{"deformer": "gffd", "skeleton": [{"type": "polyhedron", "vertices": [[0,0,0],[0.3,0,0],[0,0.3,0]], "faces": [[0,1,2]], "radius": 0.5}]}' \
    'skeleton: skeleton[0]: polyhedron is not closed: edge (0, 1) is used by 1 face, expected 2'
bad_rig structure '{"deformer": "gffd", "skeleton": ['"$LINE"'], "edits": [{"primitive": 0, "vertices": [[0,0,0],[1,0,0]]}]}' \
    'edits[0].vertices: 2 vertices, but skeleton[0] has 3: an edit keeps the skeleton'"'"'s structure; to change it, use "replace" with "correspondences"'
bad_rig warp '{"deformer": "gffd", "skeleton": ['"$LINE"'], "replace": ['"$LINE"'], "tracking": "warp"}' \
    'replace: warp tracking after a skeleton replacement needs "correspondences"'
bad_rig moves '{"deformer": "gffd", "skeleton": ['"$LINE"'], "moves": []}' \
    'moves: not a key of "deformer": "gffd" rigs'
bad_rig lattice '{"resolution": [3,3,3], "skeleton": ['"$LINE"']}' \
    'skeleton: only for "deformer": "gffd" rigs'
bad_rig nonfinite '{"deformer": "gffd", "skeleton": ['"$LINE"'], "edits": [{"primitive": 0, "translate": [0,1e999,0]}]}' \
    'edits[0].translate[1]: expected a finite number, got inf'
bad_rig ratio '{"deformer": "gffd", "skeleton": ['"$LINE"'], "resample": {"ratio": 1}}' \
    'resample.ratio: expected a number > 1'
bad_rig unit '{"deformer": "gffd", "skeleton": ['"$LINE"'], "unit": 1e-6}' \
    'skeleton: unit 1e-06 is too small for this skeleton'
bad_rig nofile '{"deformer": "gffd", "skeleton": [{"type": "polyline", "file": "nowhere.obj", "radius": 0.5}]}' \
    "skeleton[0].file: $T/nowhere.obj"
bad_rig stl '{"deformer": "gffd", "skeleton": [{"type": "patch", "file": "hinge.stl", "radius": 0.5}]}' \
    "skeleton[0].file: $T/hinge.stl: STL has no shared vertices"
printf 'v 0 0 0\nv 1 0 0\nl 1 2\nl 2 1\n' >"$T/two-l.obj"
bad_rig twol '{"deformer": "gffd", "skeleton": [{"type": "polyline", "file": "two-l.obj", "radius": 0.5}]}' \
    "skeleton[0].file: $T/two-l.obj:4: a second 'l' statement"
printf 'v 0 0 0\nv 1 x 0\n' >"$T/bad-v.obj"
bad_rig badv '{"deformer": "gffd", "skeleton": [{"type": "polyline", "file": "bad-v.obj", "radius": 0.5}]}' \
    "skeleton[0].file: $T/bad-v.obj:2: expected 3 numbers after 'v'"

# a failing bend (the tip meets vertex 3) on the elephant leaves it alone, with or without resampling
cp "$EX/elephant.off" "$T/el.off"
sed -e 's/"vertex": 4, "move": \[-0.14, -0.06, 0.0\]/"vertex": 4, "move": [-0.09, -0.09, 0.04]/' \
    "$EX/bend.json" >"$T/rigs/broken.json"
cp "$EX/trunk.obj" "$T/rigs/"
grep -q '"move": \[-0.09, -0.09, 0.04\]' "$T/rigs/broken.json" || fail "could not derive broken.json from bend.json"
bad 1 deform "$T/el.off" -o "$T/el-out.off" --rig "$T/rigs/broken.json" --report
has stderr "$T/rigs/broken.json: edits[2]: skeleton[0]: zero-length segment between vertices 3 and 4"
[ -s "$T/stdout" ] && fail "a failed deform printed a report: $(cat "$T/stdout")"
[ -e "$T/el-out.off" ] && fail "a failed bend wrote its output"
cmp -s "$T/el.off" "$EX/elephant.off" || fail "a failed bend changed the elephant"

if [ "$failures" -ne 0 ]; then
    echo "$failures failure(s)"
    exit 1
fi
echo "GFFD example rigs, reports, skeleton output and errors pass"
