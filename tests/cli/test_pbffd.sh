#!/usr/bin/env bash
# PB-FFD from the command line: every example rig in examples/pbffd/ runs on
# its mesh (positions change, nothing else); `ffd pbffd place` writes a rig
# that replays to an identical mesh; bad input gets a clear message, a
# non-zero exit and no output.
# usage: bash test_pbffd.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
EX=$SRC/examples/pbffd

topology() {
    "$FFD" info --json "$1" | sed -e 's/"file": "[^"]*", //' -e 's/, "bbox": .*//'
}

count=0
for rig in "$EX"/*.json; do
    name=$(basename "$rig" .json)
    mesh=$EX/${name%%-*}.off
    [ -f "$mesh" ] || { fail "$name: no mesh $mesh"; continue; }
    sum=$(cksum <"$mesh")
    out=$T/$name.off
    count=$((count + 1))
    if ! "$FFD" deform "$mesh" -o "$out" --rig "$rig" --report >"$T/$name.report" 2>"$T/$name.err"; then
        fail "$name: ffd deform failed: $(cat "$T/$name.err")"
        continue
    fi
    [ "$(topology "$out")" = "$(topology "$mesh")" ] || fail "$name: counts or topology changed"
    cmp -s "$mesh" "$out" && fail "$name: no vertex moved"
    grep -q '"placed": true' "$T/$name.report" || fail "$name: report lacks placement: $(cat "$T/$name.report")"
    grep -q '"uncovered": 0' "$T/$name.report" || fail "$name: uncovered vertices: $(cat "$T/$name.report")"
    [ "$(cksum <"$mesh")" = "$sum" ] || fail "$name: the input mesh was modified"
done
[ "$count" -ge 4 ] || fail "expected at least 4 example rigs, found $count"

# The direct-manipulation example reaches its targets.
sed -e 's/.*"max_residual": \([^,]*\),.*/\1/' "$T/cow-drag.report" >"$T/maxres"
awk '{ exit !($1 <= 1e-9) }' "$T/maxres" || fail "cow-drag.json: max_residual $(cat "$T/maxres") > 1e-9"

# place writes a rig; replaying it without moves gives the mesh back byte for byte.
ok pbffd place "$EX/cow.off" -o "$T/controls.json" --interior 30 --exterior 40 --levels 2 \
    --points "$T/points.obj" --report
has stdout '"controls": 70, "interior": 30, "exterior": 40, "open": false'
has stderr "wrote $T/controls.json (70 control points: 30 interior, 40 exterior; closed surface;"
grep -q '"levels": 2' "$T/controls.json" || fail "the placed rig lacks its levels"
[ "$(grep -c '^v ' "$T/points.obj")" = 70 ] || fail "--points wrote $(grep -c '^v ' "$T/points.obj") points"
ok deform "$EX/cow.off" -o "$T/same.off" --rig "$T/controls.json"
cmp -s "$EX/cow.off" "$T/same.off" || fail "replaying placed controls without moves changed the mesh"

# A disabled control changes nothing, bitwise: far away (it used to move the
# master) or near, and whether it comes first or last.
C3='{"center": [0.4,0,0], "radius": 0.2}, {"center": [0.3,0.1,0], "radius": 0.2}, {"center": [-0.3,0,0], "radius": 0.35}'
MV='"levels": 2, "moves": [{"control": %d, "delta": [0.05,0.02,0]}, {"control": 0, "level": 1, "delta": [0,0,0.03]}]'
printf "{\"deformer\": \"pbffd\", \"controls\": [$C3], $MV}" 0 >"$T/on.json"
printf "{\"deformer\": \"pbffd\", \"controls\": [$C3, {\"center\": [50,-20,80], \"radius\": 1, \"enabled\": false}], $MV}" 0 >"$T/far.json"
printf "{\"deformer\": \"pbffd\", \"controls\": [{\"center\": [0.35,0,0], \"radius\": 0.1, \"enabled\": false}, $C3], $MV}" 1 >"$T/near.json"
ok deform "$EX/cow.off" -o "$T/on.off" --rig "$T/on.json"
cmp -s "$EX/cow.off" "$T/on.off" && fail "the disabled-control rig moved nothing"
for v in far near; do
    ok deform "$EX/cow.off" -o "$T/$v.off" --rig "$T/$v.json"
    cmp -s "$T/on.off" "$T/$v.off" || fail "a disabled control ($v) changed the result"
done

# Placement works on a sphere (cospherical vertices: Qhull merges them into
# one Delaunay region): a UV sphere of radius 2 about (1,2,3), 32 x 16.
awk 'BEGIN { pi = 3.14159265358979; s = 32; r = 16; print "v 1 2 5";
    for (i = 1; i < r; i++) for (j = 0; j < s; j++)
        printf "v %.17g %.17g %.17g\n", 1 + 2 * sin(pi * i / r) * cos(2 * pi * j / s),
            2 + 2 * sin(pi * i / r) * sin(2 * pi * j / s), 3 + 2 * cos(pi * i / r);
    print "v 1 2 1"; south = 2 + (r - 1) * s;
    for (j = 0; j < s; j++) printf "f 1 %d %d\n", 2 + j, 2 + (j + 1) % s;
    for (i = 1; i < r - 1; i++) for (j = 0; j < s; j++)
        printf "f %d %d %d %d\n", 2 + (i - 1) * s + j, 2 + i * s + j, 2 + i * s + (j + 1) % s,
            2 + (i - 1) * s + (j + 1) % s;
    for (j = 0; j < s; j++) printf "f %d %d %d\n", south, 2 + (r - 2) * s + (j + 1) % s, 2 + (r - 2) * s + j
}' >"$T/sphere.obj"
ok pbffd place "$T/sphere.obj" -o "$T/sphere.json" --points "$T/sphere-points.obj" --report
has stdout '"interior": 1, "exterior": 60, "open": false'
has stderr "the medial axis has only 1 distinct interior point"
# the interior point is the centre (1,2,3), within 1e-4 of the radius
grep -m 1 '^v ' "$T/sphere-points.obj" | awk '{ exit !($1 == "v" && ($2-1)^2 + ($3-2)^2 + ($4-3)^2 < 4e-8) }' ||
    fail "the sphere's interior point is not its centre: $(grep -m 1 '^v ' "$T/sphere-points.obj")"
ok pbffd place "$T/sphere.obj" -o "$T/sphere2.json"
cmp -s "$T/sphere.json" "$T/sphere2.json" || fail "placement on the sphere is not deterministic"
ok deform "$T/sphere.obj" -o "$T/sphere-same.obj" --rig "$T/sphere.json"
cmp -s "$T/sphere.obj" "$T/sphere-same.obj" || fail "replaying the sphere's controls changed it"

# An open mesh takes the open-surface path and says so.
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0.2\nv 0.5 0.5 0.3\nf 1 2 5\nf 2 4 5\nf 4 3 5\nf 3 1 5\n' >"$T/open.obj"
ok pbffd place "$T/open.obj" -o "$T/open.json" --exterior 6 --surface closed
has stderr "note: "
has stderr "open surface"

# Bad input: message, exit status, no output.
bad 2 pbffd
has stderr "missing subcommand"
bad 2 pbffd shuffle
has stderr "unknown subcommand 'shuffle'"
bad 2 pbffd place "$EX/cow.off"
has stderr "missing -o CONTROLS.json"
bad 2 pbffd place "$EX/cow.off" -o "$T/x.json" --interior 0
has stderr "--interior '0': expected a positive integer"
bad 2 pbffd place "$EX/cow.off" -o "$T/x.json" --surface flat
has stderr "--surface 'flat'"
bad 2 pbffd place "$EX/cow.off" -o "$T/x.json" --offset -1
bad 1 pbffd place "$EX/cow.off" -o "$T/x.json" --interior 100000
has stderr "only"
has stderr "Voronoi vertices lie inside the mesh"
[ -e "$T/x.json" ] && fail "a failed place wrote its output"
bad 1 pbffd place "$T/missing.off" -o "$T/x.json"
has stderr "missing.off"
printf '{"deformer": "pbffd", "controls": [{"center": [0,0,0], "radius": 0}]}' >"$T/zero.json"
bad 1 deform "$EX/cow.off" -o "$T/x.off" --rig "$T/zero.json"
has stderr "zero.json: controls[0].radius: 0: expected a radius > 0"
printf '{"deformer": "pbffd", "controls": [{"center": [0,0,0], "radius": 1, "frame": [[1,0,0],[2,0,0],[0,0,1]]}]}' >"$T/flat.json"
bad 1 deform "$EX/cow.off" -o "$T/x.off" --rig "$T/flat.json"
has stderr "degenerate frame"
printf '{"deformer": "pbffd", "controls": [{"center": [9,9,9], "radius": 0.1}], "constraints": [{"vertex": 0, "target": [0,0,0]}]}' >"$T/far.json"
bad 1 deform "$EX/cow.off" -o "$T/x.off" --rig "$T/far.json"
has stderr "but the master's, so it cannot move"
printf '{"deformer": "pbffd", "sigma": 1e-300}' >"$T/sigma.json"
bad 1 deform "$EX/cow.off" -o "$T/x.off" --rig "$T/sigma.json"
has stderr "sigma: 1e-300: expected a number in [0.05, 1e6]"
printf '{"deformer": "pbffd", "levels": 2, "controls": [{"center": [1e200,0,0], "radius": 1}, {"center": [-1e200,0,0], "radius": 1}]}' >"$T/huge.json"
bad 1 deform "$EX/cow.off" -o "$T/x.off" --rig "$T/huge.json"
has stderr "beyond the supported range"
[ -e "$T/x.off" ] && fail "a failed deform wrote its output"

# place never overwrites its input, and -o and --points are different files
cp "$EX/cow.off" "$T/c.off"
bad 2 pbffd place "$T/c.off" -o "$T/./c.off"
has stderr "is the same file as the input mesh"
bad 2 pbffd place "$T/c.off" -o "$T/r.json" --points "$T/c.off"
has stderr "--points $T/c.off is the same file as the input mesh"
bad 2 pbffd place "$T/c.off" -o "$T/r.obj" --points "$T/r.obj"
has stderr "the same file as -o"
bad 2 pbffd place "$T/c.off" -o "$T/r.json" --offset 1e300
has stderr "--offset '1e300'"
bad 1 pbffd place "$T/c.off" -o "$T/r.json" --levels 32 --interior 2 --exterior 1
has stderr "level"
cmp -s "$T/c.off" "$EX/cow.off" || fail "place modified its input"
[ -e "$T/r.json" ] && fail "a failed place wrote its rig"

if [ "$failures" -ne 0 ]; then
    echo "$failures failure(s)"
    exit 1
fi
echo "$count PB-FFD example rigs and the pbffd command pass"
