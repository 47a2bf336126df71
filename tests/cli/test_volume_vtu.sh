#!/usr/bin/env bash
# VTU through the CLI, checked by an independent reader (meshio, Debian's
# python3-meshio): every sample of data/volume/ and a surface mesh converted
# to each VTU encoding (ascii, --base64, --raw, with and without --compress)
# and deformed, then read by meshio and compared with the source (points,
# cells per type, point and cell data) and with the deformed OBJ. Untouched
# conversions of a .vtu to itself are byte-identical; deformed ones keep
# their size when the encoding has fixed-size values. meshio runs once, on
# the list of pairs.
# usage: bash test_volume_vtu.sh PATH_TO_ffd SOURCE_DIR   (exit 77: meshio missing)
set -u
source "$(dirname "$0")/lib.sh" "$@"
PY=/usr/bin/python3
if ! "$PY" -c 'import meshio' 2>/dev/null; then
    echo "SKIP: meshio is missing (/usr/bin/python3 -c 'import meshio'; Debian python3-meshio)"
    exit 77
fi
RIG=$SRC/tests/data/rig/pull.json
: >"$T/pairs"
# pair KIND A B [C]: meshio compares A with B (same: points, cells, data;
# geom: points and cells, for OBJ whose meshio group ids VTU does not hold;
# moved: A's points are B's, its cells and data C's, and C's points moved)
pair() { echo "$*" >>"$T/pairs"; }

encodings=("--ascii" "--base64" "--raw" "--base64 --compress" "--raw --compress")
for f in "$SRC"/data/volume/*.vtu; do
    b=$(basename "$f" .vtu)
    ok convert "$f" "$T/$b.same.vtu"
    cmp -s "$f" "$T/$b.same.vtu" || fail "$b: untouched convert is not byte-identical"
    for e in "${encodings[@]}"; do
        tag=$(echo "$e" | tr -d ' -')
        # shellcheck disable=SC2086
        ok convert "$f" "$T/$b.$tag.vtu" $e
        pair same "$T/$b.$tag.vtu" "$f"
    done
    ok deform "$f" -o "$T/$b.def.vtu" --rig "$RIG"
    ok deform "$f" -o "$T/$b.def.obj" --rig "$RIG"
    pair moved "$T/$b.def.vtu" "$T/$b.def.obj" "$f"
    case $b in *zlib* | *ascii*) ;; *)
        [ "$(wc -c <"$T/$b.def.vtu")" -eq "$(wc -c <"$f")" ] || fail "$b: deformed size changed" ;;
    esac
done
for e in "${encodings[@]}"; do
    tag=$(echo "$e" | tr -d ' -')
    # shellcheck disable=SC2086
    ok convert "$SRC/data/bunny.obj" "$T/bunny.$tag.vtu" $e
    pair geom "$T/bunny.$tag.vtu" "$SRC/data/bunny.obj"
done
ok convert "$T/bunny.rawcompress.vtu" "$T/bunny.back.obj"
pair geom "$T/bunny.back.obj" "$SRC/data/bunny.obj"
bad 1 convert "$SRC/data/bunny.obj" "$T/x.vtu" --ascii --compress
has stderr "not ascii"

"$PY" - "$T/pairs" <<'PYEOF' || fail "meshio comparisons"
import sys, warnings
import numpy as np
import meshio
warnings.simplefilter("ignore")
bad = 0
def cells(m):
    # OBJ faces come as one block; VTU triangles too
    return [(c.type, np.asarray(c.data)) for c in m.cells]
def same_cells(a, b):
    ca, cb = cells(a), cells(b)
    return [t for t, _ in ca] == [t for t, _ in cb] and all(
        np.array_equal(x, y) for (_, x), (_, y) in zip(ca, cb))
for line in open(sys.argv[1]):
    kind, *paths = line.split()
    try:
        m = [meshio.read(p) for p in paths]
        a, b = m[0], m[1]
        tol = 1e-6 if b.points.dtype == np.float32 or a.points.dtype == np.float32 else 0
        assert a.points.shape == b.points.shape, (a.points.shape, b.points.shape)
        assert np.allclose(a.points, b.points, rtol=0, atol=tol), abs(a.points - b.points).max()
        src = m[2] if kind == "moved" else b
        assert same_cells(a, src), "cells differ"
        if kind == "moved":
            assert not np.array_equal(a.points, src.points), "nothing moved"
        if kind == "geom":
            continue
        for k in src.point_data:
            assert np.allclose(np.ravel(a.point_data[k]), np.ravel(src.point_data[k])), k
        for k in src.cell_data:
            assert all(np.array_equal(np.ravel(x), np.ravel(y))
                       for x, y in zip(a.cell_data[k], src.cell_data[k])), k
    except Exception as e:  # report every pair
        print(f"FAIL: meshio {kind} {' '.join(paths)}: {type(e).__name__}: {e}")
        bad += 1
print(f"meshio: {sum(1 for _ in open(sys.argv[1]))} comparisons, {bad} failed")
sys.exit(1 if bad else 0)
PYEOF

[ "$failures" -eq 0 ] && echo "test_volume_vtu: all passed"
exit $((failures > 0))
