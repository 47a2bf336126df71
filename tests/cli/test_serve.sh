#!/usr/bin/env bash
# `ffd serve` over HTTP with curl (docs/editor.md): the printed URL, the API's
# replies and content types, every refusal of "Safety" and "Errors" with its
# HTTP code and JSON message (paths leaving --root by "..", absolute paths and
# symbolic links; bodies over the limits; unknown formats, ops, URLs and
# methods; malformed JSON; missing files), the server still answering with an
# unchanged state after each, concurrent requests, the page's files, atomic
# saves under the root, the --host warning, a taken port, a clean stop on
# SIGTERM; the opened mesh is never modified. Connections: one client
# address holds at most --client-connections (others still get in past 256
# idle ones), silent connections close after --idle-timeout, an ambiguous
# body length (two Content-Length headers) is a 400 that closes the
# connection; GET /api/state answers while a long request holds the session.
# Work is never lost: GET /api/history, POST /api/history/goto, the autosave
# under ROOT/.ffd resumed by a server started again (after SIGKILL), written
# on SIGTERM, kept aside when the mesh changed; a mesh opened again from the
# page starts anew, its earlier session kept aside and resumed by POST
# /api/autosave/resume; --no-autosave writes nothing.
# Raw connections use bash's /dev/tcp and curl --interface 127.0.0.2 (a
# second loopback client address); nothing leaves 127.0.0.0/8.
# The "session" part (a lattice, a drag, undo, rig and mesh round trips) needs
# the real editing session; set FFD_SERVE_STUB=1 to skip it when the library
# is built with a stub session.
# usage: bash test_serve.sh PATH_TO_ffd SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
case $FFD in /*) ;; *) FFD=$(cd "$(dirname "$FFD")" && pwd)/$(basename "$FFD") ;; esac
command -v curl >/dev/null || { echo "FAIL: curl is not installed (scripts/setup.sh)"; exit 1; }

PIDS=()
cleanup() {
    for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null; done
    rm -rf "$T"
}
trap cleanup EXIT

sanitizer_clean() { # sanitizer_clean FILE NAME
    grep -q -e 'Sanitizer' -e 'runtime error' -e 'LeakSanitizer' "$1" && fail "$2: $(cat "$1")"
}

# start NAME ARGS...: runs `ffd serve ARGS` in the background, waits for its
# URL line; sets URL and PID (stdout in $T/NAME.out, stderr in $T/NAME.err).
start() {
    local name=$1
    shift
    "$FFD" serve "$@" >"$T/$name.out" 2>"$T/$name.err" &
    PID=$!
    PIDS+=("$PID")
    URL=
    for _ in $(seq 1 200); do
        URL=$(sed -n 's/^ffd serve: \(http:.*\)$/\1/p' "$T/$name.out")
        URL=${URL%/} # paths below start with '/'
        [ -n "$URL" ] && return 0
        kill -0 "$PID" 2>/dev/null || break
        sleep 0.05
    done
    fail "ffd serve $* did not print its URL: $(cat "$T/$name.out" "$T/$name.err")"
    return 1
}
# stop NAME: SIGTERM, exit status 0, no sanitizer report.
stop() {
    kill -TERM "$PID"
    wait "$PID"
    local rc=$?
    [ "$rc" -eq 0 ] || fail "$1: ffd serve exited $rc after SIGTERM: $(cat "$T/$1.err")"
    sanitizer_clean "$T/$1.err" "$1"
}

# req METHOD PATH [CURL ARGS...]: the reply's body in $T/body, headers in
# $T/headers, status in $CODE.
req() {
    local method=$1 path=$2
    shift 2
    CODE=$(curl -s --max-time 60 -X "$method" -o "$T/body" -D "$T/headers" -w '%{http_code}' \
        "$@" "$URL$path")
}
# expect CODE WORD METHOD PATH [CURL ARGS...]: an error reply with that HTTP
# code and {"error": "...", "status": WORD}.
expect() {
    local code=$1 word=$2 method=$3 path=$4
    shift 4
    req "$method" "$path" "$@"
    if [ "$CODE" != "$code" ]; then
        fail "$method $path $*: HTTP $CODE, expected $code: $(show)"
    elif ! grep -q "^{\"error\":\"[^\"]" "$T/body" || ! grep -qF "\"status\":\"$word\"" "$T/body"; then
        fail "$method $path $*: not an error of status $word: $(show)"
    fi
}
post_json() { # post_json CODE WORD PATH JSON
    expect "$1" "$2" POST "$3" -H 'Content-Type: application/json' --data-binary "$4"
}
show() { head -c 300 "$T/body" | tr -c '[:print:]\n' '.'; } # the reply, printable
has_body() { grep -qF -- "$1" "$T/body" || fail "reply lacks '$1': $(show)"; }
# has_key KEY VALUE: the reply holds "KEY": VALUE (any spacing; VALUE a regex)
has_key() { grep -qE "\"$1\" *: *$2" "$T/body" || fail "reply lacks \"$1\": $2: $(show)"; }
# bbox_close A B: the bounding boxes in two `ffd info --json` outputs agree to 1e-9
bbox_close() {
    paste <(sed 's/.*"bbox"//' "$1" | grep -oE '[-0-9.e+]+') <(sed 's/.*"bbox"//' "$2" | grep -oE '[-0-9.e+]+') |
        awk 'BEGIN { bad = 0; n = 0 } { n++; d = $1 - $2; if (d < 0) d = -d; m = $1 < 0 ? -$1 : $1;
             if (m < 1) m = 1; if (d > 1e-9 * m) bad = 1 } END { exit bad || n != 6 }'
}
has_header() { grep -qiF -- "$1" "$T/headers" || fail "headers lack '$1': $(cat "$T/headers")"; }

# same_state FILE: FILE holds the state saved in $T/state0 (busy_ms aside: a timing)
same_state() {
    local strip='s/"busy_ms" *: *[-0-9.eE+]*//'
    [ "$(sed "$strip" "$1")" = "$(sed "$strip" "$T/state0")" ]
}
# state_same WHAT: after WHAT, the server answers with the state saved in $T/state0.
state_same() {
    req GET /api/state
    [ "$CODE" = 200 ] || { fail "after $1: GET /api/state answered $CODE"; return; }
    same_state "$T/body" || fail "after $1: the state changed: $(cat "$T/body")"
}

# ---- the command line ----
ok serve --help
has stdout "usage: ffd serve"
bad 2 serve --port 70000
bad 2 serve --port abc
bad 2 serve --host not-an-address
bad 2 serve --max-upload 0
bad 2 serve --bogus
bad 2 serve a.obj b.obj
bad 2 serve --client-connections 0
has stderr "--client-connections '0': expected a count, 1 to 256"
bad 2 serve --client-connections 257
bad 2 serve --idle-timeout 0
bad 2 serve --idle-timeout 1.5
has stderr "--idle-timeout '1.5': expected seconds, 1 to 86400"
bad 1 serve "$T/missing.obj" --port 0
has stderr "missing.obj"

# ---- fixtures: a root with a mesh, a rig, subdirectories, links out ----
ROOT=$T/root
OUT=$T/outside
mkdir -p "$ROOT/sub/deeper/deepest" "$ROOT/.hidden" "$ROOT/node_modules" "$OUT" "$T/web/assets"
cp "$SRC/examples/lattice/bunny.obj" "$ROOT/bunny.obj"
cp "$SRC/examples/lattice/bend.json" "$ROOT/bend.json"
cp "$SRC/examples/lattice/bunny.obj" "$ROOT/sub/copy.obj"
cp "$SRC/examples/lattice/bunny.obj" "$ROOT/sub/deeper/two.obj"
cp "$SRC/examples/lattice/bunny.obj" "$ROOT/sub/deeper/deepest/three.obj"
cp "$SRC/examples/lattice/bunny.obj" "$ROOT/.hidden/h.obj"
cp "$SRC/examples/lattice/bunny.obj" "$ROOT/node_modules/n.obj"
cp "$SRC/examples/lattice/bunny.obj" "$OUT/secret.obj"
printf '{"version": 1}\n' >"$OUT/secret.json"
printf '<!doctype html><title>outside</title>\n' >"$OUT/secret.html"
ln -s "$OUT" "$ROOT/out"
ln -s "$OUT/secret.obj" "$ROOT/link.obj"
ln -s "$OUT/secret.json" "$ROOT/link.json"
ln -s "$ROOT/sub/copy.obj" "$ROOT/inside.obj"
printf '<!doctype html><title>ffd</title>\n' >"$T/web/index.html"
printf 'console.log(1);\n' >"$T/web/assets/app.js"
printf 'not served\n' >"$T/web/notes.txt"
ln -s "$OUT/secret.html" "$T/web/leak.html"
BUNNY_SUM=$(cksum <"$ROOT/bunny.obj")
OUT_SUM=$(cd "$OUT" && cat secret.obj secret.json secret.html | cksum)

# 64 connections per client: "concurrent requests" below opens 60 at once
# --no-autosave here and below: the servers on this root start from a bare
# session (the autosave has its own part at the end)
start main "$ROOT/bunny.obj" --port 0 --root "$ROOT" --web "$T/web" --client-connections 64 --no-autosave || exit 1
MAIN_PID=$PID
MAIN_URL=$URL
PORT=${URL##*:}
[ "$(wc -l <"$T/main.out")" -eq 1 ] || fail "stdout is not one line: $(cat "$T/main.out")"
grep -qE '^ffd serve: http://127\.0\.0\.1:[0-9]+/$' "$T/main.out" ||
    fail "URL line: $(cat "$T/main.out")"
[ "$PORT" -gt 0 ] 2>/dev/null || fail "--port 0: no port in $URL"
[ -s "$T/main.err" ] && fail "a quiet server printed on stderr: $(cat "$T/main.err")"

# ---- reading ----
req GET /api/state
[ "$CODE" = 200 ] || fail "GET /api/state: $CODE"
has_header 'Content-Type: application/json'
has_header 'Cache-Control: no-store'
has_body '"revision":'
has_body '"bunny.obj"'
cp "$T/body" "$T/state0"
req GET /api/frame
[ "$CODE" = 200 ] || fail "GET /api/frame: $CODE"
has_header 'Content-Type: application/octet-stream'
[ "$(head -c 4 "$T/body")" = FFDF ] || fail "GET /api/frame: no FFDF magic"
[ "$(stat -c %s "$T/body")" -ge $((20 + 12 * 1839)) ] || fail "GET /api/frame: short frame"
req GET /api/topology
[ "$CODE" = 200 ] || fail "GET /api/topology: $CODE"
[ "$(head -c 4 "$T/body")" = FFDT ] || fail "GET /api/topology: no FFDT magic"
req GET '/api/export?format=ply&encoding=binary'
[ "$CODE" = 200 ] || fail "GET /api/export ply: $CODE $(head -c 200 "$T/body")"
has_header 'Content-Disposition: attachment; filename="bunny-deformed.ply"'
[ "$(head -c 4 "$T/body")" = "$(printf 'ply\n')" ] || fail "GET /api/export ply: not a PLY file"
grep -qaF 'format binary_little_endian' "$T/body" || fail "GET /api/export ply: not binary"
req GET /api/export
[ "$CODE" = 200 ] || fail "GET /api/export: $CODE"
has_header 'filename="bunny-deformed.obj"'
expect 400 invalid GET '/api/export?format=xyz'
expect 400 invalid GET '/api/export?format=stl&encoding=ebcdic'
req GET /api/files
[ "$CODE" = 200 ] || fail "GET /api/files: $CODE"
has_body "\"root\":\"$(cd "$ROOT" && pwd -P)/\""
has_body '"meshes":["bunny.obj","inside.obj","sub/copy.obj","sub/deeper/two.obj"]'
has_body '"rigs":["bend.json"]'
for hidden in h.obj n.obj three.obj secret link.obj link.json; do
    grep -qF "$hidden" "$T/body" && fail "GET /api/files lists $hidden: $(cat "$T/body")"
done

# ---- the page's files ----
req GET /
[ "$CODE" = 200 ] || fail "GET /: $CODE"
has_header 'Content-Type: text/html'
has_header 'Cache-Control: no-store'
has_body '<title>ffd</title>'
req GET /assets/app.js
[ "$CODE" = 200 ] || fail "GET /assets/app.js: $CODE"
has_header 'Content-Type: text/javascript'
expect 404 not_found GET /notes.txt
expect 404 not_found GET /missing.html
expect 403 forbidden GET /leak.html
expect 403 forbidden GET /../outside/secret.html --path-as-is
expect 403 forbidden GET /%2e%2e/outside/secret.html --path-as-is
expect 403 forbidden GET /assets/%2e%2e/%2e%2e/outside/secret.html --path-as-is
expect 403 forbidden GET /%2e%2e%2foutside%2fsecret.html --path-as-is
expect 403 forbidden GET /.hidden --path-as-is
expect 405 method_not_allowed POST / --data-binary x
has_header 'Allow: GET, HEAD'
state_same "the page's files"

# ---- refusals: each leaves the server answering and the state unchanged ----
post_json 403 forbidden /api/open '{"path": "../outside/secret.obj"}'
post_json 403 forbidden /api/open '{"path": "sub/../../outside/secret.obj"}'
post_json 403 forbidden /api/open '{"path": "sub/../bunny.obj"}'
post_json 403 forbidden /api/open "{\"path\": \"$OUT/secret.obj\"}"
post_json 403 forbidden /api/open '{"path": "out/secret.obj"}'
post_json 403 forbidden /api/open '{"path": "link.obj"}'
post_json 403 forbidden /api/open '{"path": ".hidden/h.obj"}'
post_json 403 forbidden /api/open '{"path": "sub\\copy.obj"}'
post_json 404 not_found /api/open '{"path": "missing.obj"}'
post_json 404 not_found /api/open '{"path": "nodir/missing.obj"}'
has_body 'nodir/missing.obj'
post_json 400 parse /api/open '{"path": "bunny.obj"'
has_body 'malformed JSON at byte'
post_json 400 parse /api/open '{"path": 3}'
post_json 400 parse /api/open '{"file": "bunny.obj"}'
post_json 400 parse /api/open '["bunny.obj"]'
post_json 400 parse /api/open '{"path": "bunny.obj", "path": "sub/copy.obj"}'
post_json 400 parse /api/open '{"path": "bunny.obj"} trailing'
post_json 400 parse /api/open ''
post_json 415 unsupported_format /api/open '{"path": "bend.json"}'
state_same "refused opens"

post_json 403 forbidden /api/rig/load '{"path": "../outside/secret.json"}'
post_json 403 forbidden /api/rig/load '{"path": "link.json"}'
post_json 403 forbidden /api/rig/load '{"path": "out/secret.json"}'
post_json 403 forbidden /api/rig/load "{\"path\": \"$OUT/secret.json\"}"
post_json 404 not_found /api/rig/load '{"path": "missing.json"}'
post_json 400 parse /api/rig/load '{"path": "bend.json",}'
post_json 403 forbidden /api/rig/save '{"path": "../outside/edit.json"}'
post_json 403 forbidden /api/rig/save '{"path": "out/edit.json"}'
post_json 403 forbidden /api/rig/save '{"path": "link.json"}'
post_json 403 forbidden /api/rig/save "{\"path\": \"$OUT/edit.json\"}"
post_json 400 invalid /api/rig/save '{"path": "edit.obj"}'
post_json 400 parse /api/rig/save '{"path": "edit.json"'
post_json 403 forbidden /api/export/save '{"path": "../outside/out.obj"}'
post_json 403 forbidden /api/export/save '{"path": "out/out.obj"}'
post_json 403 forbidden /api/export/save '{"path": "link.obj"}'
post_json 403 forbidden /api/export/save "{\"path\": \"$OUT/out.obj\"}"
post_json 400 invalid /api/export/save '{"path": "out.txt"}'
post_json 400 invalid /api/export/save '{"path": "out.ply", "encoding": "ebcdic"}'
post_json 400 parse /api/export/save '{"path": "out.ply", "extra": 1}'
post_json 409 conflict /api/export/save '{"path": "bunny.obj"}'
post_json 404 not_found /api/export/save '{"path": "nodir/out.obj"}'
[ "$(cd "$OUT" && ls | sort | tr '\n' ' ')" = "secret.html secret.json secret.obj " ] ||
    fail "a refused save wrote outside the root: $(ls -a "$OUT")"
[ -e "$ROOT/out.txt" ] || [ -e "$ROOT/out.ply" ] && fail "a refused export wrote a file"
state_same "refused rig and export requests"

# a NUL in a JSON key or string, or %00 in the URL's path or query: refused
# (cJSON and MHD hand out C strings, which would end at the NUL and open
# sub/copy.obj or serve index.html); nothing is opened (issue 14)
post_json 400 parse /api/open '{"path": "sub/copy.obj\u0000/../.."}'
has_body 'body:1:23: a NUL character (\\u0000) in a string is not allowed'
post_json 400 parse /api/open '{"path\u0000x": "sub/copy.obj"}'
post_json 400 parse /api/rig/load '{"path": "bend.json\u0000.obj"}'
expect 400 parse POST '/api/rig/upload?name=r.json' --data-binary '{"deformer": "lattice", "margin\u0000x": 0.5}'
has_body 'r.json:1:32: a NUL character'
expect 400 parse POST /api/create --data-binary '{"method": "lattice\u0000x"}'
expect 400 invalid GET '/index.html%00.png'
has_body 'a NUL character (%00) in the URL is not allowed'
expect 400 invalid GET '/api/state%00/../x' --path-as-is
expect 400 invalid GET '/api/export?format=obj%00ply'
expect 400 invalid GET '/api/export?format%00x=obj'
expect 400 invalid POST '/api/upload?name=sub.obj%00.txt' --data-binary @"$ROOT/bunny.obj"
expect 400 invalid POST '/api/open%00' -H 'Content-Type: application/json' --data-binary '{"path": "sub/copy.obj"}'
[ -e "$ROOT/sub.obj" ] && fail "an upload named with %00 wrote a file"
state_same "NUL in JSON and URLs"

head -c $((1024 * 1024 + 1)) /dev/zero | tr '\0' ' ' >"$T/big.json"
expect 413 too_large POST /api/create --data-binary @"$T/big.json"
expect 413 too_large POST /api/create -H 'Transfer-Encoding: chunked' --data-binary @"$T/big.json"
# a declared length past the limit is answered at once, from the headers:
# these send one byte, so that curl is not still sending when the server
# closes (with a real 1 MiB body the reset could beat the 413 to curl: 000)
expect 413 too_large POST /api/open -H 'Expect:' --data-binary 'x' -H 'Content-Length: 1048577'
expect 413 too_large POST /api/rig/upload?name=r.json --data-binary 'x' -H 'Expect:' \
    -H 'Content-Length: 999999999999'
expect 415 unsupported_format POST '/api/upload?name=model.fbx' --data-binary @"$ROOT/bunny.obj"
expect 415 unsupported_format POST '/api/rig/upload?name=rig.txt' --data-binary @"$ROOT/bend.json"
expect 400 invalid POST '/api/upload' --data-binary @"$ROOT/bunny.obj"
expect 400 parse POST '/api/upload?name=broken.obj' --data-binary 'v 1 x 3'
expect 400 parse POST '/api/upload?name=broken.ply' --data-binary 'ply'
expect 404 unsupported POST /api/no_such_op --data-binary '{}'
expect 404 not_found POST /api/Bad-Op --data-binary '{}'
expect 404 not_found POST /api/a_very_long_operation_name_that_is_too_long --data-binary '{}'
expect 404 not_found GET /api/no/such/thing
expect 404 not_found GET /api/no_such_op
expect 405 method_not_allowed GET /api/undo
has_header 'Allow: POST'
expect 405 method_not_allowed POST /api/state --data-binary '{}'
has_header 'Allow: GET, HEAD'
expect 405 method_not_allowed DELETE /api/state
expect 405 method_not_allowed PUT /api/files --data-binary x
expect 405 method_not_allowed GET /api/rig/save
state_same "refused requests"

# ---- concurrent requests are all answered ----
CURLS=()
for i in $(seq 1 20); do
    curl -s --max-time 60 -o "$T/c$i.state" -w '%{http_code}\n' "$URL/api/state" >"$T/c$i.code" &
    CURLS+=($!)
    curl -s --max-time 60 -o "$T/c$i.frame" -w '%{http_code}\n' "$URL/api/frame" >"$T/c$i.fcode" &
    CURLS+=($!)
    curl -s --max-time 60 -o /dev/null -w '%{http_code}\n' -X POST --data-binary '{' \
        "$URL/api/open" >"$T/c$i.bcode" &
    CURLS+=($!)
done
wait "${CURLS[@]}"
for i in $(seq 1 20); do
    [ "$(cat "$T/c$i.code")" = 200 ] && same_state "$T/c$i.state" ||
        fail "concurrent GET /api/state $i: $(cat "$T/c$i.code") $(head -c 200 "$T/c$i.state")"
    [ "$(cat "$T/c$i.fcode")" = 200 ] || fail "concurrent GET /api/frame $i: $(cat "$T/c$i.fcode")"
    [ "$(cat "$T/c$i.bcode")" = 400 ] || fail "concurrent bad open $i: $(cat "$T/c$i.bcode")"
done
state_same "concurrent requests"

# ---- an ambiguous body length: refused, and the connection closed ----
# raw TEXT: sends TEXT (printf format) on a new connection and reads the
# replies until the server closes it (5 s at most) into $T/raw.
raw() {
    local fd
    exec {fd}<>"/dev/tcp/127.0.0.1/$PORT" || { fail "raw: cannot connect to $PORT"; return; }
    # the server may close before all is sent: no SIGPIPE for this shell
    (trap '' PIPE; printf "$1" >&"$fd") 2>/dev/null
    timeout 5 cat <&"$fd" >"$T/raw"
    exec {fd}>&-
}
replies() { grep -ac '^HTTP/1\.1 ' "$T/raw"; } # how many replies $T/raw holds
# two lengths: libmicrohttpd reads the first (5 bytes) and would take the rest
# for a second request (a smuggled GET)
raw 'POST /api/open HTTP/1.1\r\nHost: x\r\nContent-Length: 5\r\nContent-Length: 80\r\n\r\n{"patGET /api/state HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n'
grep -q '^HTTP/1.1 400 ' "$T/raw" && [ "$(replies)" = 1 ] && grep -qiF 'Connection: close' "$T/raw" &&
    grep -qF '"error":"2 Content-Length headers: the body' "$T/raw" && grep -qF '"status":"invalid"' "$T/raw" ||
    fail "two Content-Length headers: not one 400 closing the connection: $(tr -c '[:print:]\n' . <"$T/raw")"
raw 'POST /api/open HTTP/1.1\r\nHost: x\r\nContent-Length: 21\r\nContent-Length: 21\r\nConnection: close\r\n\r\n{"path": "bunny.obj"}'
grep -q '^HTTP/1.1 400 ' "$T/raw" && [ "$(replies)" = 1 ] ||
    fail "two equal Content-Length headers: not one 400: $(tr -c '[:print:]\n' . <"$T/raw")"
raw 'POST /api/open HTTP/1.1\r\nHost: x\r\nContent-Length: 21\r\nTransfer-Encoding: chunked\r\n\r\n15\r\n{"path": "bunny.obj"}\r\n0\r\n\r\n'
grep -q '^HTTP/1.1 400 ' "$T/raw" && [ "$(replies)" = 1 ] &&
    grep -qF 'Content-Length and Transfer-Encoding together' "$T/raw" ||
    fail "Content-Length with Transfer-Encoding: not one 400: $(tr -c '[:print:]\n' . <"$T/raw")"
raw 'POST /api/open HTTP/1.1\r\nHost: x\r\nContent-Length: 5, 80\r\n\r\n{"pat'
grep -q '^HTTP/1.1 400 ' "$T/raw" || fail "Content-Length: 5, 80: not a 400: $(tr -c '[:print:]\n' . <"$T/raw")"
raw 'POST /api/open HTTP/1.1\r\nHost: x\r\nContent-Length: 21\r\nConnection: close\r\n\r\n{"path": "bunny.obj"}'
grep -q '^HTTP/1.1 200 ' "$T/raw" || fail "one Content-Length: not a 200: $(tr -c '[:print:]\n' . <"$T/raw")"
state_same "ambiguous body lengths"

# ---- uploads and opens replace the session ----
expect_ok() { # expect_ok METHOD PATH [CURL ARGS]: HTTP 200
    req "$@"
    [ "$CODE" = 200 ] || fail "$1 $2: HTTP $CODE: $(show)"
}
expect_ok POST '/api/upload?name=up%2Fmodel.obj' --data-binary @"$ROOT/sub/copy.obj"
has_body '"model.obj"'
expect_ok POST /api/open --data-binary '{"path": "inside.obj"}'
has_body '"inside.obj"'
expect_ok POST /api/open --data-binary '{"path": "bunny.obj"}'
has_body '"bunny.obj"'

# ---- a second server: --max-upload 1 ----
start small "$ROOT/bunny.obj" --port 0 --no-autosave --root "$ROOT" --max-upload 1 --web "$T/no-page" || exit 1
head -c $((1024 * 1024 + 1)) /dev/zero >"$T/big.stl"
expect 413 too_large POST '/api/upload?name=big.stl' --data-binary @"$T/big.stl"
expect 413 too_large POST '/api/upload?name=big.stl' -H 'Transfer-Encoding: chunked' \
    --data-binary @"$T/big.stl"
expect 413 too_large POST '/api/rig/upload?name=big.json' --data-binary @"$T/big.stl"
expect_ok POST '/api/upload?name=small.obj' --data-binary @"$ROOT/bunny.obj"
has_body '"small.obj"'
req GET /
[ "$CODE" = 404 ] || fail "GET / without a page: HTTP $CODE"
stop small

# ---- connections: per client address, idle timeout (a server with small limits) ----
# idle N: opens N connections from 127.0.0.1 that send nothing; their
# descriptors in IDLE.
idle() {
    local fd
    for _ in $(seq 1 "$1"); do
        exec {fd}<>"/dev/tcp/127.0.0.1/$PORT" || { fail "cannot connect to $PORT"; return; }
        IDLE+=("$fd")
    done
}
# closed FD SECONDS: the server closes FD within SECONDS (read sees the end)
closed() {
    local line
    read -r -t "$2" -u "$1" line
    [ $? -eq 1 ]
}
close_idle() {
    for fd in "${IDLE[@]}"; do exec {fd}>&-; done
    IDLE=()
}
# state_from ADDRESS: GET /api/state from that client address answers 200 (5 s at most)
state_from() {
    [ "$(curl -s --max-time 5 --interface "$1" -o /dev/null -w '%{http_code}' "$URL/api/state")" = 200 ]
}
start limits "$ROOT/bunny.obj" --port 0 --no-autosave --root "$ROOT" --web "$T/no-page" --client-connections 4 \
    --idle-timeout 2 || exit 1
PORT=${URL##*:}
IDLE=()
t0=$(date +%s%N)
idle 4
(trap '' PIPE; printf 'GET /api/state HTTP/1.1\r\nHost: x\r\n' >&"${IDLE[0]}") 2>/dev/null # half a request
idle 2
closed "${IDLE[4]}" 1 && closed "${IDLE[5]}" 1 ||
    fail "--client-connections 4: the 5th and 6th connection of 127.0.0.1 were not closed at once"
closed "${IDLE[1]}" 0.2 && fail "--client-connections 4: the 2nd connection was closed at once"
state_from 127.0.0.2 || fail "--client-connections 4: 127.0.0.2 shut out by 4 idle connections of 127.0.0.1"
state_from 127.0.0.1 && fail "--client-connections 4: a 5th connection of 127.0.0.1 was served"
for i in 0 1 2 3; do
    closed "${IDLE[$i]}" 10 || fail "--idle-timeout 2: idle connection $i still open after 10 s"
done
ms=$((($(date +%s%N) - t0) / 1000000))
[ "$ms" -ge 1500 ] || fail "--idle-timeout 2: idle connections closed after $ms ms"
close_idle
state_from 127.0.0.1 || fail "127.0.0.1 not served after its idle connections were closed"
# a request that computes longer than the idle timeout (a few seconds) is still answered
if [ "${FFD_SERVE_STUB:-0}" != 1 ]; then
    expect_ok POST /api/create --data-binary '{"method": "tspline", "resolution": [14, 14, 14]}'
    expect_ok POST /api/refine --data-binary '{"insertions": [{"cells": "proxy"}]}'
fi
stop limits

# ---- more idle clients than the server's 256 connections, at the defaults ----
start crowd "$ROOT/bunny.obj" --port 0 --no-autosave --root "$ROOT" --web "$T/no-page" || exit 1
PORT=${URL##*:}
idle 260
closed "${IDLE[40]}" 2 || fail "defaults: the 41st idle connection of 127.0.0.1 was not closed at once"
state_from 127.0.0.2 || fail "defaults: 260 idle connections of 127.0.0.1 shut out 127.0.0.2"
close_idle
for _ in $(seq 1 50); do state_from 127.0.0.1 && break; sleep 0.1; done
state_from 127.0.0.1 || fail "defaults: 127.0.0.1 not served after closing its idle connections"
# a browser: 6 keep-alive connections, 60 requests
urls=()
for _ in $(seq 1 20); do
    for u in state frame topology; do urls+=(-o /dev/null "$URL/api/$u"); done
done
codes=$(curl -s --parallel --parallel-max 6 --max-time 60 -w '%{http_code}\n' "${urls[@]}" 2>/dev/null |
    sort | uniq -c | tr -s ' ')
[ "$codes" = " 60 200" ] || fail "6 parallel keep-alive connections: codes $codes"
stop crowd
PORT=${MAIN_URL##*:}

# ---- a taken port; a non-loopback host ----
bad 1 serve "$ROOT/bunny.obj" --port "$PORT" --root "$ROOT"
has stderr "ffd: serve: cannot listen on 127.0.0.1:$PORT: Address already in use"
start any "$ROOT/bunny.obj" --port 0 --no-autosave --host 0.0.0.0 --root "$ROOT" || exit 1
grep -qF "ffd: warning: listening on 0.0.0.0: the editor has no authentication; anyone who can reach this port can read and write files under $(cd "$ROOT" && pwd -P)" "$T/any.err" ||
    fail "--host 0.0.0.0: no warning: $(cat "$T/any.err")"
grep -qE '^ffd serve: http://0\.0\.0\.0:[0-9]+/$' "$T/any.out" || fail "--host 0.0.0.0: $(cat "$T/any.out")"
stop any
start local "$ROOT/bunny.obj" --port 0 --no-autosave --host localhost --root "$ROOT" --verbose || exit 1
grep -q warning "$T/local.err" && fail "--host localhost warned: $(cat "$T/local.err")"
req GET /api/state
grep -qF 'GET /api/state 200' "$T/local.err" || fail "--verbose: no request line: $(cat "$T/local.err")"
stop local

# ---- the session: needs the real editing session (src/session/) ----
PID=$MAIN_PID
URL=$MAIN_URL
if [ "${FFD_SERVE_STUB:-0}" != 1 ]; then
    req GET /api/state
    has_key method null
    expect 409 conflict GET /api/rig
    post_json 409 conflict /api/rig/save '{"path": "edit.json"}'
    expect 409 conflict POST /api/drag --data-binary '{"delta": [1, 0, 0]}'
    expect 400 parse POST /api/create --data-binary '{"method": "lattice"'
    expect 400 parse POST /api/create --data-binary '{"method": "lattice", "resolution": "5"}'
    expect 400 invalid POST /api/create --data-binary '{"method": "lattice", "resolution": [1, 1, 1]}'
    # the create body is a rig's creation part: other rig keys are refused by name
    expect 400 parse POST /api/create --data-binary '{"deformer": "lattice", "moves": []}'
    grep -qF 'create: moves: unknown key' "$T/body" || fail "create with moves: $(show)"
    expect 400 parse POST /api/create --data-binary '{"method": "lattice", "deformer": "tspline"}'
    grep -qF 'name different methods' "$T/body" || fail "create with two methods: $(show)"
    req GET /api/state
    cp "$T/body" "$T/state0"
    expect_ok POST /api/create --data-binary '{"method": "lattice", "resolution": [4, 4, 4]}'
    has_key method '"lattice"'
    has_key count 64
    expect 400 range POST /api/drag_begin --data-binary '{"points": [64]}'
    expect_ok POST /api/drag_begin --data-binary '{"points": [63]}'
    expect_ok POST /api/drag --data-binary '{"delta": [0.5, 0, 0]}'
    has_header 'Content-Type: application/octet-stream'
    [ "$(head -c 4 "$T/body")" = FFDF ] || fail "drag: not a frame"
    # delta frames (?base=REV, the frame the client holds): a base the session
    # did not send through a delta request gets the full frame, which it then
    # holds; a bad base is refused before the step runs; the same step against
    # the frame just sent changes nothing
    rev=$(od -An -tu4 -j4 -N4 "$T/body" | tr -d ' ')
    expect_ok POST "/api/drag?base=$rev" --data-binary '{"delta": [0.5, 0, 0]}'
    [ "$(head -c 4 "$T/body")" = FFDF ] || fail "drag?base=$rev: not the full frame: $(show)"
    rev=$(od -An -tu4 -j4 -N4 "$T/body" | tr -d ' ')
    expect 400 invalid POST '/api/drag?base=x1' --data-binary '{"delta": [0.7, 0, 0]}'
    has_body 'drag: base: expected the revision'
    expect 400 invalid GET '/api/frame?base=-1'
    expect 400 invalid GET '/api/frame?base=4294967295'
    expect_ok POST "/api/drag?base=$rev" --data-binary '{"delta": [0.5, 0, 0]}'
    [ "$(head -c 4 "$T/body")" = FFDD ] || fail "drag?base=$rev: not a delta frame: $(show)"
    [ "$(od -An -tu4 -j16 -N8 "$T/body" | tr -s ' ')" = " 0 0" ] || fail "drag?base=$rev: vertices changed"
    [ "$(stat -c %s "$T/body")" = $((36 + 12 * 64)) ] || fail "drag?base=$rev: $(stat -c %s "$T/body") bytes"
    expect_ok GET '/api/frame?base=none'
    [ "$(head -c 4 "$T/body")" = FFDF ] || fail "frame?base=none: not the full frame: $(show)"
    expect_ok POST /api/drag_end --data-binary '{}'
    expect_ok GET /api/rig
    has_header 'Content-Disposition: attachment; filename="bunny-rig.json"'
    cp "$T/body" "$T/rig.json"
    expect_ok POST /api/rig/save --data-binary '{"path": "sub/edit.json"}'
    cmp -s "$T/rig.json" "$ROOT/sub/edit.json" || fail "rig/save: the file differs from GET /api/rig"
    expect_ok POST /api/export/save --data-binary '{"path": "sub/out.ply", "encoding": "binary"}'
    grep -qaF 'format binary_little_endian' "$ROOT/sub/out.ply" || fail "export/save: not binary PLY"
    # the saved rig replays to the saved mesh
    ok deform "$ROOT/bunny.obj" -o "$T/replay.ply" --rig "$ROOT/sub/edit.json" --binary
    ok info --json "$ROOT/sub/out.ply"
    cp "$T/stdout" "$T/info-saved"
    ok info --json "$T/replay.ply"
    bbox_close "$T/stdout" "$T/info-saved" ||
        fail "the saved rig does not replay to the saved mesh: $(cat "$T/stdout" "$T/info-saved")"
    ls -a "$ROOT" "$ROOT/sub" | grep -q '\.tmp' && fail "a save left a temporary file: $(ls -a "$ROOT" "$ROOT/sub")"
    expect_ok POST /api/undo --data-binary '{}'
    expect_ok POST /api/undo --data-binary '{}'
    has_key method null
    expect_ok POST /api/rig/load --data-binary '{"path": "bend.json"}'
    has_key method '"lattice"'
    expect_ok POST '/api/rig/upload?name=bend.json' --data-binary @"$ROOT/bend.json"
    expect_ok POST /api/influence --data-binary '{"points": [0]}'
    [ "$(head -c 4 "$T/body")" = FFDI ] || fail "influence: no FFDI magic"

    # several meshes (docs/editor.md "Several meshes"): ?add=1 adds a mesh to
    # the session, each mesh exports alone (an untouched copy byte for byte
    # after the deformer is reset), remove_mesh takes one out
    expect_ok POST '/api/open?add=1' --data-binary '{"path": "sub/copy.obj"}'
    has_body '"meshes":[{"name":"bunny.obj","first":0,"vertices":1839,"faces":3674},{"name":"copy.obj","first":1839,"vertices":1839,"faces":3674}]'
    has_body '"vertices":3678'
    expect_ok POST '/api/upload?add=1&name=third.obj' --data-binary @"$ROOT/bunny.obj"
    has_body '{"name":"third.obj","first":3678'
    expect_ok POST /api/reset --data-binary '{}'
    expect_ok GET '/api/export?mesh=2'
    has_header 'filename="third-deformed.obj"'
    cmp -s "$T/body" "$ROOT/bunny.obj" || fail "export?mesh=2 of an untouched mesh differs from its file"
    expect 400 invalid GET '/api/export?mesh=3'
    has_body 'expected the index of one of the session'
    expect 400 invalid GET '/api/export?mesh=1x'
    post_json 400 range /api/remove_mesh '{"mesh": 5}'
    post_json 400 parse /api/remove_mesh '{"index": 1}'
    expect_ok POST /api/remove_mesh --data-binary '{"mesh": 1}'
    has_body '{"name":"third.obj","first":1839'
    expect_ok POST /api/remove_mesh --data-binary '{"mesh": 1}'
    has_body '"meshes":[{"name":"bunny.obj","first":0,"vertices":1839,"faces":3674}]'
    post_json 409 conflict /api/remove_mesh '{"mesh": 0}'

    # files a rig names that are not regular files: the client's error (400), never a hang
    mkfifo "$ROOT/pipe.obj" "$ROOT/pipe.json"
    mkdir "$ROOT/folder.obj"
    printf '{"deformer": "gffd", "skeleton": [{"type": "polyline", "file": "pipe.obj", "radius": 1}]}\n' \
        >"$ROOT/pipe-skeleton.json"
    printf '{"deformer": "gffd", "skeleton": [{"type": "polyline", "file": "folder.obj", "radius": 1}]}\n' \
        >"$ROOT/folder-skeleton.json"
    printf '{"deformer": "gffd", "skeleton": [{"type": "polyline", "file": "spine.obj", "radius": 1}],\n
            "replace": [{"type": "polyline", "file": "pipe.obj", "radius": 1}]}\n' >"$ROOT/pipe-replace.json"
    printf 'v 0 0 0\nv 0 5 0\nl 1 2\n' >"$ROOT/spine.obj"
    req GET /api/state
    cp "$T/body" "$T/state0"
    post_json 400 invalid /api/rig/load '{"path": "pipe-skeleton.json"}'
    has_body 'pipe.obj: not a regular file'
    post_json 400 invalid /api/rig/load '{"path": "folder-skeleton.json"}'
    has_body 'folder.obj: is a directory'
    post_json 400 invalid /api/rig/load '{"path": "pipe-replace.json"}'
    has_body 'pipe.obj: not a regular file'
    post_json 400 invalid /api/rig/load '{"path": "pipe.json"}'
    printf 'solid s\nendsolid s\n' >"$ROOT/skeleton.stl"
    printf '{"deformer": "gffd", "skeleton": [{"type": "polyline", "file": "skeleton.stl", "radius": 1}]}\n' \
        >"$ROOT/stl-skeleton.json"
    post_json 415 unsupported_format /api/rig/load '{"path": "stl-skeleton.json"}'
    has_body 'skeleton.stl: STL has no shared vertices'
    post_json 400 invalid /api/open '{"path": "pipe.obj"}'
    post_json 400 invalid /api/open '{"path": "folder.obj"}'
    post_json 400 invalid /api/export/save '{"path": "pipe.obj"}'
    post_json 400 invalid /api/export/save '{"path": "folder.obj"}'
    [ -p "$ROOT/pipe.obj" ] || fail "export/save replaced a FIFO"
    state_same "rigs naming a FIFO or a directory"

    # GET /api/state answers from the published state while a long request
    # (a T-spline refinement of every proxy cell, seconds) holds the session
    expect_ok POST /api/create --data-binary '{"method": "tspline", "resolution": [14, 14, 14]}'
    cp "$T/body" "$T/state0"
    curl -s --max-time 600 -o "$T/slow" -w '%{http_code}' -X POST \
        --data-binary '{"insertions": [{"cells": "proxy"}]}' "$URL/api/refine" >"$T/slow.code" &
    SLOW=$!
    sleep 0.3
    during=0
    for _ in $(seq 1 20); do
        kill -0 "$SLOW" 2>/dev/null || break
        t=$(curl -s --max-time 10 -o "$T/during" -w '%{http_code} %{time_total}' "$URL/api/state")
        kill -0 "$SLOW" 2>/dev/null || break # answered after the refinement: proves nothing
        during=$((during + 1))
        [ "${t%% *}" = 200 ] && awk -v t="${t#* }" 'BEGIN { exit !(t < 1) }' ||
            fail "GET /api/state during a long request: $t (expected 200 within 1 s)"
        same_state "$T/during" || fail "GET /api/state during a long request: not the last state"
        # GET /api/progress names the running op, its time and the library's stage
        t=$(curl -s --max-time 10 -o "$T/progress" -w '%{http_code}' "$URL/api/progress")
        if kill -0 "$SLOW" 2>/dev/null; then
            [ "$t" = 200 ] && grep -qE '^\{"op": "refine", "seconds": [0-9.]+, "stage": (null|"[^"]+", "fraction": [0-9.]+, "stage_seconds": [0-9.]+)\}$' "$T/progress" ||
                fail "GET /api/progress during a long refinement: $t $(cat "$T/progress")"
            grep -qF '"stage": "T-spline set-up"' "$T/progress" && staged=1
        fi
        sleep 0.1
    done
    wait "$SLOW"
    [ "$during" = 0 ] || [ "${staged:-0}" = 1 ] || fail "GET /api/progress never showed the T-spline set-up stage"
    expect_ok GET /api/progress
    grep -qxF '{"op": null, "stage": null}' "$T/body" || fail "GET /api/progress after the request: $(show)"
    [ "$(cat "$T/slow.code")" = 200 ] || fail "the long refinement: HTTP $(cat "$T/slow.code")"
    [ "$during" -ge 1 ] || fail "no GET /api/state was answered while the refinement ran"
    req GET /api/state
    same_state "$T/body" && fail "GET /api/state after the refinement: the state before it"
    cmp -s "$T/body" "$T/slow" || fail "GET /api/state after the refinement differs from its reply"
fi

# Vertex-group weights from a file under the root (POST /api/weights/load):
# refused without a deformer, outside the root, or with a bad file (naming
# the line or the count), changing nothing; a good file is one undo step and
# lands in the rig.
expect_ok POST /api/open --data-binary '{"path": "bunny.obj"}'
awk 'BEGIN { for (i = 0; i < 1839; i++) print (i < 900 ? 0.25 : 1) }' >"$ROOT/w.txt"
{ echo 0.5; echo half; } >"$ROOT/w-bad.txt"
echo 0.5 >"$ROOT/w-short.txt"
awk 'BEGIN { for (i = 0; i < 1839; i++) print (i == 7 ? 1.5 : 1) }' >"$ROOT/w-range.txt"
post_json 409 conflict /api/weights/load '{"path": "w.txt"}'
expect_ok POST /api/create --data-binary '{"deformer": "lattice", "resolution": [3, 3, 3]}'
expect_ok POST /api/move --data-binary '{"points": [13], "delta": [0, 1, 0]}'
req GET /api/state
cp "$T/body" "$T/weights-before"
post_json 403 forbidden /api/weights/load '{"path": "../outside/secret.json"}'
post_json 403 forbidden /api/weights/load '{"path": "link.json"}'
post_json 404 not_found /api/weights/load '{"path": "missing.txt"}'
post_json 400 parse /api/weights/load '{"path": "w-bad.txt"}'
has_body 'w-bad.txt:2: expected one weight (a number) per line'
post_json 400 invalid /api/weights/load '{"path": "w-short.txt"}'
has_body 'w-short.txt: 1 weights for 1839 vertices'
post_json 400 range /api/weights/load '{"path": "w-range.txt"}'
has_body 'vertex 7 is 1.5'
req GET /api/state
cmp -s "$T/body" "$T/weights-before" || fail "refused weights files changed the state"
expect_ok POST /api/weights/load --data-binary '{"path": "w.txt"}'
has_key undo 3
req GET /api/rig
grep -q '"weights"' "$T/body" || fail "GET /api/rig after loading weights: no \"weights\": $(show)"
expect_ok POST /api/undo --data-binary '{}'
has_key undo 2

stop main
[ "$(cksum <"$ROOT/bunny.obj")" = "$BUNNY_SUM" ] || fail "the opened mesh was modified"
[ "$(cd "$OUT" && cat secret.obj secret.json secret.html | cksum)" = "$OUT_SUM" ] ||
    fail "files outside the root were modified"

# ---- work is never lost: history, autosave and resume (docs/editor.md) ----
if [ -z "${FFD_SERVE_STUB:-}" ]; then
    AR=$T/autosave
    mkdir -p "$AR"
    cp "$SRC/examples/lattice/bunny.obj" "$AR/bunny.obj"
    start a1 "$AR/bunny.obj" --port 0 --root "$AR" --web "$T/no-page" || exit 1
    req POST /api/create -d '{"deformer":"lattice","resolution":[4,4,4]}'
    req POST /api/move -d '{"points":[21,22],"delta":[0,0.3,0]}'
    req POST /api/pin -d '{"vertex":893}'
    [ "$CODE" = 200 ] || fail "autosave: the edits: HTTP $CODE: $(show)"
    req GET /api/history
    has_body '{"steps":["Open bunny.obj","Create lattice 4×4×4","Drag 2 controls","Pin vertex 893"],"current":3}'
    req GET /api/rig
    tr -d '[:space:]' <"$T/body" | grep -qF '"pins":[{"vertex":893,' || fail "GET /api/rig lacks the pin: $(show)"
    post_json 400 range /api/history/goto '{"index":9}'
    has_body 'history_goto: index: 9 out of range (the history has 4 steps, 0 to 3)'
    post_json 400 parse /api/history/goto '{"step":1}'
    req POST /api/history/goto -d '{"index":1}'
    [ "$CODE" = 200 ] || fail "POST /api/history/goto: HTTP $CODE: $(show)"
    has_key current 1
    req POST /api/history/goto -d '{"index":3}'
    sleep 1 # the autosave's quiet time
    [ -f "$AR/.ffd/autosave-bunny.obj.json" ] || fail "no autosave under ROOT/.ffd after the edits"
    grep -q '"Pin vertex 893"' "$AR/.ffd/autosave-bunny.obj.json" || fail "the autosave lacks the steps"
    ls "$AR/.ffd" | grep -v '^autosave-bunny.obj.json$' && fail "a temporary file left in ROOT/.ffd"
    kill -KILL "$PID"
    wait "$PID" 2>/dev/null
    start a2 "$AR/bunny.obj" --port 0 --root "$AR" --web "$T/no-page" || exit 1
    grep -q "ffd serve: resumed your session of bunny.obj from .* (4 history steps; .ffd/autosave-bunny.obj.json)" "$T/a2.err" ||
        fail "a restarted server does not say it resumed: $(cat "$T/a2.err")"
    req GET /api/state
    has_body '"steps":["Open bunny.obj","Create lattice 4×4×4","Drag 2 controls","Pin vertex 893"],"current":3}'
    has_body '"resumed":true'
    has_key vertex 893
    req POST /api/undo
    has_key undo 2
    stop a2 # SIGTERM writes the pending change
    grep -qE '"current":[[:space:]]*2,' "$AR/.ffd/autosave-bunny.obj.json" || fail "the stop did not write the last change"
    # the mesh changed since: not applied, kept aside, the state says why
    sed -i '0,/^v /s/^v .*/v 0 0 0/' "$AR/bunny.obj"
    start a3 "$AR/bunny.obj" --port 0 --root "$AR" --web "$T/no-page" || exit 1
    grep -q "your autosaved session was not applied: .*saved for another version of bunny.obj" "$T/a3.err" ||
        fail "a changed mesh: no word of the autosave not applied: $(cat "$T/a3.err")"
    [ -f "$AR/.ffd/autosave-bunny.obj.not-applied.json" ] || fail "the autosave not applied is not kept"
    req GET /api/state
    has_body '"resumed":false'
    has_body 'kept as .ffd/autosave-bunny.obj.not-applied.json'
    has_key method null
    stop a3
    # opened again from the page: a new session; the earlier one kept aside and offered
    AO=$T/reopen
    mkdir -p "$AO"
    cp "$SRC/examples/lattice/bunny.obj" "$AO/bunny.obj"
    cp "$SRC/examples/tspline/cow.off" "$AO/cow.off"
    start a5 "$AO/bunny.obj" --port 0 --root "$AO" --web "$T/no-page" || exit 1
    req POST /api/create -d '{"deformer":"lattice","resolution":[3,3,3]}'
    req POST /api/move -d '{"points":[13],"delta":[0,0.3,0]}'
    req POST /api/open -d '{"path":"cow.off"}'
    [ -f "$AO/.ffd/autosave-bunny.obj.json" ] || fail "opening another mesh did not write the session it replaced"
    req POST /api/open -d '{"path":"bunny.obj"}'
    has_key method null
    has_key undo 0
    has_body '"previous":{"file":".ffd/autosave-bunny.obj.previous.json"'
    [ -f "$AO/.ffd/autosave-bunny.obj.previous.json" ] || fail "the earlier session of bunny.obj is not kept aside"
    req POST /api/autosave/resume -d '{}'
    [ "$CODE" = 200 ] || fail "POST /api/autosave/resume: HTTP $CODE: $(show)"
    has_body '"steps":["Open bunny.obj","Create lattice 3×3×3","Drag control 13"],"current":2}'
    [ -e "$AO/.ffd/autosave-bunny.obj.previous.json" ] && fail "the resumed earlier session is still kept aside"
    post_json 409 conflict /api/autosave/resume '{}'
    has_body 'no earlier session of bunny.obj is kept'
    stop a5
    # a root where the record cannot be written: stderr and the state say so
    AE=$T/unwritable
    mkdir -p "$AE"
    cp "$SRC/examples/lattice/bunny.obj" "$AE/bunny.obj"
    printf 'not a directory\n' >"$AE/.ffd"
    start a6 "$AE/bunny.obj" --port 0 --root "$AE" --web "$T/no-page" || exit 1
    req POST /api/create -d '{"deformer":"lattice"}'
    sleep 1
    req POST /api/reset -d '{}'
    has_body '"error":"'
    grep -q "ffd: warning: autosave: .*autosave-bunny.obj.json" "$T/a6.err" || fail "a failed autosave: no warning: $(cat "$T/a6.err")"
    stop a6
    # --no-autosave: nothing written, nothing resumed
    AN=$T/noauto
    mkdir -p "$AN"
    cp "$SRC/examples/lattice/bunny.obj" "$AN/bunny.obj"
    start a4 "$AN/bunny.obj" --port 0 --root "$AN" --web "$T/no-page" --no-autosave || exit 1
    req POST /api/create -d '{"deformer":"lattice"}'
    sleep 1
    stop a4
    [ -e "$AN/.ffd" ] && fail "--no-autosave wrote $AN/.ffd"
fi

if [ "$failures" -ne 0 ]; then
    echo "$failures failure(s)"
    exit 1
fi
echo "all serve tests passed"
