#!/usr/bin/env bash
# Gmsh .msh through the CLI, checked by an independent reader (meshio,
# Debian's python3-meshio): each sample converted to MSH 2.2 ascii and
# binary, deformed in place of its own format (lossless) and converted after
# deforming, and a surface (bunny.obj) written as .msh; meshio must read
# every result with the expected points, cells and gmsh tags.
# Skipped (77) without meshio. usage: bash test_volume_msh.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
PY=/usr/bin/python3
if ! "$PY" -c 'import meshio' 2>/dev/null; then
    echo "SKIP: meshio is not installed for $PY (apt install python3-meshio)"
    exit 77
fi
V=$SRC/data/volume
RIG=$SRC/tests/data/rig/pull.json

# same A B [points]: meshio reads A and B with equal cells and tags (and points unless "moved")
same() {
    "$PY" - "$1" "$2" "${3:-}" <<'PYEOF' || fail "meshio: $1 vs $2 ($3)"
import sys, meshio, numpy as np
a, b, how = meshio.read(sys.argv[1]), meshio.read(sys.argv[2]), sys.argv[3]
def blocks(m):  # cells merged per type, in file order
    out = {}
    for c in m.cells:
        out.setdefault(c.type, []).append(c.data)
    return {k: np.concatenate(v) for k, v in out.items()}
ba, bb = blocks(a), blocks(b)
assert ba.keys() == bb.keys(), (ba.keys(), bb.keys())
for k in ba:
    assert np.array_equal(ba[k], bb[k]), k
if how == "moved":
    assert a.points.shape == b.points.shape and not np.array_equal(a.points, b.points)
elif how == "close":
    assert np.allclose(a.points, b.points, rtol=0, atol=1e-12)
else:
    assert np.array_equal(a.points, b.points)
for tag in ("gmsh:physical", "gmsh:geometrical"):
    if tag in a.cell_data:
        ta = np.concatenate(a.cell_data[tag]); tb = np.concatenate(b.cell_data[tag])
        assert np.array_equal(ta, tb), tag
PYEOF
}

for s in mixed_22 mixed_22_bin prism_41 prism_41_bin box_tet10_41; do
    ok convert "$V/$s.msh" "$T/$s.a.msh" --ascii
    ok convert "$V/$s.msh" "$T/$s.b.msh" --binary
    same "$V/$s.msh" "$T/$s.a.msh"
    same "$V/$s.msh" "$T/$s.b.msh"
    # deform: lossless in the source's own encoding, then transcoded
    ok deform "$V/$s.msh" -o "$T/$s.d.msh" --rig "$RIG"
    same "$V/$s.msh" "$T/$s.d.msh" moved
    ok convert "$T/$s.d.msh" "$T/$s.d22.msh" --binary
    same "$T/$s.d.msh" "$T/$s.d22.msh" close
done
# the untouched convert in the source's encoding is a byte copy
ok convert "$V/prism_41_bin.msh" "$T/copy.msh"
cmp -s "$V/prism_41_bin.msh" "$T/copy.msh" || fail "untouched binary 4.1 is not copied byte for byte"

# a surface as .msh: triangles
ok convert "$SRC/data/bunny.obj" "$T/bunny.msh"
"$PY" - "$T/bunny.msh" "$SRC/data/bunny.obj" <<'PYEOF' || fail "meshio: bunny.msh"
import sys, meshio, numpy as np
m, o = meshio.read(sys.argv[1]), meshio.read(sys.argv[2])
assert np.array_equal(m.points, o.points)
tri = np.concatenate([c.data for c in m.cells if c.type == "triangle"])
assert np.array_equal(tri, np.concatenate([c.data for c in o.cells]))
PYEOF

# ffd info of a volume .msh: the boundary faces
ok info "$V/mixed_22.msh"
has stdout "faces               18"

exit $((failures > 0))
