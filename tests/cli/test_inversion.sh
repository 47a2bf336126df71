#!/usr/bin/env bash
# Inverted cells and flipped faces in `ffd deform` (docs/volume.md,
# "Inverted cells and fold-overs"): --report's "inversions" and "folds"
# objects, and --fail-on-inversion, which exits 1 writing nothing. The
# meshes are surfaces (the volume codecs land on other branches: the cell
# checks themselves are tested in tests/test_quality.c).
# usage: bash test_inversion.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

cube=$SRC/tests/bad/inversion-fail/cube.obj
mirror=$SRC/tests/bad/inversion-fail/mirror.json
cat >"$T/rest.json" <<'JSON'
{"version": 1, "deformer": "lattice", "basis": "bspline", "resolution": [4, 4, 4], "box": "auto"}
JSON

# at rest: nothing inverted, nothing flipped, nothing folded
ok deform "$cube" -o "$T/rest.obj" --rig "$T/rest.json" --report
has stdout '"inversions": {"cells_checked": 0, "inverted": 0, "worst_det": null'
has stdout '"faces_checked": 6, "flipped_faces": 0, "face_ids": []'
has stdout '"folds": {"cells": "lattice cell", "cells_checked": 125, "samples": 15625, "folded": 0, "min_det": 1'
cmp -s "$cube" "$T/rest.obj" || fail "the identity rig changed the cube"

# the mirror: four faces flip (the +-x faces keep their normals), the one lattice cell folds
ok deform "$cube" -o "$T/mirror.obj" --rig "$mirror" --report
has stdout '"flipped_faces": 4, "face_ids": [0, 1, 2, 4]'
has stdout '"folded": 1, "min_det": -1, "cell_ids": [0]'
# --fail-on-inversion: exit 1, the message names the count, nothing written
echo "old bytes" >"$T/out.obj"
bad 1 deform "$cube" -o "$T/out.obj" --rig "$mirror" --fail-on-inversion
has stderr '4 faces flipped (the first: face 0): nothing written (--fail-on-inversion)'
[ "$(cat "$T/out.obj")" = "old bytes" ] || fail "--fail-on-inversion changed the output"
bad 1 deform "$cube" -o "$T/new.obj" --rig "$mirror" --fail-on-inversion --report
[ -e "$T/new.obj" ] && fail "--fail-on-inversion wrote $T/new.obj"
[ -s "$T/stdout" ] && fail "--fail-on-inversion printed a report: $(cat "$T/stdout")"
# without a fold: --fail-on-inversion writes as usual
ok deform "$cube" -o "$T/rest2.obj" --rig "$T/rest.json" --fail-on-inversion
cmp -s "$cube" "$T/rest2.obj" || fail "--fail-on-inversion changed an unfolded result"

[ "$failures" -eq 0 ] && echo "ok: test_inversion" && exit 0
echo "$failures failure(s)"
exit 1
