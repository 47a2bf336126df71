#!/usr/bin/env bash
# Point sets (.xyz, .csv, .npy; docs/volume.md "Point sets") from the command
# line: the bunny's vertices as points are deformed by every linear method
# (lattice, PB-FFD with controls placed on the bunny's surface, T-spline)
# like the bunny's own vertices; an untouched convert is byte-identical;
# conversions between the point formats, to OBJ, and from OBJ/SU2 keep every
# point (NumPy and meshio read the results); Python's ffdkit.read_mesh
# reads a .npy when the package is built.
# usage: bash test_volume_xyz.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
PY=/usr/bin/python3
if ! "$PY" -c 'import meshio, numpy' 2>/dev/null; then
    echo "SKIP: $PY cannot import meshio and numpy (Debian python3-meshio)"
    exit 77
fi
V=$SRC/data/volume
EX=$SRC/examples
BUNNY=$SRC/data/bunny.obj

# Untouched: byte-identical.
for f in bunny_points.xyz bunny_points.csv bunny_points.npy bunny_points_f4be.npy; do
    ok convert "$V/$f" "$T/same.${f##*.}"
    cmp -s "$V/$f" "$T/same.${f##*.}" || fail "convert $f is not byte-identical"
done

# PB-FFD controls placed on the surface, with a drag of vertex 100.
ok pbffd place "$BUNNY" -o "$T/placed.json"
"$PY" - "$T/placed.json" <<'PYEOF' || fail "could not add a constraint to the placed rig"
import json, sys
r = json.load(open(sys.argv[1]))
r["constraints"] = [{"vertex": 100, "target": [0.2, 0.3, 2.9]}]
json.dump(r, open(sys.argv[1], "w"))
PYEOF

# Every linear method: the points move as the bunny's vertices do.
for rig in "$EX/lattice/bend.json" "$T/placed.json" "$EX/tspline/bunny-ears.json"; do
    name=$(basename "$rig" .json)
    ok deform "$BUNNY" --rig "$rig" -o "$T/$name.obj"
    for f in bunny_points.xyz bunny_points.csv bunny_points.npy; do
        ext=${f##*.}
        out=$T/$name-points.$ext
        ok deform "$V/$f" --rig "$rig" -o "$out"
        cmp -s "$V/$f" "$out" && fail "$name: deform $f moved nothing"
        "$PY" - "$T/$name.obj" "$out" "$name" <<'PYEOF' || fail "$name: $f does not move like the bunny"
import sys, numpy as np, meshio
surface = meshio.read(sys.argv[1]).points
path = sys.argv[2]
if path.endswith(".npy"):
    pts = np.load(path)
elif path.endswith(".csv"):
    pts = np.loadtxt(path, delimiter=",", skiprows=1)[:, :3]
else:
    pts = np.loadtxt(path)[:, :3]
assert pts.shape == surface.shape, (pts.shape, surface.shape)
err = np.abs(pts - surface).max()
# lattice and PB-FFD bind positions only: the same points land on the same
# places. The T-spline proxy's occupancy samples the bunny's faces, a point
# set has its points only: a slightly different proxy, the same drag.
diag = np.linalg.norm(surface.max(0) - surface.min(0))
tol = 1e-2 * diag if sys.argv[3] == "bunny-ears" else 1e-12 * diag
assert err <= tol, (sys.argv[3], err, tol)
PYEOF
    done
done

# Conversions: point formats among themselves and to OBJ, OBJ and SU2 to points.
ok convert "$V/bunny_points.csv" "$T/c.npy"
ok convert "$V/bunny_points.npy" "$T/n.xyz"
ok convert "$V/bunny_points.xyz" "$T/x.csv"
ok convert "$V/bunny_points.xyz" "$T/x.obj"
ok convert "$BUNNY" "$T/b.npy"
ok convert "$V/mixed.su2" "$T/m.xyz"
"$PY" - "$T" "$V" "$BUNNY" <<'PYEOF' || fail "converted points differ"
import sys, numpy as np, meshio
t, v, bunny = sys.argv[1:4]
ref = meshio.read(bunny).points
assert np.array_equal(np.load(t + "/c.npy"), ref)
assert np.load(t + "/c.npy").dtype == np.dtype("<f8")
assert np.array_equal(np.loadtxt(t + "/n.xyz"), ref)
c = np.loadtxt(t + "/x.csv", delimiter=",", skiprows=1)
assert np.array_equal(c, ref)
assert open(t + "/x.csv").readline() == "x,y,z\n"
o = meshio.read(t + "/x.obj")
assert np.array_equal(o.points, ref) and sum(len(b.data) for b in o.cells) == 0
assert np.array_equal(np.load(t + "/b.npy"), ref)
assert np.array_equal(np.loadtxt(t + "/m.xyz"), meshio.read(v + "/mixed.su2").points)
PYEOF

# Python reads a .npy point set (when the package is built beside ffd).
pydir=$(dirname "$FFD")/python
if [ -d "$pydir/ffdkit" ]; then
    # a sanitizer build's module needs its runtime loaded first (as run_pytest.sh does)
    asan=$(ldd "$FFD" | awk '/libasan/ {print $3}')
    LD_PRELOAD=$asan ASAN_OPTIONS=detect_leaks=0 PYTHONPATH=$pydir "$PY" -c "
import ffdkit, numpy as np
m = ffdkit.read_mesh('$V/bunny_points.npy')
assert np.array_equal(m.points, np.load('$V/bunny_points.npy'))
" || fail "ffdkit.read_mesh on a .npy"
fi

# Bad input: a NaN point, a (N, 2) array.
printf '1 2 3\n4 nan 6\n' >"$T/nan.xyz"
bad 1 info "$T/nan.xyz"
has stderr "nan.xyz:2: coordinate y of point 2 is not finite"
"$PY" -c "import numpy as np; np.save('$T/flat.npy', np.zeros((4, 2)))"
bad 1 info "$T/flat.npy"
has stderr "shape (4, 2) is not (N, 3)"

[ "$failures" -eq 0 ] && echo "test_volume_xyz: ok"
exit $((failures > 0))
