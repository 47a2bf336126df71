#!/usr/bin/env bash
# A real glTF client reads what we write: the fixture tests/data/mesh/
# cube_nodes.glb (a cube and a triangle under nodes with TRS and matrix
# transforms) is deformed by a lattice rig, and Blender (Debian's `blender`,
# headless) imports the deformed .glb; the world-space vertex positions it
# sees must be those ffd reads back (written as OBJ by `ffd convert`), to
# float precision. Skipped, passing, when blender is not installed.
# usage: bash test_gltf_blender.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

if ! command -v blender >/dev/null 2>&1; then
    echo "SKIP: blender not installed"
    exit 0
fi

printf '{"version": 1, "basis": "bspline", "resolution": [4, 4, 4], "margin": 0.1,
  "moves": [{"index": [3, 3, 3], "delta": [1.5, -0.5, 2]}, {"index": [0, 1, 2], "delta": [0, 1, 0]}]}\n' >"$T/rig.json"
ok deform "$SRC/tests/data/mesh/cube_nodes.glb" -o "$T/deformed.glb" --rig "$T/rig.json"
ok convert "$T/deformed.glb" "$T/expected.obj"
cmp -s "$SRC/tests/data/mesh/cube_nodes.glb" "$T/deformed.glb" && fail "the rig moved nothing"

# Blender's importer turns glTF's +Y up into +Z up: (x, y, z) -> (x, -z, y).
# Debian 12's Blender 3.4 importer still uses numpy.bool, which NumPy 1.24
# removed; the alias is restored before the importer loads.
cat >"$T/dump.py" <<'PY'
import bpy, sys
import numpy
if not hasattr(numpy, "bool"):
    numpy.bool = bool
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=sys.argv[-2])
with open(sys.argv[-1], "w") as f:
    for o in bpy.context.scene.objects:
        if o.type != "MESH":
            continue
        for v in o.data.vertices:
            w = o.matrix_world @ v.co
            f.write("%.9g %.9g %.9g\n" % (w.x, w.z, -w.y))
PY
blender --background --factory-startup --python "$T/dump.py" -- "$T/deformed.glb" "$T/blender.txt" \
    >"$T/blender.log" 2>&1 || fail "blender failed: $(tail -5 "$T/blender.log")"
if grep -q "No module named 'numpy'" "$T/blender.log"; then
    fail "Blender's glTF importer needs NumPy: apt-get install python3-numpy"
elif [ ! -s "$T/blender.txt" ]; then
    fail "Blender wrote no positions: $(grep -m3 -i error "$T/blender.log")"
fi
[ "$failures" -eq 0 ] || { echo "$failures failure(s)"; exit 1; }

# Same set of positions (Blender may merge or reorder vertices): every point
# of each list within 1e-5 (relative to 1) of a point of the other.
awk '/^v /{print $2, $3, $4}' "$T/expected.obj" >"$T/ffd.txt"
awk -v tol=1e-5 '
    NR == FNR { a[++na] = $0; next }
    { b[++nb] = $0 }
    function near(p, q,   x, y, i, d) {
        split(p, x, " "); split(q, y, " ")
        for (i = 1; i <= 3; i++) { d = x[i] - y[i]; if (d < 0) d = -d; if (d > tol * (1 + (x[i] < 0 ? -x[i] : x[i]))) return 0 }
        return 1
    }
    function covered(p, l, n,   i) { for (i = 1; i <= n; i++) if (near(p, l[i])) return 1; return 0 }
    END {
        if (nb == 0) { print "blender imported no vertices"; exit 1 }
        for (i = 1; i <= na; i++) if (!covered(a[i], b, nb)) { print "ffd vertex " a[i] " not in Blender"; exit 1 }
        for (i = 1; i <= nb; i++) if (!covered(b[i], a, na)) { print "Blender vertex " b[i] " not in ffd"; exit 1 }
    }' "$T/ffd.txt" "$T/blender.txt" >"$T/compare" || fail "$(cat "$T/compare")"

[ "$failures" -eq 0 ] || { echo "$failures failure(s)"; exit 1; }
echo "ok: Blender imports the deformed .glb with ffd's vertex positions"
