#!/usr/bin/env bash
# Outputs never alias inputs or each other (docs/cli.md, "Output files"): for
# every output option of every command, an output naming an input (the mesh,
# the rig, a GFFD rig's skeleton file) directly, through a symbolic link or
# through a hard link, or naming another output (same path, ./path, a
# symlinked directory, a dangling link to the other), is refused with exit 2
# and a message naming both options, before any work: the inputs keep their
# bytes and no output appears.
# usage: bash test_outputs.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$1" "$2"
DATA=$SRC/tests/data

W=$T/work
mkdir -p "$W"
cp "$DATA/rig/cube.obj" "$W/cube.obj"
cp "$DATA/rig/pull.json" "$W/pull.json"
printf '{"deformer": "tspline", "resolution": [4, 4, 4]}\n' >"$W/ts.json"
cp "$SRC/examples/gffd/trunk.obj" "$W/trunk.obj"
cat >"$W/gffd.json" <<'EOF'
{"deformer": "gffd", "skeleton": [{"type": "polyline", "file": "trunk.obj", "radius": 0.18}],
 "edits": [{"primitive": 0, "vertex": 2, "move": [-0.02, 0, 0]}]}
EOF
ln -s "$W" "$T/wlink" # a symlinked directory
cd "$W" || exit 1

snapshot() { (cd "$W" && cksum -- * 2>/dev/null); } # every name (links followed) and its bytes
before=$(snapshot)

# refused EXPECT1 EXPECT2 ARGS...: exit 2, both fragments in the message,
# nothing in $W changed and no file appeared.
refused() {
    local e1=$1 e2=$2
    shift 2
    bad 2 "$@"
    has stderr "$e1"
    has stderr "$e2"
    has stderr "is the same file as"
    local now
    now=$(snapshot)
    [ "$now" = "$before" ] || fail "ffd $* changed or created files: $(diff <(echo "$before") <(echo "$now"))"
    # the links made for a case go; the files they name stay
    find "$W" -maxdepth 1 \( -name 'alias*' -o -name 'new*' \) -exec rm -f {} +
    before=$(snapshot)
}

# alias KIND TARGET: a name for TARGET: itself, a symbolic link, a hard link
# (links to the rig end in .obj: an output needs a mesh extension)
alias_of() {
    case $1 in
    direct) echo "$2" ;;
    symlink) ln -sf "$2" "alias_s_${2%.*}.obj" && echo "alias_s_${2%.*}.obj" ;;
    hardlink) ln -f "$2" "alias_h_${2%.*}.obj" && echo "alias_h_${2%.*}.obj" ;;
    esac
}

for kind in direct symlink hardlink; do
    # deform: -o, --lattice-out, --proxy-out against the mesh, the rig, the skeleton file
    for opt in --lattice-out --proxy-out; do
        a=$(alias_of $kind cube.obj)
        before=$(snapshot)
        refused "$opt $a" "the input mesh cube.obj" deform cube.obj -o new.obj --rig ts.json "$opt" "$a"
        a=$(alias_of $kind ts.json)
        before=$(snapshot)
        refused "$opt $a" "--rig ts.json" deform cube.obj -o new.obj --rig ts.json "$opt" "$a"
    done
    for opt in -o --lattice-out; do
        a=$(alias_of $kind trunk.obj)
        before=$(snapshot)
        if [ $opt = -o ]; then
            refused "-o $a" "skeleton file trunk.obj" deform cube.obj -o "$a" --rig gffd.json
        else
            refused "$opt $a" "skeleton file trunk.obj" deform cube.obj -o new.obj --rig gffd.json "$opt" "$a"
        fi
    done
    if [ $kind != direct ]; then # -o IN itself has its own message (pass --in-place)
        a=$(alias_of $kind pull.json)
        before=$(snapshot)
        refused "-o $a" "--rig pull.json" deform cube.obj -o "$a" --rig pull.json
        a=$(alias_of $kind cube.obj)
        before=$(snapshot)
        bad 2 deform cube.obj -o "$a" --rig pull.json
        has stderr "the output is the input file"
        before=$(snapshot)
        bad 2 convert cube.obj "$a"
        has stderr "the output is the input file"
        rm -f alias_*
    fi
    # --in-place: the rewritten mesh is still an input of the other outputs
    a=$(alias_of $kind cube.obj)
    before=$(snapshot)
    refused "--lattice-out $a" "the input mesh (--in-place) cube.obj" \
        deform cube.obj --in-place --rig pull.json --lattice-out "$a"

    # pbffd place: -o and --points against the mesh
    a=$(alias_of $kind cube.obj)
    before=$(snapshot)
    refused "-o $a" "the input mesh cube.obj" pbffd place cube.obj -o "$a"
    a=$(alias_of $kind cube.obj)
    before=$(snapshot)
    refused "--points $a" "the input mesh cube.obj" pbffd place cube.obj -o new.json --points "$a"

    # tspline proxy: -o and --lattice against the mesh and the rig
    for opt in -o --lattice; do
        a=$(alias_of $kind cube.obj)
        before=$(snapshot)
        if [ $opt = -o ]; then
            refused "-o $a" "the input mesh cube.obj" tspline proxy cube.obj -o "$a" --lattice new2.obj
        else
            refused "--lattice $a" "the input mesh cube.obj" tspline proxy cube.obj -o new.obj --lattice "$a"
        fi
        [ $kind = direct ] && continue # -o ts.json: refused for its extension
        a=$(alias_of $kind ts.json)
        before=$(snapshot)
        if [ $opt = -o ]; then
            refused "-o $a" "--rig ts.json" tspline proxy cube.obj -o "$a" --rig ts.json
        else
            refused "--lattice $a" "--rig ts.json" tspline proxy cube.obj -o new.obj --rig ts.json --lattice "$a"
        fi
    done
done

# Two outputs that do not exist yet: the same path, ./path, a symlinked
# directory, a dangling symbolic link to the other.
for form in same dot dirlink dangling; do
    first=new_out.obj
    case $form in
    same) second=new_out.obj ;;
    dot) second=./new_out.obj ;;
    dirlink) second=$T/wlink/new_out.obj ;;
    dangling) ln -s new_out.obj alias_dangling.obj && second=alias_dangling.obj ;;
    esac
    before=$(snapshot)
    [ $form = dangling ] && rm -f alias_dangling.obj && ln -s new_out.obj alias_dangling.obj
    refused "--lattice-out $second" "-o $first" deform cube.obj -o "$first" --rig pull.json --lattice-out "$second"
    [ $form = dangling ] && ln -s new_out.obj alias_dangling.obj
    refused "--proxy-out $second" "-o $first" deform cube.obj -o "$first" --rig ts.json --proxy-out "$second"
    [ $form = dangling ] && ln -s new_out.obj alias_dangling.obj
    refused "--proxy-out $second" "--lattice-out $first" deform cube.obj -o new2.obj --rig ts.json --lattice-out "$first" --proxy-out "$second"
    [ $form = dangling ] && ln -s new_out.obj alias_dangling.obj
    refused "--lattice $second" "-o $first" tspline proxy cube.obj -o "$first" --lattice "$second"
    [ $form = dangling ] && ln -s new_out.obj alias_dangling.obj
    refused "--points $second" "-o $first" pbffd place cube.obj -o "$first" --points "$second"
done
# an existing output file reached twice: hard link
printf 'keep\n' >new_keep.obj
ln -f new_keep.obj alias_keep.obj
before=$(snapshot)
bad 2 deform cube.obj -o new_keep.obj --rig pull.json --lattice-out alias_keep.obj
has stderr "--lattice-out alias_keep.obj is the same file as -o new_keep.obj"
[ "$(cat new_keep.obj)" = keep ] || fail "the output reached twice was written"
rm -f new_keep.obj alias_keep.obj

# Distinct files still work, and in a symlinked directory too.
ok deform cube.obj -o out1.obj --rig ts.json --lattice-out lat1.obj --proxy-out prox1.obj
ok tspline proxy cube.obj -o "$T/wlink/p1.obj" --lattice l1.obj
ok deform cube.obj -o out2.obj --rig gffd.json --lattice-out lat2.obj
cmp -s "$W/trunk.obj" "$SRC/examples/gffd/trunk.obj" || fail "the skeleton file changed"
cmp -s "$W/cube.obj" "$DATA/rig/cube.obj" || fail "the mesh changed"

[ "$failures" -eq 0 ] && echo "cli outputs: all passed"
exit $((failures > 0))
