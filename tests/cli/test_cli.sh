#!/usr/bin/env bash
# The `ffd` command's successful paths: help, version, info (text and JSON),
# convert, deform with --report and --timings, --in-place.
# usage: bash test_cli.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
DATA=$SRC/tests/data/rig


ok --help
has stdout "usage: ffd COMMAND"
has stdout "deform"
# The top-level help and the command messages are built from the CLI's table
# of method commands (tools/cli/cli_methods.c): byte for byte what they were
# when main.c spelled them out.
cat >"$T/help.expected" <<'HELP'
usage: ffd COMMAND [ARGS]
       ffd --help | --version

Free-form deformation of triangle and polygon meshes (OBJ, PLY, OFF, STL).

commands:
  info MESH [--json]                     counts, bounding box and edge topology
  convert IN OUT [--ascii|--binary|--binary-be]
                                         rewrite a mesh in the format of OUT's extension
  deform IN -o OUT --rig RIG [--report] [--timings] [--in-place]
         [--ascii|--binary|--binary-be]  apply a rig (JSON or PyGeM .prm) to a mesh
  sensitivities MESH --rig RIG -o OUT.mtx [--expand]
                                         dX/dP of the deformed vertices (Matrix Market)
  pbffd place MESH -o CONTROLS.json [--interior N] [--exterior N] ...
                                         place PB-FFD control points, write them as a rig
  tspline proxy MESH -o PROXY.obj [--resolution L,M,N] [--rig RIG] [--lattice F]
                                         write the T-spline proxy (and T-lattice) of a mesh
  serve [MESH] [--port N] [--host ADDR] [--root DIR] [--web DIR] [--max-upload MB]
        [--verbose]                      the editor: a local web server, deform in a browser

global options (any command):
  --progress                             progress on stderr as lines when it is not
                                         a terminal (on a terminal: always a bar)
  --quiet                                no notes, warnings or progress bar on stderr
                                         (errors are still printed)

'-' as a mesh or rig file reads standard input or writes standard output;
--format FMT (obj, ply, off, stl, gltf, glb, vtk, vtu, msh, su2, xyz, csv or
npy) names its format (docs/cli.md "Pipes").
Run 'ffd COMMAND --help' for a command's options.
Exit status: 0 success, 1 bad or unreadable input (or a failed write), 2 usage error.
HELP
cmp -s "$T/stdout" "$T/help.expected" || fail "ffd --help differs: $(diff "$T/help.expected" "$T/stdout")"
bad 2
has stderr "ffd: missing command (info, convert, deform, sensitivities, pbffd, tspline, serve)"
bad 2 bogus
has stderr "ffd: unknown command 'bogus' (expected info, convert, deform, sensitivities, pbffd, tspline or serve)"
for c in pbffd tspline; do
    ok "$c" --help
    has stdout "usage: ffd $c"
done
ok --version
has stdout "ffd 0.1.0"
for c in info convert deform; do
    ok "$c" --help
    has stdout "usage: ffd $c"
done

ok info "$DATA/cube.obj"
has stdout "vertices            8"
has stdout "closed"
ok info "$DATA/cube.off" --json
has stdout '"format": "off", "vertices": 8, "faces": 6, "corners": 24'
has stdout '"boundary_edges": 0, "nonmanifold_edges": 0, "closed": true'
has stdout '"bbox": {"min": [0, 0, 0], "max": [1, 1, 1]}'

printf 'OFF\n0 0 0\n' >"$T/empty.off"
ok info --json "$T/empty.off"
has stdout '"vertices": 0, "faces": 0'
has stdout '"bbox": null}'

ok convert "$DATA/cube.off" "$T/cube.obj"
has stderr "wrote $T/cube.obj (8 vertices, 6 faces)"
ok info --json "$T/cube.obj"
has stdout '"format": "obj", "vertices": 8, "faces": 6'
ok convert "$T/cube.obj" "$T/back.off"
ok info --json "$T/back.off"
has stdout '"vertices": 8, "faces": 6, "corners": 24'

cp "$DATA/cube.obj" "$T/same.obj"
ok convert "$T/same.obj" "$T/same.obj" --in-place
cmp -s "$T/same.obj" "$DATA/cube.obj" || fail "convert --in-place to the same format changed the bytes"

ok deform "$DATA/cube.obj" -o "$T/pulled.obj" --rig "$DATA/pull.json" --report --timings
has stdout '{"constraints": [{"index": 0, "residual": '
has stdout '"reached": ['
has stdout '{"index": 2, "residual": '
has stdout '"rank": 3, "outside": 0, "controls": 64, "method": "lattice", "inversions": {"cells_checked": 0, "inverted": 0,'
has stdout '"flipped_faces": 0, "face_ids": []}, "folds": {"cells": "lattice cell", "cells_checked": 125, "samples": 15625, "folded": 0,'
has stderr '{"read": '
has stderr '"bind": '
has stderr '"solve": '
has stderr '"evaluate": '
has stderr '"write": '
has stderr "wrote $T/pulled.obj (8 vertices, 12 faces)"
grep -q '^v 1.2 1.1 1.3' "$T/pulled.obj" || grep -q '^v 1.2000000000000' "$T/pulled.obj" ||
    grep -q '^v 1.19999999999' "$T/pulled.obj" || fail "vertex 6 did not reach its target: $(grep '^v ' "$T/pulled.obj")"
# --rig=RIG and --output=OUT forms, OFF input.
ok deform "$DATA/cube.off" --output="$T/pulled.off" --rig="$DATA/pull.json"
ok info --json "$T/pulled.off"
has stdout '"vertices": 8, "faces": 6'

cp "$DATA/cube.obj" "$T/inplace.obj"
ok deform "$T/inplace.obj" --in-place --rig "$DATA/pull.json"
cmp -s "$T/inplace.obj" "$T/pulled.obj" || fail "--in-place result differs from -o result"
ok deform "$T/pulled.obj" -o "$T/pulled.obj" --in-place --rig "$DATA/pull.json"

echo '{"deformer": "lattice"}' >"$T/identity.json"

# A UTF-8 byte order mark before the first line (issue 14: the first v line
# was lost and every face shifted) is read past and written back; a rig file
# may start with one too.
sed 1d "$DATA/cube.obj" >"$T/plain.obj"
{ printf '\357\273\277'; cat "$T/plain.obj"; } >"$T/bom.obj"
{ printf '\357\273\277'; cat "$DATA/pull.json"; } >"$T/bom.json"
ok info --json "$T/bom.obj"
has stdout '"vertices": 8, "faces": 12'
ok deform "$T/plain.obj" -o "$T/plain_pulled.obj" --rig "$DATA/pull.json"
ok deform "$T/bom.obj" -o "$T/bom_pulled.obj" --rig "$T/bom.json"
{ printf '\357\273\277'; cat "$T/plain_pulled.obj"; } | cmp -s - "$T/bom_pulled.obj" ||
    fail "deforming a mesh with a byte order mark: not the mark and the unmarked result"
ok deform "$T/bom.obj" -o "$T/bom_identity.obj" --rig "$T/identity.json"
cmp -s "$T/bom.obj" "$T/bom_identity.obj" || fail "identity rig changed the bytes of a mesh with a byte order mark"
cp "$T/bom.obj" "$T/bom_same.obj"
ok convert "$T/bom_same.obj" "$T/bom_same.obj" --in-place
cmp -s "$T/bom.obj" "$T/bom_same.obj" || fail "convert --in-place dropped the byte order mark"

# A rig that moves nothing writes every mesh of data/ back byte for byte
# (evaluation adds the zero displacement to each point exactly).
for m in "$SRC"/data/*.obj "$SRC"/data/*.off "$SRC"/data/*.stl; do
    [ -f "$m" ] || { fail "missing test mesh $m"; continue; }
    out="$T/identity_$(basename "$m")"
    ok deform "$m" -o "$out" --rig "$T/identity.json"
    cmp -s "$m" "$out" || fail "identity rig changed the bytes of $(basename "$m")"
done

if [ "$failures" -ne 0 ]; then
    echo "$failures failure(s)"
    exit 1
fi
echo "cli pass"
