# What test_install.sh and test_deb.sh share (sourced): a temporary directory
# $T removed at exit with the server $PID stopped, fail, and starting an
# installed ffd serve on its bundled mesh.
T=$(mktemp -d)
PID=
cleanup() {
    [ -n "$PID" ] && kill "$PID" 2>/dev/null
    rm -rf "$T"
}
trap cleanup EXIT
failures=0
fail() {
    echo "FAIL: $*"
    failures=$((failures + 1))
}

# check_serve_bundled WHAT DATA FFD...: the ffd of an installed tree (WHAT
# names it in messages; DATA is its share/ffd, beside its bin/) run as
# `FFD... serve --port 0` with no mesh opens DATA's bundled bunny and serves
# DATA's page, or warns naming the missing page when DATA has none. The
# bunny is replaced by an 8-vertex cube and the page marked first, so that
# the source tree's (compiled in as a fallback) would show.
check_serve_bundled() {
    local what=$1 data=$2 code
    shift 2
    printf 'v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 1 2 3 4\nf 5 8 7 6\n' \
        >"$data/examples/lattice/bunny.obj"
    [ -f "$data/web/index.html" ] && echo '<!-- installed -->' >>"$data/web/index.html"
    "$@" serve --port 0 >"$T/serve.out" 2>"$T/serve.err" &
    PID=$!
    local url=
    for _ in $(seq 1 200); do
        url=$(sed -n 's/^ffd serve: \(http:.*\)$/\1/p' "$T/serve.out")
        [ -n "$url" ] && break
        kill -0 "$PID" 2>/dev/null || break
        sleep 0.05
    done
    if [ -z "$url" ]; then
        fail "$what: ffd serve printed no URL: $(cat "$T/serve.out" "$T/serve.err")"
        return
    fi
    url=${url%/}
    code=$(curl -s --max-time 30 -o "$T/state" -w '%{http_code}' "$url/api/state")
    [ "$code" = 200 ] && grep -q '"vertices":8,' "$T/state" ||
        fail "$what: GET /api/state: $code, not its bundled bunny.obj: $(head -c 300 "$T/state")"
    code=$(curl -s --max-time 30 -o "$T/mesh" -w '%{http_code}' "$url/api/export")
    [ "$code" = 200 ] && [ "$(grep -c '^v ' "$T/mesh")" = 8 ] ||
        fail "$what: GET /api/export: $code, not its bundled bunny.obj: $(head -c 300 "$T/mesh")"
    code=$(curl -s --max-time 30 -o "$T/page" -w '%{http_code}' "$url/")
    if [ -f "$data/web/index.html" ]; then
        [ "$code" = 200 ] && grep -qF '<!-- installed -->' "$T/page" ||
            fail "$what: GET /: $code, not its page: $(head -c 200 "$T/page")"
        code=$(curl -s --max-time 30 -o /dev/null -w '%{http_code}' "$url/app.js")
        [ "$code" = 200 ] || fail "$what: GET /app.js: $code"
        grep -q 'warning' "$T/serve.err" && fail "$what: a warning with the page installed: $(cat "$T/serve.err")"
    else # DATA is PREFIX/share/ffd: the warning names PREFIX/bin/../share/ffd/web
        grep -qF "no index.html at $(dirname "$(dirname "$data")")/bin/../share/ffd/web/index.html" "$T/serve.err" ||
            fail "$what: no warning naming the missing page: $(cat "$T/serve.err")"
    fi
    kill -TERM "$PID"
    wait "$PID" || fail "$what: ffd serve exited $? after SIGTERM: $(cat "$T/serve.err")"
    PID=
    grep -q -e 'Sanitizer' -e 'runtime error' "$T/serve.err" && fail "$what: serve: $(cat "$T/serve.err")"
}
