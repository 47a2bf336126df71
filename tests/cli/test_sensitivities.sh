#!/usr/bin/env bash
# ffd sensitivities: the Matrix Market file scipy.io.mmread reads back equals
# the library's W (through the Python package when it is built next to ffd:
# W itself and the product W v), --expand is W (x) I3, the comment lines say
# what rows and columns are; a linear deformation is X = X0 + W (P - P0)
# (checked against ffd deform for the lattice); GFFD and bad command lines
# are refused without output. Skips the scipy checks politely without scipy.
# usage: bash test_sensitivities.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
EX=$SRC/examples
PY=/usr/bin/python3
BUILD=$(cd "$(dirname "$FFD")" && pwd)
# the Python package next to ffd, unless this is a sanitizer build (its module
# needs the sanitizer runtime preloaded: tests/python/run_pytest.sh)
PYPATH=$BUILD/python
ldd "$FFD" 2>/dev/null | grep -q 'libasan' && PYPATH=

cases="lattice/bunny.obj:lattice/pins.json pbffd/cow.off:pbffd/cow-levels.json tspline/bunny.obj:tspline/bunny-ears.json"
for c in $cases; do
    mesh=$EX/${c%%:*} rig=$EX/${c##*:}
    name=$(basename "${c##*:}" .json)
    ok sensitivities "$mesh" --rig "$rig" -o "$T/$name.mtx"
    has stderr "wrote $T/$name.mtx"
    head -1 "$T/$name.mtx" | grep -qx '%%MatrixMarket matrix coordinate real general' ||
        fail "$name: not a Matrix Market header: $(head -1 "$T/$name.mtx")"
    grep -q '^% dX/dP = W (x) I3' "$T/$name.mtx" || fail "$name: no comment saying dX/dP = W (x) I3"
    ok sensitivities "$mesh" --rig "$rig" -o "$T/$name-x.mtx" --expand
    rows=$(grep -v '^%' "$T/$name.mtx" | head -1 | cut -d' ' -f1)
    nv=$("$FFD" info --json "$mesh" | sed 's/.*"vertices": \([0-9]*\).*/\1/')
    [ "$rows" = "$nv" ] || fail "$name: $rows rows for $nv vertices"
done

if "$PY" -c "import scipy.io, numpy" 2>/dev/null; then
    PYTHONPATH=$PYPATH "$PY" - "$T" "$EX" <<'PYEOF' || fail "scipy checks (above)"
import os, sys
import numpy as np, scipy.io, scipy.sparse
T, EX = sys.argv[1], sys.argv[2]
try:
    import ffdkit
except ImportError:
    ffdkit = None
    print("note: no ffdkit next to ffd: W checked by its structure and --expand only")
bad = 0
for mesh, rig in [("lattice/bunny.obj", "lattice/pins.json"), ("pbffd/cow.off", "pbffd/cow-levels.json"),
                  ("tspline/bunny.obj", "tspline/bunny-ears.json")]:
    name = os.path.basename(rig)[:-5]
    W = scipy.sparse.csr_matrix(scipy.io.mmread(os.path.join(T, name + ".mtx")))
    E = scipy.sparse.csr_matrix(scipy.io.mmread(os.path.join(T, name + "-x.mtx")))
    K = scipy.sparse.kron(W, scipy.sparse.identity(3), format="csr")
    if E.shape != K.shape or abs(E - K).max() != 0:
        print(f"FAIL: {name}: --expand is not W (x) I3"); bad += 1
    if ffdkit is not None:
        d = ffdkit.Rig.load(os.path.join(EX, rig)).deformer(ffdkit.read_mesh(os.path.join(EX, mesh)))
        L = d.sensitivities()
        if L.shape != W.shape or abs(L - W).max() != 0:  # 17 digits: the same doubles
            print(f"FAIL: {name}: the .mtx differs from Deformer.sensitivities"); bad += 1
        v = np.random.default_rng(0).standard_normal((d.control_count, 3))
        if not np.allclose(W @ v, d.sensitivity_product(v), rtol=0, atol=1e-12):
            print(f"FAIL: {name}: W v from the .mtx differs from sensitivity_product"); bad += 1
sys.exit(bad)
PYEOF
    # a linear deformation: X = X0 + W (P - P0), with P - P0 the moves of a
    # B-spline lattice rig (control (i, j, k) is column (i m + j) n + k)
    cat >"$T/move.json" <<'JSON'
{"version": 1, "deformer": "lattice", "basis": "bspline", "resolution": [4, 4, 4], "box": "auto",
 "moves": [{"index": [1, 2, 3], "delta": [0.5, -0.25, 1.0]}, {"index": [0, 0, 0], "delta": [0.0, 2.0, 0.0]}]}
JSON
    ok sensitivities "$EX/lattice/bunny.obj" --rig "$T/move.json" -o "$T/move.mtx"
    ok deform "$EX/lattice/bunny.obj" --rig "$T/move.json" -o "$T/moved.obj"
    "$PY" - "$T" "$EX" <<'PYEOF' || fail "X = X0 + W (P - P0) (above)"
import sys
import numpy as np, scipy.io
T, EX = sys.argv[1], sys.argv[2]
def points(path):
    return np.array([[float(t) for t in l.split()[1:4]] for l in open(path) if l.startswith("v ")])
W = scipy.io.mmread(T + "/move.mtx").tocsr()
dP = np.zeros((64, 3))
dP[(1 * 4 + 2) * 4 + 3] = [0.5, -0.25, 1.0]
dP[0] = [0.0, 2.0, 0.0]
X0, X = points(EX + "/lattice/bunny.obj"), points(T + "/moved.obj")
err = np.abs(X0 + W @ dP - X).max()
if err > 1e-5:  # the OBJ keeps 6 decimals
    print(f"FAIL: X0 + W dP differs from ffd deform by {err}")
    sys.exit(1)
PYEOF
else
    echo "SKIP (part): $PY lacks scipy: the .mtx files are not read back (Debian: python3-scipy)"
fi

# refusals: no output written
bad 1 sensitivities "$EX/gffd/elephant.off" --rig "$SRC/tests/data/deformer/gffd-bend.json" -o "$T/g.mtx"
has stderr "the gffd method has no sensitivities"
[ -e "$T/g.mtx" ] && fail "GFFD: an output was written"
bad 2 sensitivities "$EX/lattice/bunny.obj" -o "$T/n.mtx"
has stderr "missing --rig RIG"
bad 2 sensitivities "$EX/lattice/bunny.obj" --rig "$EX/lattice/pins.json"
has stderr "missing -o OUT.mtx"
cp "$EX/lattice/pins.json" "$T/pins.json"
bad 2 sensitivities "$EX/lattice/bunny.obj" --rig "$T/pins.json" -o "$T/pins.json"
has stderr "refusing to overwrite an input"
cmp -s "$T/pins.json" "$EX/lattice/pins.json" || fail "the rig was overwritten"
ok sensitivities --help
has stdout "usage: ffd sensitivities MESH"

[ "$failures" -eq 0 ] && echo "ok" || { echo "$failures failure(s)"; exit 1; }
