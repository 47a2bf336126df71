#!/usr/bin/env bash
# T-spline rigs from the command line: `ffd tspline proxy` writes a closed
# proxy (and the T-lattice) for a resolution or a rig; usage errors exit 2,
# other failures exit 1 with a message and write nothing; `ffd deform` with
# a "tspline" rig prints the T-spline report fields and writes --proxy-out and
# --lattice-out; every rig in examples/tspline/ runs on its mesh without a
# fold-over warning and changes it; inputs are never modified.
# usage: bash test_tspline.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
case $FFD in /*) ;; *) FFD=$(cd "$(dirname "$FFD")" && pwd)/$(basename "$FFD") ;; esac
BUNNY=$SRC/data/bunny.obj
[ -f "$BUNNY" ] || { echo "FAIL: missing test mesh $BUNNY"; exit 1; }

# field FILE KEY: the number after "KEY": in FILE (first occurrence)
field() {
    sed -n -e "s/.*\"$2\": \([-0-9.eE+]*\).*/\1/p" "$1" | head -n 1
}
info() { # info MESH: ffd info --json MESH into $T/info
    "$FFD" info --json "$1" >"$T/info" 2>&1 || fail "ffd info $1: $(cat "$T/info")"
}
sanitizer_clean() { # sanitizer_clean FILE NAME
    grep -q -e 'Sanitizer' -e 'runtime error' "$1" && fail "$2: $(cat "$1")"
}
bunny_sum=$(cksum <"$BUNNY")

# ---- ffd tspline proxy ----
check_proxy() { # check_proxy NAME PROXY REPORT: closed, counts as reported
    info "$2"
    grep -qF '"closed": true' "$T/info" || fail "$1: the proxy is not closed: $(cat "$T/info")"
    grep -qF '"boundary_edges": 0,' "$T/info" || fail "$1: the proxy has boundary edges: $(cat "$T/info")"
    [ "$(field "$T/info" vertices)" = "$(field "$3" proxy_points)" ] ||
        fail "$1: proxy vertices $(field "$T/info" vertices) != proxy_points in $(cat "$3")"
    [ "$(field "$T/info" faces)" = "$(field "$3" proxy_faces)" ] ||
        fail "$1: proxy faces $(field "$T/info" faces) != proxy_faces in $(cat "$3")"
    # a closed, outward 2-manifold (docs/tspline.md: touching sheets are split)
    grep -qF '"nonmanifold_edges": 0,' "$T/info" || fail "$1: the proxy is not manifold: $(cat "$T/info")"
    manifold "$2" >"$T/manifold" || fail "$1: $(cat "$T/manifold")"
    awk '{ exit !($5 > 0) }' "$T/manifold" || fail "$1: the proxy points inwards: $(cat "$T/manifold")"
}
# manifold PROXY: checks that the OBJ polygon mesh is a closed, consistently
# oriented 2-manifold (every directed edge once and its reverse once, so
# every edge has two faces; the corners at every vertex form one fan, a
# single cycle of prev -> next links) and prints "V E F CHI VOLUME" (the
# signed volume: > 0 when the faces point outwards); exits 1 otherwise
manifold() {
    awk '
    /^v / { nv++; x[nv] = $2; y[nv] = $3; z[nv] = $4 }
    /^f / {
        nf++; n = NF - 1
        for (i = 2; i <= NF; i++) { split($i, a, "/"); c[i - 1] = a[1] + 0 }
        for (i = 1; i <= n; i++) {
            p = c[i]; q = c[i % n + 1]; r = c[(i + n - 2) % n + 1]
            if (p == q) bad = bad " repeated-corner:" nf
            d[p " " q]++
            u[p < q ? p " " q : q " " p]++
            corners[p]++; if (!(p in first)) first[p] = r
            if ((p, r) in link) bad = bad " two-corners-after:" p "," r
            link[p, r] = q
        }
        for (i = 2; i + 1 <= n; i++) { # fan triangles: signed volume
            a0 = c[1]; a1 = c[i]; a2 = c[i + 1]
            vol += (x[a0] * (y[a1] * z[a2] - z[a1] * y[a2]) - y[a0] * (x[a1] * z[a2] - z[a1] * x[a2]) \
                    + z[a0] * (x[a1] * y[a2] - y[a1] * x[a2])) / 6
        }
    }
    END {
        for (k in d) { if (d[k] != 1) bad = bad " directed-edge-twice:" k
                       split(k, e, " "); if (!((e[2] " " e[1]) in d)) bad = bad " no-reverse:" k }
        for (k in u) { ne++; if (u[k] != 2) bad = bad " edge-faces:" k "=" u[k] }
        for (p in corners) { # one fan: follow the links from the first corner
            s = first[p]; t = s; steps = 0
            do { if (!((p, t) in link)) break; t = link[p, t]; steps++ } while (t != s && steps <= corners[p])
            if (t != s || steps != corners[p]) bad = bad " not-one-fan:" p
        }
        if (bad != "") { print "not a closed oriented manifold:" substr(bad, 1, 400); exit 1 }
        printf "%d %d %d %d %.12g\n", nv, ne, nf, nv - ne + nf, vol
    }' "$1"
}
check_lattice() { # check_lattice NAME LATTICE CONTROLS EDGES
    [ "$(grep -c '^v ' "$2")" -eq "$3" ] || fail "$1: $(grep -c '^v ' "$2") v lines, expected $3"
    [ "$(grep -c '^l ' "$2")" -eq "$4" ] || fail "$1: $(grep -c '^l ' "$2") l lines, expected $4"
    [ "$(grep -cv -e '^v ' -e '^l ' -e '^#' "$2")" -eq 0 ] || fail "$1: the lattice has other lines"
}

ok tspline proxy "$BUNNY" -o "$T/p0.obj" --report
cp "$T/stdout" "$T/p0.report"
sanitizer_clean "$T/stderr" default
has stderr "wrote $T/p0.obj (proxy: "
for key in '"control_points": 216' '"cells": 125' '"edges": 540' '"proxy_points": ' \
    '"proxy_faces": ' '"refinements": 0' '"added_points": 0' '"max_weight_deviation": 0'; do
    grep -qF "$key" "$T/p0.report" || fail "default: the report lacks $key: $(cat "$T/p0.report")"
done
check_proxy default "$T/p0.obj" "$T/p0.report"

# cells that share only an edge or a vertex (tests/data/tspline-contacts.obj:
# four cubes in the cells (0,0,0), (1,1,0), (2,2,1), (1,1,2) of a 3x3x3
# lattice): the proxy is four separate cubes, the 28 control points on them
# written once per sheet, 32 points in all, V - E + F = 8 (four spheres),
# volume 4 (each cube a unit cell of the [0,3]^3 box)
CONTACTS=$SRC/tests/data/tspline-contacts.obj
ok tspline proxy "$CONTACTS" --resolution 4 -o "$T/contacts.obj" --report
cp "$T/stdout" "$T/contacts.report"
check_proxy contacts "$T/contacts.obj" "$T/contacts.report"
[ "$(cat "$T/manifold")" = "32 48 24 8 4" ] || fail "contacts: V E F chi volume $(cat "$T/manifold")"
has contacts.report '"proxy_points": 32'
grep -qF '"welded_vertices": 28,' "$T/info" || fail "contacts: not 28 distinct positions: $(cat "$T/info")"
# ffd deform --proxy-out writes the same manifold proxy (a rig that moves nothing)
printf '{"deformer": "tspline", "resolution": [4, 4, 4]}' >"$T/contacts.json"
ok deform "$CONTACTS" -o "$T/contacts.out.obj" --rig "$T/contacts.json" --report \
    --proxy-out "$T/contacts.proxy.obj"
cp "$T/stdout" "$T/contacts.deform.report"
check_proxy "contacts deform" "$T/contacts.proxy.obj" "$T/contacts.deform.report"
cmp -s "$T/contacts.obj" "$T/contacts.proxy.obj" || fail "contacts: --proxy-out differs from tspline proxy"

ok tspline proxy "$BUNNY" --resolution 6,7,5 --output "$T/p1.obj" --lattice "$T/l1.obj" --report
cp "$T/stdout" "$T/p1.report"
has p1.report '"control_points": 210'
has p1.report '"cells": 120'
check_proxy "6,7,5" "$T/p1.obj" "$T/p1.report"
check_lattice "6,7,5" "$T/l1.obj" 210 "$(field "$T/p1.report" edges)"
# 6*7*5 points: 5*7*5 + 6*6*5 + 6*7*4 edges
[ "$(field "$T/p1.report" edges)" = $((5 * 7 * 5 + 6 * 6 * 5 + 6 * 7 * 4)) ] ||
    fail "6,7,5: $(field "$T/p1.report" edges) edges"

ok tspline proxy "$BUNNY" --resolution 7 -o "$T/p2.obj" --report
has stdout '"control_points": 343'

# --rig with a refinement step
printf '{"deformer": "tspline", "resolution": [6, 7, 5], "steps": [{"refine": [{"cells": "proxy"}]}]}' >"$T/refine.json"
ok tspline proxy "$BUNNY" -r "$T/refine.json" -o "$T/p3.obj" --lattice "$T/l3.obj" --report
cp "$T/stdout" "$T/p3.report"
has p3.report '"refinements": 1'
added=$(field "$T/p3.report" added_points)
[ "${added:-0}" -gt 0 ] || fail "refine: added_points '$added'"
[ "$(field "$T/p3.report" control_points)" = $((210 + added)) ] || fail "refine: control_points != 210 + $added"
check_proxy refine "$T/p3.obj" "$T/p3.report"
check_lattice refine "$T/l3.obj" "$(field "$T/p3.report" control_points)" "$(field "$T/p3.report" edges)"
[ "$(field "$T/p3.report" proxy_faces)" -gt "$(field "$T/p1.report" proxy_faces)" ] ||
    fail "refine: the refined proxy has no more faces than the coarse one"
# refinement does not change the map: the proxy of the refined lattice covers the same box
bbox() { # bbox MESH: the six numbers of its box, one a line
    "$FFD" info --json "$1" | sed -n 's/.*"bbox": {"min": \[\(.*\)\], "max": \[\(.*\)\]}}/\1, \2/p' | tr ',' '\n'
}
paste <(bbox "$T/p1.obj") <(bbox "$T/p3.obj") |
    awk 'NF == 2 { n++; d = $1 - $2; if (d * d > 1e-18) bad++ } END { exit !(n == 6 && bad == 0) }' ||
    fail "refine: the proxy's box changed: $(bbox "$T/p1.obj" | tr '\n' ' ') vs $(bbox "$T/p3.obj" | tr '\n' ' ')"
[ "$(cksum <"$BUNNY")" = "$bunny_sum" ] || fail "tspline proxy modified its input"

# ---- usage errors: exit 2, nothing written ----
usage() { # usage FRAGMENT ARGS...
    local fragment=$1
    shift
    rm -f "$T/u.obj" "$T/ul.obj"
    bad 2 "$@"
    has stderr "$fragment"
    sanitizer_clean "$T/stderr" "usage $*"
    [ -e "$T/u.obj" ] && fail "ffd $*: wrote its output"
    [ -e "$T/ul.obj" ] && fail "ffd $*: wrote its lattice"
}
usage "missing -o" tspline proxy "$BUNNY" --lattice "$T/ul.obj"
usage "missing input mesh" tspline proxy -o "$T/u.obj"
usage "--resolution '6,x'" tspline proxy "$BUNNY" -o "$T/u.obj" --resolution 6,x
usage "--resolution '6,7'" tspline proxy "$BUNNY" -o "$T/u.obj" --resolution 6,7
usage "--resolution '6,7,5,4'" tspline proxy "$BUNNY" -o "$T/u.obj" --resolution 6,7,5,4
usage "--resolution ''" tspline proxy "$BUNNY" -o "$T/u.obj" --resolution ''
usage "--resolution '-6'" tspline proxy "$BUNNY" -o "$T/u.obj" --resolution -6
usage "--resolution ' 6'" tspline proxy "$BUNNY" -o "$T/u.obj" --resolution ' 6'
usage "--resolution and --rig" tspline proxy "$BUNNY" -o "$T/u.obj" --resolution 6 --rig "$T/refine.json"
usage "unknown subcommand 'lattice'" tspline lattice "$BUNNY" -o "$T/u.obj"
usage "unknown option '--bogus'" tspline proxy "$BUNNY" -o "$T/u.obj" --bogus
usage "unexpected argument" tspline proxy "$BUNNY" "$BUNNY" -o "$T/u.obj"
usage "" tspline proxy "$BUNNY" -o
bad 2 tspline
has stderr "usage: ffd tspline proxy"
ok tspline --help
has stdout "usage: ffd tspline proxy"
ok tspline proxy --help
has stdout "--resolution L,M,N"

# ---- other failures: exit 1 with a message, nothing written ----
failing() { # failing FRAGMENT ARGS...
    local fragment=$1
    shift
    rm -f "$T/u.obj" "$T/ul.obj"
    bad 1 "$@"
    has stderr "$fragment"
    sanitizer_clean "$T/stderr" "failing $*"
    [ -e "$T/u.obj" ] && fail "ffd $*: wrote its output"
    [ -e "$T/ul.obj" ] && fail "ffd $*: wrote its lattice"
}
# docs/cli.md: a resolution below 4 is exit 1 with a message
failing "resolution[0]: 3: expected 4 to 256 control points" \
    tspline proxy "$BUNNY" -o "$T/u.obj" --lattice "$T/ul.obj" --resolution 3
failing "resolution[1]: 300: expected 4 to 256" tspline proxy "$BUNNY" -o "$T/u.obj" --resolution 6,300,6
printf '{"resolution": [3, 3, 3], "moves": [{"index": [1, 1, 1], "delta": [0, 1, 0]}]}' >"$T/lattice.json"
failing 'not a "tspline" rig' tspline proxy "$BUNNY" -o "$T/u.obj" --lattice "$T/ul.obj" --rig "$T/lattice.json"
printf '{"deformer": "tspline", "resolution": [6, 6, 6], "steps": [{"refine": [{"cell": 9999}]}]}' >"$T/badcell.json"
failing "$T/badcell.json: steps[0].refine: cell 9999: there are 125 cells" \
    tspline proxy "$BUNNY" -o "$T/u.obj" --lattice "$T/ul.obj" --rig "$T/badcell.json"
printf '{"deformer": "tspline", "steps": [{"refine": []}]}' >"$T/badparse.json"
failing "$T/badparse.json: steps[0].refine: expected a non-empty array" \
    tspline proxy "$BUNNY" -o "$T/u.obj" --rig "$T/badparse.json"
failing "$T/nothere.json" tspline proxy "$BUNNY" -o "$T/u.obj" --rig "$T/nothere.json"
failing "$T/nothere.obj" tspline proxy "$T/nothere.obj" -o "$T/u.obj"
printf 'this is not a mesh\n' >"$T/garbage.off"
failing "$T/garbage.off" tspline proxy "$T/garbage.off" -o "$T/u.obj"
printf 'OFF\n0 0 0\n' >"$T/empty.off"
failing "" tspline proxy "$T/empty.off" -o "$T/u.obj"
# an output that cannot be written: exit 1, and no stray files
mkdir -p "$T/out" "$T/out/dir.obj"
bad 1 tspline proxy "$BUNNY" -o "$T/out/dir.obj"
[ "$(ls -A "$T/out")" = dir.obj ] || fail "a failed write left files: $(ls -A "$T/out")"
[ -z "$(ls -A "$T/out/dir.obj")" ] || fail "a failed write left files: $(ls -A "$T/out/dir.obj")"
bad 1 tspline proxy "$BUNNY" -o "$T/out/p.obj" --lattice "$T/out/dir.obj"
[ -z "$(ls -A "$T/out/dir.obj")" ] || fail "a failed lattice write left files: $(ls -A "$T/out/dir.obj")"
[ "$(ls -A "$T/out")" = dir.obj ] || fail "a failed lattice write left files: $(ls -A "$T/out")"
[ "$(cksum <"$BUNNY")" = "$bunny_sum" ] || fail "a failing tspline proxy modified its input"

# ---- ffd deform with a tspline rig ----
cp "$BUNNY" "$T/in.obj"
in_sum=$(cksum <"$T/in.obj")
cat >"$T/drag.json" <<'EOF'
{"deformer": "tspline", "resolution": [6, 7, 5], "steps": [
  {"refine": [{"cells": "proxy"}]},
  {"deform": {"freeze": [{"box": {"min": [-99, -99, -99], "max": [99, 3, 99]}}],
              "handles": [{"near": [0, 10, 0], "delta": [0.5, 0.5, 0]}]}},
  {"constraints": {"targets": [{"vertex": 0, "target": [0, 0, 0]}]}}]}
EOF
ok deform "$T/in.obj" -o "$T/drag.obj" --rig "$T/drag.json" --report \
    --proxy-out "$T/drag.proxy.obj" --lattice-out "$T/drag.lattice.obj"
cp "$T/stdout" "$T/drag.report"
sanitizer_clean "$T/stderr" drag
grep -q 'warning' "$T/stderr" && fail "drag: a warning: $(cat "$T/stderr")"
for key in '"cells": ' '"proxy_points": ' '"proxy_faces": ' '"refinements": 1' '"added_points": ' \
    '"moved_points": ' '"max_weight_deviation": ' '"arap_solves": 1' '"max_handle_error": ' \
    '"folds": {"cells_checked": ' '"min_det": ' '"folded_cells": []' '"inverted_faces": []' \
    '"constraints": [' '"controls": '; do
    grep -qF -- "$key" "$T/drag.report" || fail "drag: the report lacks $key: $(cat "$T/drag.report")"
done
[ "$(wc -l <"$T/drag.report")" -eq 1 ] || fail "drag: the report is not one JSON line"
awk -v r="$(field "$T/drag.report" max_residual)" 'BEGIN { exit !(r < 1e-6) }' ||
    fail "drag: max_residual $(field "$T/drag.report" max_residual)"
[ "$(cksum <"$T/in.obj")" = "$in_sum" ] || fail "drag: the input mesh was modified"
# the proxy: closed, its counts as reported; the lattice: a v per control point, an l per edge
check_proxy drag "$T/drag.proxy.obj" "$T/drag.report"
[ "$(grep -c '^v ' "$T/drag.lattice.obj")" -eq "$(field "$T/drag.report" controls)" ] ||
    fail "drag: --lattice-out v lines != controls"
[ "$(grep -c '^l ' "$T/drag.lattice.obj")" -gt 0 ] || fail "drag: --lattice-out has no edges"
# vertex 0 went to the origin
"$FFD" convert "$T/drag.obj" "$T/drag.copy.obj" >/dev/null 2>&1
grep -m 1 '^v ' "$T/drag.copy.obj" | awk '{ exit !($2^2 + $3^2 + $4^2 < 1e-12) }' ||
    fail "drag: vertex 0 is not at its target: $(grep -m 1 '^v ' "$T/drag.copy.obj")"
# same topology, some vertices moved
diff <(grep -v '^v ' "$T/in.obj") <(grep -v '^v ' "$T/drag.obj") >/dev/null || fail "drag: non-vertex lines changed"
cmp -s "$T/in.obj" "$T/drag.obj" && fail "drag: the mesh did not change"
# --proxy-out with a rig of another deformer: exit 1
rm -f "$T/lat.obj" "$T/lat.proxy.obj"
bad 1 deform "$T/in.obj" -o "$T/lat.obj" --rig "$T/lattice.json" --proxy-out "$T/lat.proxy.obj"
has stderr "only a T-spline rig has a proxy"
[ -e "$T/lat.proxy.obj" ] && fail "a lattice rig wrote a proxy"
# a failing tspline rig writes nothing
rm -f "$T/u.obj" "$T/up.obj"
bad 1 deform "$T/in.obj" -o "$T/u.obj" --rig "$T/badcell.json" --proxy-out "$T/up.obj"
has stderr "$T/badcell.json: steps[0].refine: cell 9999"
[ -e "$T/u.obj" ] && fail "a failing tspline rig wrote the mesh"
[ -e "$T/up.obj" ] && fail "a failing tspline rig wrote the proxy"
[ "$(cksum <"$T/in.obj")" = "$in_sum" ] || fail "a failing deform modified the input mesh"
# an empty rig is (to rounding) the identity
printf '{"deformer": "tspline"}' >"$T/empty.json"
ok deform "$T/in.obj" -o "$T/same.obj" --rig "$T/empty.json" --report
has stdout '"arap_solves": 0'
awk -v d="$(field "$T/stdout" min_det)" 'BEGIN { exit !(d > 1 - 1e-9 && d < 1 + 1e-9) }' ||
    fail "the empty tspline rig: min_det $(field "$T/stdout" min_det)"
paste <(grep '^v ' "$T/in.obj") <(grep '^v ' "$T/same.obj") |
    awk '{ d = ($2-$6)^2 + ($3-$7)^2 + ($4-$8)^2; if (d > 1e-20) bad++ } END { exit bad > 0 }' ||
    fail "the empty tspline rig moved vertices"

# ---- the examples ----
EX=$SRC/examples/tspline
if [ -d "$EX" ]; then
    count=0
    for rig in "$EX"/*.json; do
        [ -e "$rig" ] || continue
        name=$(basename "$rig" .json)
        # the mesh: the .obj/.off named on the rig's row of the README's table
        mesh=$(grep -F "\`$name.json\`" "$EX/README.md" | head -n 1 |
            sed -n 's/^|[^|]*|[^`]*`\([^`]*\.\(obj\|off\)\)`.*/\1/p')
        if [ -z "$mesh" ] || [ ! -f "$EX/$mesh" ]; then
            fail "$name: no mesh for it in $EX/README.md ('$mesh')"
            continue
        fi
        count=$((count + 1))
        ext=${mesh##*.}
        sum=$(cksum <"$EX/$mesh")
        out=$T/ex-$name.$ext
        if ! "$FFD" deform "$EX/$mesh" -o "$out" --rig "$rig" --report \
            --proxy-out "$T/ex-$name.proxy.obj" --lattice-out "$T/ex-$name.lattice.obj" \
            >"$T/ex-$name.report" 2>"$T/ex-$name.err"; then
            fail "$name: ffd deform failed: $(cat "$T/ex-$name.err")"
            continue
        fi
        sanitizer_clean "$T/ex-$name.err" "$name"
        grep -q 'warning' "$T/ex-$name.err" && fail "$name: $(cat "$T/ex-$name.err")"
        grep -qF '"folded_cells": [], "inverted_faces": []' "$T/ex-$name.report" ||
            fail "$name: the map folds: $(cat "$T/ex-$name.report")"
        awk -v d="$(field "$T/ex-$name.report" min_det)" 'BEGIN { exit !(d > 0) }' ||
            fail "$name: min_det $(field "$T/ex-$name.report" min_det)"
        solves=$(field "$T/ex-$name.report" arap_solves)
        [ "${solves:-0}" -ge 1 ] || fail "$name: no deform step ran"
        [ "$(cksum <"$EX/$mesh")" = "$sum" ] || fail "$name: the input mesh was modified"
        cmp -s "$EX/$mesh" "$out" && fail "$name: the mesh did not change"
        info "$out"
        [ "$(field "$T/info" vertices)" = "$(ffd_vertices=$("$FFD" info --json "$EX/$mesh") &&
            echo "$ffd_vertices" | sed -n -e 's/.*"vertices": \([0-9]*\),.*/\1/p')" ] ||
            fail "$name: the vertex count changed"
        info "$T/ex-$name.proxy.obj"
        grep -qF '"closed": true' "$T/info" || fail "$name: the proxy is not closed"
        # ffd tspline proxy with the rig gives the same proxy as deform --proxy-out
        if "$FFD" tspline proxy "$EX/$mesh" -o "$T/ex-$name.proxy2.obj" --rig "$rig" \
            >/dev/null 2>"$T/ex-$name.err2"; then
            cmp -s "$T/ex-$name.proxy.obj" "$T/ex-$name.proxy2.obj" ||
                fail "$name: tspline proxy --rig and deform --proxy-out differ"
        else
            fail "$name: ffd tspline proxy --rig failed: $(cat "$T/ex-$name.err2")"
        fi
    done
    [ "$count" -ge 3 ] || fail "examples/tspline holds $count rigs, expected at least 3"
fi

# A map that folds: the report's details (nested objects and arrays) and the
# method's warning are printed without the CLI knowing the method.
printf '{"deformer": "tspline", "resolution": [4, 4, 4], "steps": [{"move": [{"points": [0], "delta": [1000, 1000, 1000]}]}]}\n' >"$T/fold.json"
ok deform "$BUNNY" -o "$T/fold.obj" --rig "$T/fold.json" --report
sanitizer_clean "$T/stderr" fold
has stdout '"controls": 64, "method": "tspline", "cells": 27, '
has stdout '"folds": {"cells_checked": '
grep -qE '"folded_cells": \[[0-9]' "$T/stdout" || fail "fold: no folded cell listed: $(cat "$T/stdout")"
has stderr "ffd: warning: the deformation folds over: "
[ "$(grep -c 'warning' "$T/stderr")" -eq 1 ] || fail "fold: expected one warning: $(cat "$T/stderr")"

if [ "$failures" -ne 0 ]; then
    echo "$failures failure(s)"
    exit 1
fi
echo "all tspline CLI tests passed"
