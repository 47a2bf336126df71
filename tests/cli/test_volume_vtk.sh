#!/usr/bin/env bash
# Legacy VTK through the CLI, checked by another reader: the samples of
# data/volume/ are converted to the other encoding (written from data),
# deformed by a rig (written losslessly, only coordinates change) and
# converted again; a surface (bunny.obj) and the polydata samples are written
# as .vtk; meshio (Debian's python3-meshio) reads every result and must see
# the points, cells and data ffd wrote. Exit 77 (ctest: skipped) without meshio.
# usage: bash test_volume_vtk.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

PY=/usr/bin/python3
if ! "$PY" -c 'import meshio' 2>/dev/null; then
    echo "SKIP: meshio is not installed for $PY (Debian: python3-meshio)"
    exit 77
fi
VOL="$SRC/data/volume"
RIG="$SRC/tests/data/rig/pull.json"

for s in mixed_51_ascii mixed_42_ascii mixed_51_binary mixed_42_binary box_tet_binary; do
    case $s in *ascii) other=--binary-be ;; *) other=--ascii ;; esac
    ok convert "$VOL/$s.vtk" "$T/$s.other.vtk" $other
    ok convert "$VOL/$s.vtk" "$T/$s.same.vtk"
    cmp -s "$VOL/$s.vtk" "$T/$s.same.vtk" || fail "$s: an untouched convert is not byte-identical"
    ok deform "$VOL/$s.vtk" -o "$T/$s.deformed.vtk" --rig "$RIG"
    [ "$(stat -c %s "$VOL/$s.vtk")" = "$(stat -c %s "$T/$s.deformed.vtk")" ] || case $s in
        *binary) fail "$s: the deformed binary file changed size" ;;
    esac
    cmp -s "$VOL/$s.vtk" "$T/$s.deformed.vtk" && fail "$s: the rig moved nothing"
    ok convert "$T/$s.deformed.vtk" "$T/$s.deformed.other.vtk" $other
done
ok convert "$SRC/data/bunny.obj" "$T/bunny_ascii.vtk"
ok convert "$SRC/data/bunny.obj" "$T/bunny_binary.vtk" --binary-be
ok convert "$VOL/polydata_ascii.vtk" "$T/polydata_ascii.other.vtk" --binary-be
ok convert "$VOL/polydata_binary.vtk" "$T/polydata_binary.other.vtk" --ascii

"$PY" - "$VOL" "$T" "$SRC/data/bunny.obj" <<'PY' || fail "meshio disagrees (above)"
import sys
import warnings

import meshio
import numpy as np

warnings.simplefilter("ignore")
vol, t, bunny = sys.argv[1:4]
bad = 0


def check(cond, what):
    global bad
    if not cond:
        print("FAIL:", what)
        bad += 1


def same_cells(a, b):
    return [c.type for c in a.cells] == [c.type for c in b.cells] and all(
        np.array_equal(x.data, y.data) for x, y in zip(a.cells, b.cells))


def same_data(a, b):
    ok = sorted(a.point_data) == sorted(b.point_data) and sorted(a.cell_data) == sorted(b.cell_data)
    for k in a.point_data if ok else []:
        ok = ok and np.array_equal(np.ravel(a.point_data[k]), np.ravel(b.point_data[k]))
    for k in a.cell_data if ok else []:
        ok = ok and all(np.array_equal(np.ravel(x), np.ravel(y))
                        for x, y in zip(a.cell_data[k], b.cell_data[k]))
    return ok


for s in ["mixed_51_ascii", "mixed_42_ascii", "mixed_51_binary", "mixed_42_binary", "box_tet_binary"]:
    src = meshio.read(f"{vol}/{s}.vtk")
    other = meshio.read(f"{t}/{s}.other.vtk")
    check(np.array_equal(src.points, other.points), f"{s}: points of the other encoding")
    check(same_cells(src, other), f"{s}: cells of the other encoding")
    check(same_data(src, other), f"{s}: data of the other encoding")
    deformed = meshio.read(f"{t}/{s}.deformed.vtk")
    again = meshio.read(f"{t}/{s}.deformed.other.vtk")
    check(not np.array_equal(src.points, deformed.points), f"{s}: the deformation moved nothing")
    check(np.array_equal(deformed.points, again.points), f"{s}: deformed points, other encoding")
    check(same_cells(src, deformed) and same_cells(src, again), f"{s}: deformed cells")
    check(same_data(src, deformed) and same_data(src, again), f"{s}: deformed data")

obj = meshio.read(bunny)
for e in ["ascii", "binary"]:
    m = meshio.read(f"{t}/bunny_{e}.vtk")
    check(np.array_equal(m.points, obj.points), f"bunny {e}: points")
    check(len(m.cells) == 1 and m.cells[0].type == "triangle" and
          np.array_equal(m.cells[0].data, obj.cells[0].data), f"bunny {e}: triangles")

# polydata comes back as an unstructured grid (meshio skips poly lines and strips)
for s, n in [("polydata_ascii", 10), ("polydata_binary", 10)]:
    m = meshio.read(f"{t}/{s}.other.vtk")
    check(len(m.points) == n, f"{s}: points")
    check({c.type: len(c.data) for c in m.cells} ==
          {"vertex": 1, "triangle": 1, "quad": 1, "polygon": 1}, f"{s}: cells {m.cells}")
sys.exit(1 if bad else 0)
PY

if [ "$failures" -ne 0 ]; then
    echo "$failures failure(s)"
    exit 1
fi
echo "legacy VTK: conversions, deformations and surfaces read back by meshio"
