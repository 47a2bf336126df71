#!/usr/bin/env bash
# Byte-for-byte identity (docs/cli.md, "ffd deform"): a rig that moves
# nothing writes the mesh back unchanged. Every mesh of the repository that
# ffd reads (tests/, examples/, fuzz/ corpora), plus the normal-carrying
# fixtures converted to every format and encoding, goes through the identity
# rig of every method, and the output must `cmp` equal to the input:
#   lattice B-spline and Bernstein (no moves; also a box smaller than the mesh
#   with "clamp" / "extrapolate" outside points), lattice direct manipulation
#   whose targets are the points' own positions, PB-FFD with the rig written
#   by `ffd pbffd place` (explicit controls when placement refuses a tiny
#   mesh), GFFD with no edits (with and without resampling; glTF, which refuses
#   refinement, without), T-spline with no
#   steps and with a refinement only (refinement is exact).
# usage: bash test_identity.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

# info --json field: the numbers of "min" / "max" of the bbox, or a count.
bbox() { # bbox FILE min|max -> "x y z"
    sed -n "s/.*\"$2\": \[\([^]]*\)\].*/\1/p" "$1" | tr -d ','
}
count() { # count FILE key
    sed -n "s/.*\"$2\": \([0-9]*\).*/\1/p" "$1"
}

# ---- the meshes --------------------------------------------------------------
meshes=()
seen=" "
while IFS= read -r f; do
    "$FFD" info "$f" >/dev/null 2>&1 || continue # bad inputs of the corpora
    sum=$(cksum <"$f" | cut -d' ' -f1)
    case "$seen" in *" $sum "*) continue ;; esac # fuzz seeds repeat tests/data
    seen="$seen$sum "
    meshes+=("$f")
done < <(find "$SRC/tests" "$SRC/examples" "$SRC/fuzz" -path "$SRC/tests/bad" -prune -o -type f \
    \( -iname '*.obj' -o -iname '*.ply' -o -iname '*.off' -o -iname '*.stl' -o -iname '*.gltf' -o -iname '*.glb' \) -print | LC_ALL=C sort)
[ "${#meshes[@]}" -ge 20 ] || fail "expected at least 20 distinct meshes in the repository, found ${#meshes[@]}"

# Every format and encoding, from data (the writers of ffd convert), for the
# fixtures that carry normals: OBJ vn/vt, PLY nx/ny/nz in three encodings,
# NOFF, STL facet normals in both encodings.
mkdir -p "$T/conv"
D=$SRC/tests/data/mesh
for f in "$D/identity_smooth.obj" "$D/identity_flat.obj" "$D/cube_ascii.ply" "$D/normals.off"; do
    b=$(basename "$f")
    e=${b##*.}
    b=${b%.*}
    for spec in "ply --ascii" "ply --binary" "ply --binary-be" "off --ascii" "stl --ascii" "stl --binary" "obj --ascii"; do
        set -- $spec
        [ "$1" = "$e" ] && [ "$2" = --ascii ] && continue # the file itself
        out=$T/conv/$b-${2#--}.$1
        "$FFD" convert "$f" "$out" "$2" >/dev/null 2>"$T/stderr" || fail "convert $b to $spec: $(cat "$T/stderr")"
        [ -f "$out" ] && meshes+=("$out")
    done
done
for f in "$D/identity_smooth.obj" "$D/identity_flat.obj"; do
    grep -q -- '-0\.000000 ' "$f" || fail "$f: the fixture lost its -0.000000 coordinates"
done
grep -q '^vn .*-0\.0000\b' "$D/identity_flat.obj" || fail "identity_flat.obj: the fixture lost its -0.0000 normals"

# ---- the rigs ----------------------------------------------------------------
lattice_rig() { # lattice_rig FILE BASIS RES [extra JSON members]
    printf '{"version": 1, "deformer": "lattice", "basis": "%s", "resolution": %s, "box": "auto"%s}\n' \
        "$2" "$3" "${4:-}" >"$1"
}

runs=0
check() { # check NAME MESH RIG
    local name=$1 mesh=$2 rig=$3 ext=${2##*.}
    local out=$T/out.$ext
    rm -f "$out"
    runs=$((runs + 1))
    if ! "$FFD" deform "$mesh" -o "$out" --rig "$rig" >/dev/null 2>"$T/stderr"; then
        fail "$name on $mesh: ffd deform failed: $(cat "$T/stderr")"
        return
    fi
    if ! cmp -s "$mesh" "$out"; then
        fail "$name on $mesh: the output differs from the input: $(cmp "$mesh" "$out" 2>&1 | head -n 1)"
        if [ "$ext" = obj ] || [ "$ext" = off ]; then
            diff "$mesh" "$out" | head -n 4
        fi
    fi
}

for mesh in "${meshes[@]}"; do
    "$FFD" info --json "$mesh" >"$T/info.json" || { fail "info $mesh"; continue; }
    nv=$(count "$T/info.json" vertices)
    [ "$nv" -gt 0 ] || continue # nothing to fit a box to: every method refuses, rightly
    read -r x0 y0 z0 <<<"$(bbox "$T/info.json" min)"
    read -r x1 y1 z1 <<<"$(bbox "$T/info.json" max)"
    # the centre of the box, the inner half of it, a radius of a third of the diagonal
    read -r cx cy cz ox oy oz ex ey ez r <<<"$(awk -v a="$x0" -v b="$y0" -v c="$z0" -v d="$x1" -v e="$y1" -v f="$z1" 'BEGIN {
        dx = d - a; dy = e - b; dz = f - c; diag = sqrt(dx * dx + dy * dy + dz * dz); if (diag == 0) diag = 1;
        if (dx == 0) dx = diag; if (dy == 0) dy = diag; if (dz == 0) dz = diag;
        printf "%.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", (a + d) / 2, (b + e) / 2, (c + f) / 2,
            a + dx / 4, b + dy / 4, c + dz / 4, dx / 2, dy / 2, dz / 2, diag / 3 }')"
    centre="[$cx, $cy, $cz]"
    inner="{\"origin\": [$ox, $oy, $oz], \"axes\": [[$ex, 0, 0], [0, $ey, 0], [0, 0, $ez]]}"
    # vertex 0 as written by the OBJ writer (shortest round-trip text: the same double)
    "$FFD" convert "$mesh" "$T/v0.obj" >/dev/null 2>&1 || fail "convert $mesh to OBJ"
    # (past a byte order mark, which the OBJ writer keeps)
    read -r _ vx vy vz _ <<<"$(sed '1s/^\xEF\xBB\xBF//' "$T/v0.obj" | grep -m 1 '^v ')"

    lattice_rig "$T/bspline.json" bspline "[4, 4, 4]"
    check "lattice B-spline" "$mesh" "$T/bspline.json"
    lattice_rig "$T/bernstein.json" bernstein "[3, 4, 3]"
    check "lattice Bernstein" "$mesh" "$T/bernstein.json"
    printf '{"version": 1, "deformer": "lattice", "basis": "bspline", "resolution": [5, 4, 4], "box": %s, "outside": "clamp"}\n' \
        "$inner" >"$T/clamp.json"
    check "lattice B-spline, inner box, clamp" "$mesh" "$T/clamp.json"
    printf '{"version": 1, "deformer": "lattice", "basis": "bernstein", "resolution": [4, 3, 3], "box": %s, "outside": "extrapolate"}\n' \
        "$inner" >"$T/extrapolate.json"
    check "lattice Bernstein, inner box, extrapolate" "$mesh" "$T/extrapolate.json"
    lattice_rig "$T/dm.json" bspline "[5, 5, 5]" ", \"constraints\": [
        {\"vertex\": 0, \"target\": [$vx, $vy, $vz]}, {\"point\": $centre, \"target\": $centre}]"
    check "lattice direct manipulation (targets at rest)" "$mesh" "$T/dm.json"
    lattice_rig "$T/dm-bernstein.json" bernstein "[4, 4, 4]" ", \"constraints\": [
        {\"vertex\": 0, \"target\": [$vx, $vy, $vz]}]"
    check "lattice Bernstein direct manipulation (target at rest)" "$mesh" "$T/dm-bernstein.json"

    # PB-FFD: the placed rig replayed as written (docs/cli.md, "ffd pbffd place")
    if "$FFD" pbffd place "$mesh" -o "$T/placed.json" >/dev/null 2>&1 ||
        "$FFD" pbffd place "$mesh" -o "$T/placed.json" --interior 1 --exterior 4 >/dev/null 2>&1; then
        check "PB-FFD placed rig" "$mesh" "$T/placed.json"
    fi
    printf '{"version": 1, "deformer": "pbffd", "controls": [{"center": %s, "radius": %s}, {"center": [%s, %s, %s], "radius": %s}]}\n' \
        "$centre" "$r" "$ox" "$oy" "$oz" "$r" >"$T/pbffd.json"
    check "PB-FFD explicit controls, no moves" "$mesh" "$T/pbffd.json"

    printf '{"version": 1, "deformer": "gffd", "skeleton": [{"type": "point", "position": %s, "radius": %s}], "edits": []}\n' \
        "$centre" "$r" >"$T/gffd.json"
    check "GFFD, no edits" "$mesh" "$T/gffd.json"
    printf '{"version": 1, "deformer": "gffd", "skeleton": [{"type": "polyline", "vertices": [[%s, %s, %s], %s], "radius": %s}], "resample": true}\n' \
        "$ox" "$oy" "$oz" "$centre" "$r" >"$T/gffd-resample.json"
    case "$mesh" in # glTF refuses refinement (docs/mesh-formats.md)
    *.gltf | *.glb) ;;
    *) check "GFFD polyline, no edits, resampling" "$mesh" "$T/gffd-resample.json" ;;
    esac

    printf '{"version": 1, "deformer": "tspline", "resolution": [4, 5, 4], "steps": []}\n' >"$T/tspline.json"
    check "T-spline, no steps" "$mesh" "$T/tspline.json"
    if [ "$nv" -le 3000 ]; then
        printf '{"version": 1, "deformer": "tspline", "resolution": [5, 4, 4], "steps": [{"refine": [{"cells": "proxy"}]}]}\n' \
            >"$T/tspline-refine.json"
        check "T-spline, refinement only" "$mesh" "$T/tspline-refine.json"
    fi
done
[ "$runs" -ge 300 ] || fail "expected at least 300 identity runs, made $runs"

if [ "$failures" -ne 0 ]; then
    echo "$failures failure(s) in $runs runs"
    exit 1
fi
echo "all identity checks passed (${#meshes[@]} meshes, $runs runs)"
