#!/usr/bin/env bash
# SU2 meshes (docs/volume.md "SU2") from the command line: untouched
# converts are byte-identical; a lattice deformation of the 3D, 2D and
# mixed samples changes only points (meshio reads the same cells and
# su2:tag markers, moved points); a surface (OBJ) and a created volume
# written to SU2 read back in meshio with the same points and cells; bad
# input is refused with its line.
# usage: bash test_volume_su2.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
PY=/usr/bin/python3
if ! "$PY" -c 'import meshio, numpy' 2>/dev/null; then
    echo "SKIP: $PY cannot import meshio and numpy (Debian python3-meshio)"
    exit 77
fi
V=$SRC/data/volume
RIG=$SRC/examples/lattice/bend.json

for f in mixed box_markers square_2d; do
    ok convert "$V/$f.su2" "$T/$f-same.su2"
    cmp -s "$V/$f.su2" "$T/$f-same.su2" || fail "convert $f.su2 is not byte-identical"
    ok deform "$V/$f.su2" --rig "$RIG" -o "$T/$f.su2"
    cmp -s "$V/$f.su2" "$T/$f.su2" && fail "deform $f.su2 moved nothing"
    "$PY" - "$V/$f.su2" "$T/$f.su2" <<'PYEOF' 2>"$T/py.err" || fail "$f: meshio: $(cat "$T/py.err")"
import sys, numpy as np, meshio
a, b = meshio.read(sys.argv[1]), meshio.read(sys.argv[2])
assert a.points.shape == b.points.shape
assert not np.array_equal(a.points, b.points)
assert [c.type for c in a.cells] == [c.type for c in b.cells]
for x, y in zip(a.cells, b.cells):
    assert np.array_equal(x.data, y.data), x.type
for x, y in zip(a.cell_data["su2:tag"], b.cell_data["su2:tag"]):
    assert np.array_equal(x, y)
PYEOF
done
# the 2D sample stays 2D
"$PY" -c "import meshio,sys; assert meshio.read(sys.argv[1]).points.shape[1] == 2" "$T/square_2d.su2" ||
    fail "the deformed 2D mesh is not 2D"

# A surface written to SU2: its triangles as NELEM elements.
ok convert "$SRC/data/bunny.obj" "$T/bunny.su2"
"$PY" - "$SRC/data/bunny.obj" "$T/bunny.su2" <<'PYEOF' 2>"$T/py.err" || fail "bunny.su2: $(cat "$T/py.err")"
import sys, numpy as np, meshio
a, b = meshio.read(sys.argv[1]), meshio.read(sys.argv[2])
assert np.array_equal(a.points, b.points)
assert np.array_equal(a.cells_dict["triangle"], b.cells_dict["triangle"])
PYEOF

# A volume made by meshio in another format (a legacy VTK file, when our
# VTK reader is built) written to SU2: meshio reads the same cells.
"$PY" - "$V/box_markers.su2" "$T/box.vtk" <<'PYEOF' 2>/dev/null
import sys, meshio
m = meshio.read(sys.argv[1])
meshio.write(sys.argv[2], meshio.Mesh(m.points, [c for c in m.cells if c.type == "hexahedron"]), binary=False)
PYEOF
if "$FFD" convert "$T/box.vtk" "$T/box_from_vtk.su2" >/dev/null 2>&1; then
    "$PY" - "$T/box.vtk" "$T/box_from_vtk.su2" <<'PYEOF' 2>"$T/py.err" || fail "vtk to su2: $(cat "$T/py.err")"
import sys, numpy as np, meshio
a, b = meshio.read(sys.argv[1]), meshio.read(sys.argv[2])
assert np.allclose(a.points, b.points, rtol=0, atol=0)
assert np.array_equal(a.cells_dict["hexahedron"], b.cells_dict["hexahedron"])
PYEOF
fi

# Bad input names the line.
printf 'NDIME= 3\nNELEM= 1\n10 0 1 2 9\nNPOIN= 4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\nNMARK= 0\n' >"$T/bad.su2"
bad 1 info "$T/bad.su2"
has stderr "bad.su2:3: node 9 out of range (4 nodes)"
printf 'NZONE= 2\n' >"$T/zones.su2"
bad 1 deform "$T/zones.su2" --rig "$RIG" -o "$T/zones-out.su2"
has stderr "multi-zone SU2 files (NZONE= 2) are not supported"
[ -e "$T/zones-out.su2" ] && fail "a refused deform wrote its output"

[ "$failures" -eq 0 ] && echo "test_volume_su2: ok"
exit $((failures > 0))
