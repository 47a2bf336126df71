#!/usr/bin/env bash
# ffd-mpi under mpirun -np 1..4 (docs/mpi.md): the union of the ranks' pieces
# equals `ffd deform` of the whole mesh bitwise per global id (mpi_compare),
# for every linear method and for those that read the boundary surface
# (PB-FFD placement, the T-spline);
# the partition formats (.pvtu + .vtu, Gmsh split pieces, %d patterns with
# and without global ids), a rank with an empty piece, and the errors every
# rank must exit with (a corrupt or missing piece, pieces != ranks, GFFD
# resampling), each mpirun under `timeout 60` so that a hang fails.
#
# usage: test_mpi.sh FFD_MPI FFD MPI_COMPARE SOURCE_DIR [MPIEXEC] [GROUP]
#   GROUP: methods, surface, formats, errors, or all (default)
# Exit 77 (skipped) without python3 (the partition generator).
set -u
mpi=$1 ffd=$2 cmp=$3 src=$4 mpiexec=${5:-mpirun} group=${6:-all}
command -v python3 >/dev/null || { echo "test_mpi: no python3: skipped"; exit 77; }
abs() { case $1 in /*) echo "$1" ;; *) echo "$PWD/$1" ;; esac; }
mpi=$(abs "$mpi") ffd=$(abs "$ffd") cmp=$(abs "$cmp") src=$(abs "$src")
data=$src/data/volume/mpi
box=$data/mpi_box.msh
work=$PWD/mpi_test_$group
rm -rf "$work" && mkdir -p "$work" && cd "$work" || exit 1
# root in containers; shared memory only (no network), no CMA (ptrace is often denied there)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl=self,vader OMPI_MCA_btl_vader_single_copy_mechanism=none
export OMPI_MCA_rmaps_base_oversubscribe=1 OMP_NUM_THREADS=1
# ASan builds: what Open MPI never frees is not ours (its components stay
# loaded so that their frames can be named; the slow unwinder walks through
# Open MPI's frames, which have no frame pointers)
export OMPI_MCA_mca_base_component_disable_dlclose=1
export LSAN_OPTIONS="${LSAN_OPTIONS:+$LSAN_OPTIONS:}suppressions=$src/tests/mpi/lsan.supp:print_suppressions=0"
export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}fast_unwind_on_malloc=0"

failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
pass() { echo "ok   $*"; }
# run NP ARGS...: ffd-mpi deform under mpirun; stdout in run.out, stderr in run.err
run() {
    local np=$1
    shift
    timeout 60 "$mpiexec" --oversubscribe -np "$np" "$mpi" deform "$@" >run.out 2>run.err
}

# ---- the partitions: VTU pieces made here, Gmsh pieces from data/ ---------
for k in 1 2 3 4; do
    python3 "$src/tests/mpi/make_partitions.py" vtu "$box" vtu$k $k || exit 1
done
python3 "$src/tests/mpi/make_partitions.py" vtu "$box" vtu3e 3 --empty 1 || exit 1
# PARTS and the output pieces for np ranks in format f (vtu or msh)
parts() { if [ "$1" = vtu ]; then echo "vtu$2/box.pvtu"; elif [ "$2" = 1 ]; then echo "$box"; \
          else echo "$data/mpi_box_p$2.msh"; fi; }
out_pieces() { # f np name: the files the run wrote, in rank order
    local r
    for ((r = 0; r < $2; r++)); do
        if [ "$1" = vtu ]; then echo "$3_$r.vtu"; elif [ "$2" = 1 ]; then echo "$3.msh";
        else echo "$3_$((r + 1)).msh"; fi
    done
}
out_name() { if [ "$1" = vtu ]; then echo "$2.pvtu"; else echo "$2.msh"; fi; }

# ---- rigs on the 2 x 1 x 1 box; vertex 0 is (0 0 1), vertex 6 is (2 1 1):
# on the first and the last piece --------------------------------------------
cat >lattice.json <<'EOF'
{"version": 1, "deformer": "lattice", "basis": "bspline", "resolution": [4, 3, 3], "box": "auto",
 "margin": 0.05, "moves": [{"index": [3, 1, 1], "delta": [0.3, 0.1, 0]}],
 "constraints": [{"vertex": 0, "target": [-0.05, 0.02, 1.03]},
                 {"vertex": 6, "target": [2.1, 1.05, 1.0]}]}
EOF
cat >bernstein.json <<'EOF'
{"version": 1, "deformer": "lattice", "basis": "bernstein", "resolution": [3, 3, 3], "box": "auto",
 "margin": 0.1, "moves": [{"index": [2, 1, 1], "delta": [0.3, 0, 0]},
                          {"index": [1, 2, 1], "delta": [0, 0.2, 0.1]}]}
EOF
cat >cylinder.json <<'EOF'
{"version": 1, "deformer": "lattice", "basis": "catmull-rom", "coordinates": "cylindrical",
 "frame": {"centre": [0, 0.5, 0.5], "axis": [1, 0, 0], "reference": [0, 1, 0], "r": [0, 0.8],
           "theta": [0, 6.283185307179586], "z": [-0.1, 2.1]},
 "resolution": [3, 8, 5], "moves": [{"index": [2, 2, 3], "delta": [0, 0, 0.1]}],
 "constraints": [{"vertex": 6, "target": [2.0, 1.05, 1.02]}]}
EOF
cat >nested.json <<'EOF'
{"version": 1, "deformer": "lattice", "basis": "bspline", "resolution": [4, 4, 4],
 "box": {"origin": [-0.1, -0.1, -0.1], "axes": [[2.2, 0, 0], [0, 1.2, 0], [0, 0, 1.2]]},
 "moves": [{"index": [3, 3, 3], "delta": [0.1, 0.1, 0.1]}],
 "children": [{"box": {"origin": [1.2, 0.2, 0.2], "axes": [[0.7, 0, 0], [0, 0.6, 0], [0, 0, 0.6]]},
               "resolution": [4, 4, 4], "moves": [{"index": [1, 1, 1], "delta": [0.05, 0, 0]}]}]}
EOF
points='"control_points": [[-0.5, -0.5, -0.5], [2.5, -0.5, -0.5], [-0.5, 1.5, -0.5], [2.5, 1.5, -0.5],
   [-0.5, -0.5, 1.5], [2.5, -0.5, 1.5], [-0.5, 1.5, 1.5], [2.5, 1.5, 1.5], [1, 0.5, 0.5]]'
cat >rbf.json <<EOF
{"version": 1, "deformer": "rbf", "kernel": "gaussian_spline", "radius": 1, $points,
 "constraints": [{"vertex": 0, "target": [-0.05, 0.02, 1.03]}, {"vertex": 6, "target": [2.1, 1.05, 1.0]}]}
EOF
cat >idw.json <<EOF
{"version": 1, "deformer": "idw", "power": 2, $points, "moves": [{"index": 8, "delta": [0.1, 0.2, 0]}]}
EOF
cat >cage.obj <<'EOF'
v -0.5 -0.5 -0.5
v 2.5 -0.5 -0.5
v 2.5 1.5 -0.5
v -0.5 1.5 -0.5
v -0.5 -0.5 1.5
v 2.5 -0.5 1.5
v 2.5 1.5 1.5
v -0.5 1.5 1.5
f 1 3 2
f 1 4 3
f 5 6 7
f 5 7 8
f 1 2 6
f 1 6 5
f 2 3 7
f 2 7 6
f 3 4 8
f 3 8 7
f 4 1 5
f 4 5 8
EOF
cat >cage.json <<'EOF'
{"version": 1, "deformer": "cage", "cage": "cage.obj", "coordinates": "mean_value",
 "moves": [{"index": 6, "delta": [0.3, 0.2, 0.1]}, {"index": 1, "delta": [0.1, 0, -0.1]}]}
EOF
cat >kelvinlet.json <<'EOF'
{"version": 1, "deformer": "kelvinlet", "poisson_ratio": 0.45,
 "brushes": [{"type": "grab", "center": [1, 0.5, 0.5], "radius": 0.5, "displacement": [0.1, 0.05, 0]},
             {"type": "twist", "center": [1.6, 0.5, 0.5], "radius": 0.4, "axis": [1, 0, 0], "angle": 0.3}],
 "constraints": [{"vertex": 0, "target": [0.02, 0.01, 1.0]}]}
EOF
# PB-FFD with given controls: placed once here, then moved
"$ffd" pbffd place "$box" -o placed.json --interior 6 --exterior 12 >/dev/null 2>&1 &&
python3 - <<'EOF' || fail "PB-FFD controls file"
import json
rig = json.load(open("placed.json"))
rig["moves"] = [{"control": 2, "delta": [0.1, 0.05, 0]}, {"control": 7, "delta": [0, 0, 0.08]}]
rig["constraints"] = [{"vertex": 6, "target": [2.05, 1.0, 1.0]}]
json.dump(rig, open("pbffd_controls.json", "w"))
EOF
# GFFD without resampling: a bar's field turned about the box's axis
cat >gffd.json <<'EOF'
{"version": 1, "deformer": "gffd",
 "skeleton": [{"type": "polyline", "vertices": [[0.2, 0.5, 0.5], [1.8, 0.5, 0.5]], "radius": 0.6}],
 "tracking": "warp",
 "edits": [{"primitive": 0, "rotate": {"axis": [1, 0, 0], "angle": 0.3}, "center": [1, 0.5, 0.5]}]}
EOF
# the methods that read the surface
cat >pbffd_place.json <<'EOF'
{"version": 1, "deformer": "pbffd", "controls": {"interior": 6, "exterior": 12},
 "moves": [{"near": [2, 1, 1], "delta": [0.1, 0.1, 0]}]}
EOF
cat >tspline.json <<'EOF'
{"version": 1, "deformer": "tspline", "resolution": [5, 4, 4],
 "steps": [{"deform": {"freeze": [{"box": {"min": [-9, -9, -9], "max": [0.5, 9, 9]}}],
                       "handles": [{"box": {"min": [1.6, -9, -9], "max": [9, 9, 9]},
                                    "delta": [0.2, 0.1, 0]}]}}]}
EOF

# compare NAME REF OUTPUT-FILES...: the union of the pieces against REF
compare() {
    local name=$1 ref=$2
    shift 2
    if "$cmp" --rest "$box" "$ref" "$@" 2>cmp.err; then pass "$name"; else
        fail "$name"; cat cmp.err; fi
}
# deform_case NAME RIG F NP REF: ffd-mpi on NP ranks of format F against REF
deform_case() {
    local name=$1 rig=$2 f=$3 np=$4 ref=$5 out
    out=out_${name}_${f}_np$np
    if ! run "$np" "$(parts "$f" "$np")" -o "$(out_name "$f" "$out")" --rig "$rig"; then
        fail "$name $f np=$np failed"
        cat run.err
        return
    fi
    # shellcheck disable=SC2046
    compare "$name $f np=$np" "$ref" $(out_pieces "$f" "$np" "$out")
    if [ "$f" = vtu ]; then # the index names the written pieces, in order
        local want got
        want=$(out_pieces vtu "$np" "$out" | tr '\n' ' ')
        got=$(grep -o 'Source="[^"]*"' "$out.pvtu" | sed 's/Source="//; s/"//' | tr '\n' ' ')
        [ "$want" = "$got" ] || fail "$name: $out.pvtu names '$got', expected '$want'"
    fi
    ls ./*.tmp* >/dev/null 2>&1 && fail "$name: temporary files left: $(ls ./*.tmp*)"
}

# ---- every linear method, and GFFD: against `ffd deform` of the whole mesh --
if [ "$group" = all ] || [ "$group" = methods ]; then
    i=0
    for rig in lattice bernstein cylinder nested rbf idw cage kelvinlet pbffd_controls gffd; do
        [ -f $rig.json ] || continue
        if ! "$ffd" deform "$box" -o ref_$rig.msh --rig $rig.json 2>ffd.err; then
            fail "ffd deform $rig"
            cat ffd.err
            continue
        fi
        for np in 1 2 3 4; do
            # the formats alternate, so that each meets each rank count
            if [ $(((i + np) % 2)) = 0 ]; then f=vtu; else f=msh; fi
            deform_case "$rig" $rig.json $f $np ref_$rig.msh
        done
        i=$((i + 1))
    done
fi

# ---- PB-FFD placement and the T-spline: they read the boundary surface,
# which the ranks gather in a canonical order; against `ffd deform` too -----
if [ "$group" = all ] || [ "$group" = surface ]; then
    for rig in pbffd_place tspline; do
        if ! "$ffd" deform "$box" -o ref_$rig.msh --rig $rig.json 2>ffd.err; then
            fail "ffd deform $rig"
            cat ffd.err
            continue
        fi
        for np in 1 2 3 4; do
            if [ $((np % 2)) = 0 ]; then f=vtu; else f=msh; fi
            deform_case "$rig" $rig.json $f $np ref_$rig.msh
        done
    done
fi

# ---- formats: an empty piece, patterns with and without global ids --------
if [ "$group" = all ] || [ "$group" = formats ]; then
    "$ffd" deform "$box" -o ref_lattice.msh --rig lattice.json 2>/dev/null
    # rank 1 holds no points and no cells
    if run 3 vtu3e/box.pvtu -o out_empty.pvtu --rig lattice.json; then
        compare "empty piece on rank 1" ref_lattice.msh out_empty_0.vtu out_empty_1.vtu out_empty_2.vtu
    else
        fail "empty piece failed"
        cat run.err
    fi
    # Gmsh's default split pieces: MSH 4.1 with $PartitionedEntities, ascii and binary
    for set in 41_p3:3 41bin_p2:2; do
        name=${set%%:*} np=${set##*:}
        if run "$np" "$data/mpi_box_$name.msh" -o "out_$name.msh" --rig lattice.json; then
            # shellcheck disable=SC2046
            compare "Gmsh MSH 4.1 pieces ($name)" ref_lattice.msh $(out_pieces msh "$np" "out_$name")
        else
            fail "Gmsh MSH 4.1 pieces ($name) failed"
            cat run.err
        fi
    done
    # the bunny as OBJ pieces with "#GlobalNodeID" lines; constraints on vertices of different pieces
    bunny=$src/examples/lattice/bunny.obj
    python3 "$src/tests/mpi/make_partitions.py" obj "$bunny" bunny3 3 || exit 1
    sed "s/bunny-cage.obj/${src//\//\\/}\/examples\/cage\/bunny-cage.obj/" \
        "$src/examples/cage/bunny-mvc.json" >bunny_cage.json
    for rig in "$src/examples/rbf/bunny-pins.json" bunny_cage.json; do
        "$ffd" deform "$bunny" -o ref_bunny.obj --rig "$rig" 2>/dev/null
        if run 3 'bunny3/piece_%d.obj' -o 'out_bunny_%d.obj' --rig "$rig"; then
            "$cmp" --rest "$bunny" ref_bunny.obj out_bunny_0.obj out_bunny_1.obj out_bunny_2.obj \
                2>cmp.err && pass "OBJ pattern, $(basename "$rig")" ||
                { fail "OBJ pattern, $(basename "$rig")"; cat cmp.err; }
        else
            fail "OBJ pattern $(basename "$rig") failed"
            cat run.err
        fi
    done
    # a point set cut in contiguous ranges, no ids: rank-major order
    points_file=$src/data/volume/bunny_points.xyz
    python3 "$src/tests/mpi/make_partitions.py" xyz "$points_file" pts2 2 || exit 1
    "$ffd" deform "$points_file" -o ref_points.xyz --rig "$src/examples/idw/bunny-ears.json" 2>/dev/null
    if run 2 'pts2/points_%d.xyz' -o 'out_points_%02d.xyz' --rig "$src/examples/idw/bunny-ears.json"; then
        "$cmp" --rest "$points_file" ref_points.xyz out_points_00.xyz out_points_01.xyz 2>cmp.err &&
            pass "XYZ pattern, rank-major" || { fail "XYZ pattern"; cat cmp.err; }
        grep -q "rank-major" run.err || fail "XYZ pattern: no note on rank-major numbering"
    else
        fail "XYZ pattern failed"
        cat run.err
    fi
    # --report: one JSON line, from rank 0, with the distributed details and the
    # inversions; its constraints (residuals, reached points), controls and the
    # inversion counts of the cells are those of `ffd deform --report`, to the bit
    "$ffd" deform "$box" -o ref_report.msh --rig lattice.json --report >ref_report.json 2>/dev/null
    if run 4 vtu4/box.pvtu -o out_report.pvtu --rig lattice.json --report; then
        if [ "$(wc -l <run.out)" = 1 ] && python3 - ref_report.json run.out <<'EOF'
import json, sys
one, many = (json.load(open(p)) for p in sys.argv[1:3])
keys = ("constraints", "max_residual", "controls", "method")
diff = [k for k in keys if one[k] != many[k]]
inv = ("cells_checked", "inverted", "worst_det", "worst_scaled_jacobian", "flipped_faces")
diff += ["inversions." + k for k in inv if one["inversions"][k] != many["inversions"][k]]
if "distributed" not in many or many["distributed"]["ranks"] != 4:
    diff.append("distributed")
if diff:
    sys.exit("differ from ffd deform --report: " + ", ".join(diff))
EOF
        then pass "--report equals ffd deform's"; else fail "--report"; cat run.out; fi
    else
        fail "--report failed"
        cat run.err
    fi
fi

# ---- errors: every rank exits 1 with the message, nothing written ---------
# error_case NAME PATTERN NP ARGS...: exit 1 (not the timeout's 124), the
# message once, no output file
error_case() {
    local name=$1 pattern=$2 np=$3
    shift 3
    rm -rf errout && mkdir errout
    run "$np" "$@"
    local code=$?
    if [ $code = 124 ] || [ $code = 137 ]; then
        fail "$name: timed out (a rank hung)"
    elif [ $code = 0 ]; then
        fail "$name: exit 0"
    elif ! grep -q -- "$pattern" run.err; then
        fail "$name: stderr lacks '$pattern'"
        cat run.err
    elif [ "$(grep -c "^ffd-mpi: " run.err)" != 1 ]; then
        fail "$name: the message is not printed once"
        cat run.err
    elif [ -n "$(ls -A errout)" ]; then
        fail "$name: files written: $(ls -A errout)"
    else
        pass "$name: $(head -1 run.err)"
    fi
}
if [ "$group" = all ] || [ "$group" = errors ]; then
    mkdir -p bad && cp vtu3/* bad/
    # rank 1's piece is corrupt: a tag cut short at byte 40
    head -c 40 vtu3/box_1.vtu >bad/box_1.vtu
    error_case "corrupt piece" "rank 1: bad/box_1.vtu" 3 bad/box.pvtu -o errout/o.pvtu --rig lattice.json
    rm bad/box_2.vtu
    error_case "missing piece" "rank 1: bad/box_1.vtu" 3 bad/box.pvtu -o errout/o.pvtu --rig lattice.json
    cp vtu3/box_1.vtu bad/box_1.vtu
    error_case "missing piece on the last rank" "rank 2: bad/box_2.vtu" 3 bad/box.pvtu \
        -o errout/o.pvtu --rig lattice.json
    error_case "pieces != ranks (pvtu)" "names 3 pieces but the run has 2 ranks" 2 vtu3/box.pvtu \
        -o errout/o.pvtu --rig lattice.json
    error_case "pieces != ranks (msh)" "has 3 pieces" 4 "$data/mpi_box_p3.msh" -o errout/o.msh \
        --rig lattice.json
    error_case "a bad rig" "nope.json" 2 vtu2/box.pvtu -o errout/o.pvtu --rig nope.json
    sed "s/head.off/${src//\//\\/}\/examples\/gffd\/head.off/" "$src/examples/gffd/twist.json" >twist.json
    python3 "$src/tests/mpi/make_partitions.py" obj "$src/examples/gffd/bunny.obj" gbunny 2 || exit 1
    error_case "GFFD resampling" "resampl" 2 'gbunny/piece_%d.obj' -o 'errout/o_%d.obj' --rig twist.json
    # rank 1 cannot write (its directory is missing): rank 0's finished piece goes too
    rm -rf wr && mkdir -p wr/d0
    python3 "$src/tests/mpi/make_partitions.py" xyz "$src/data/volume/bunny_points.xyz" pts2 2 || exit 1
    run 2 'pts2/points_%d.xyz' -o 'wr/d%d/o.xyz' --rig "$src/examples/idw/bunny-ears.json"
    code=$?
    if [ $code = 0 ] || [ $code = 124 ] || [ $code = 137 ]; then
        fail "a rank that cannot write: exit $code"
    elif ! grep -q "rank 1: wr/d1/o.xyz: No such file or directory" run.err; then
        fail "a rank that cannot write: stderr"
        cat run.err
    elif [ -n "$(ls -A wr/d0)" ]; then
        fail "a rank that cannot write: rank 0 left $(ls -A wr/d0)"
    else
        pass "a rank that cannot write: $(grep 'rank 1:' run.err)"
    fi
    cat >invert.json <<'EOF'
{"version": 1, "deformer": "lattice", "basis": "bernstein", "resolution": [2, 2, 2], "box": "auto",
 "moves": [{"index": [1, 1, 1], "delta": [-4, -4, -4]}]}
EOF
    error_case "--fail-on-inversion" "nothing written (--fail-on-inversion)" 3 vtu3/box.pvtu \
        -o errout/o.pvtu --rig invert.json --fail-on-inversion
fi

echo "test_mpi ($group): $failures failure(s)"
[ $failures = 0 ]
