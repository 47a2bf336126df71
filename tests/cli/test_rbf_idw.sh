#!/usr/bin/env bash
# RBF and IDW from the command line (docs/rbf-idw.md): every example rig runs
# on the bunny with a report (method, constraints reached); the control points
# come out with --lattice-out; a rig that moves nothing writes the input's
# bytes back; PyGeM's .prm files are read; a bad rig gives exit 1, the rig's
# name and key, and no output.
# usage: bash test_rbf_idw.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
EX=$SRC/examples
BUNNY=$EX/lattice/bunny.obj

for m in rbf idw; do
    for r in ears pins; do
        ok deform "$BUNNY" -o "$T/$m-$r.obj" --rig "$EX/$m/bunny-$r.json" --report --lattice-out "$T/$m-$r-cp.obj"
        has stdout "\"method\": \"$m\""
        [ "$(grep -c '^v ' "$T/$m-$r-cp.obj")" -ge 11 ] || fail "$m-$r: --lattice-out lacks the control points"
        cmp -s "$T/$m-$r.obj" "$BUNNY" && fail "$m-$r: the bunny did not move"
    done
    has stdout '"max_residual": '
    grep -q '"max_residual": [0-9.]*e-1[0-9]' "$T/stdout" || grep -q '"max_residual": 0[,}]' "$T/stdout" ||
        fail "$m pins: the constraints were not reached: $(cat "$T/stdout")"
    # nothing moved: the input's bytes
    printf '{"deformer": "%s", "control_points": [[-6,-1,-5],[6,-1,-5],[-6,11,-5],[0,0,5],[1,2,3]]}\n' "$m" >"$T/rest.json"
    ok deform "$BUNNY" -o "$T/rest.obj" --rig "$T/rest.json"
    cmp -s "$T/rest.obj" "$BUNNY" || fail "$m: a rig that moves nothing changed the bunny's bytes"
    # PyGeM's parameter file
    ok deform "$SRC/tests/data/rig/cube.obj" -o "$T/cube-$m.obj" --rig "$EX/$m/cube.prm"
    # to rounding: the solve's last bits depend on the BLAS kernels of the CPU
    awk '$1 == "v" { d = ($2 - 1.5)^2 + ($3 - 1.6)^2 + ($4 - 1.7)^2; if (d < 1e-24) hit = 1 } END { exit !hit }' "$T/cube-$m.obj" ||
        fail "$m cube.prm: the corner (1,1,1) did not reach (1.5,1.6,1.7): $(grep '^v' "$T/cube-$m.obj")"
done

# a bad rig: named, nothing written
printf '{"deformer": "rbf", "kernel": "cubic", "control_points": [[0,0,0]]}\n' >"$T/bad.json"
bad 1 deform "$BUNNY" -o "$T/bad.obj" --rig "$T/bad.json"
has stderr 'bad.json: kernel: expected "gaussian_spline"'
[ -e "$T/bad.obj" ] && fail "a bad rig wrote its output"

if [ "$failures" -ne 0 ]; then
    echo "$failures failure(s)"
    exit 1
fi
echo "RBF and IDW example rigs, reports, identity, .prm files and errors pass"
