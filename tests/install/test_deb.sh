#!/usr/bin/env bash
# The Debian package (README "Install", docs/api.md "Linking"): `cpack -G DEB`
# builds a .deb whose Depends are packages Debian 12 has, in versions it has
# (apt-cache, else dpkg-query); whose file list (dpkg-deb -c) holds the
# library, its soname and development links, the static library, the
# headers, ffd.pc, the CMake package, the ffd command, its compressed man
# pages, the copyright file and changelog, the editor's page and the example
# meshes; and whose ffd, extracted with dpkg-deb -x (nothing is installed),
# serves its own page and bundled mesh from the extracted tree. Exits 77
# (skipped) when cpack or dpkg-deb is missing.
# usage: bash test_deb.sh BUILD_DIR SOURCE_DIR   (FFD_DEB=FILE: check FILE
# instead of building one)
set -u
BUILD=$(cd "$1" && pwd)
SRC=$(cd "$2" && pwd)
for tool in cpack dpkg-deb; do
    command -v $tool >/dev/null || { echo "skip: $tool is not installed: the .deb is not checked"; exit 77; }
done
command -v curl >/dev/null || { echo "FAIL: curl is not installed (scripts/setup.sh)"; exit 1; }
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

if [ -n "${FFD_DEB:-}" ]; then
    DEB=$FFD_DEB
else
    (cd "$T" && cpack -G DEB --config "$BUILD/CPackConfig.cmake" -B "$T/deb") >"$T/cpack.log" 2>&1 ||
        { fail "cpack -G DEB: $(tail -30 "$T/cpack.log")"; exit 1; }
    DEB=$(ls "$T"/deb/*.deb 2>/dev/null | head -1)
fi
[ -n "$DEB" ] || { fail "cpack made no .deb: $(tail -30 "$T/cpack.log")"; exit 1; }
echo "checking $DEB"

# ---- Depends: each a package Debian 12 has, in a version it has ----
depends=$(dpkg-deb -f "$DEB" Depends)
[ -n "$depends" ] || fail "the .deb has no Depends"
for dep in libc6 libgomp1 liblapacke libcjson1 libqhull-r8.0 libcholmod3 libmicrohttpd12; do
    echo ", $depends" | grep -qE ", $dep( |,|$)" || fail "the .deb does not depend on $dep: $depends"
done
IFS=',' read -ra items <<<"$depends"
for item in "${items[@]}"; do
    # "name (>= version)"; no alternatives (|) are expected
    read -r name op version <<<"$(echo "$item" | sed -E 's/^ *([^ (]+) *(\(([<>=]+) *([^)]*)\))? *$/\1 \3 \4/')"
    version=${version:-}
    have=$(apt-cache show --no-all-versions "$name" 2>/dev/null | sed -n 's/^Version: //p' | head -1)
    [ -n "$have" ] || have=$(dpkg-query -W -f '${Version}' "$name" 2>/dev/null)
    if [ -z "$have" ]; then
        fail "Depends: $name is not a package this system knows (apt-cache show, dpkg-query -W)"
    elif [ -n "$op" ] && ! dpkg --compare-versions "$have" "$op" "$version"; then
        fail "Depends: $name ($op $version), but this system has $have"
    fi
done

# ---- the file list ----
dpkg-deb -c "$DEB" >"$T/deb.list"
awk '{ print $6 }' "$T/deb.list" >"$T/deb.paths"
has_path() { grep -qE "^\./usr/$1\$" "$T/deb.paths" || fail "the .deb lacks usr/$1"; }
for p in 'lib/(.*/)?libffd\.so\.0\.[0-9]+\.[0-9]+' 'lib/(.*/)?libffd\.a' 'lib/(.*/)?pkgconfig/ffd\.pc' \
    'lib/(.*/)?cmake/ffd/ffdConfig\.cmake' 'lib/(.*/)?cmake/ffd/ffdConfigVersion\.cmake' \
    'lib/(.*/)?cmake/ffd/ffdTargets\.cmake' 'include/ffd\.h' 'include/ffd_lattice\.h' 'bin/ffd' \
    'share/man/man1/ffd\.1\.gz' 'share/man/man1/ffd-deform\.1\.gz' 'share/man/man1/ffd-serve\.1\.gz' \
    'share/doc/ffdkit/copyright' 'share/doc/ffdkit/changelog\.gz' \
    'share/ffd/examples/lattice/bunny\.obj' 'share/ffd/examples/pbffd/elephant\.off'; do
    has_path "$p"
done
# one man page per command that `ffd --help` lists
for cmd in $(sed -n 's/^ffd-\(.*\)\.1$/\1/p' <(ls "$BUILD/man")); do
    has_path "share/man/man1/ffd-$cmd\\.1\\.gz"
done
# the soname link and the development link
grep -qE '\./usr/lib/(.*/)?libffd\.so\.0 -> libffd\.so\.0\.' "$T/deb.list" || fail "the .deb lacks the link libffd.so.0"
grep -qE '\./usr/lib/(.*/)?libffd\.so -> libffd\.so\.0' "$T/deb.list" || fail "the .deb lacks the link libffd.so"
grep -v '^d' "$T/deb.list" | grep -vE '^-rw-r--r-- |^-rwxr-xr-x |^lrwxrwxrwx ' |
    while read -r line; do fail "unusual mode or owner: $line"; done
grep -E '^-rwxr-xr-x ' "$T/deb.list" | grep -vq '/bin/ffd$' &&
    fail "executable files besides ffd: $(grep -E '^-rwxr-xr-x ' "$T/deb.list" | grep -v '/bin/ffd$')"
PAGE=0
with=" without its page"
if [ -f "$SRC/web/dist/index.html" ]; then
    PAGE=1
    with=" with its page"
    has_path 'share/ffd/web/index\.html'
    has_path 'share/ffd/web/app\.js'
else
    echo "note: web/dist is not built (cd web && npm ci && npm run build): the .deb has no page"
fi

# ---- the extracted package: ffd serve with no argument ----
X=$T/root
dpkg-deb -x "$DEB" "$X" || fail "dpkg-deb -x"
LIBDIR=$(dirname "$(find "$X/usr/lib" -name 'libffd.so.0' | head -1)")
zcat "$X/usr/share/man/man1/ffd.1.gz" | grep -q '^\.TH FFD 1' || fail "ffd.1.gz is not a man page"
# the extracted page and mesh are marked, so that serving the source tree's
# (compiled in as a fallback) would show
printf 'v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 1 2 3 4\nf 5 8 7 6\n' \
    >"$X/usr/share/ffd/examples/lattice/bunny.obj"
[ -f "$X/usr/share/ffd/web/index.html" ] && echo '<!-- the extracted .deb -->' >>"$X/usr/share/ffd/web/index.html"
LD_LIBRARY_PATH=$LIBDIR "$X/usr/bin/ffd" serve --port 0 >"$T/serve.out" 2>"$T/serve.err" &
PID=$!
URL=
for _ in $(seq 1 200); do
    URL=$(sed -n 's/^ffd serve: \(http:.*\)$/\1/p' "$T/serve.out")
    [ -n "$URL" ] && break
    kill -0 "$PID" 2>/dev/null || break
    sleep 0.05
done
if [ -z "$URL" ]; then
    fail "the extracted ffd serve printed no URL: $(cat "$T/serve.out" "$T/serve.err")"
else
    URL=${URL%/}
    code=$(curl -s --max-time 30 -o "$T/state" -w '%{http_code}' "$URL/api/state")
    [ "$code" = 200 ] && grep -q '"vertices":8,' "$T/state" ||
        fail "GET /api/state: $code, not the extracted bunny.obj: $(head -c 300 "$T/state")"
    code=$(curl -s --max-time 30 -o "$T/mesh" -w '%{http_code}' "$URL/api/export")
    [ "$code" = 200 ] && [ "$(grep -c '^v ' "$T/mesh")" = 8 ] ||
        fail "GET /api/export: $code, not the extracted bunny.obj: $(head -c 300 "$T/mesh")"
    code=$(curl -s --max-time 30 -o "$T/page" -w '%{http_code}' "$URL/")
    if [ "$PAGE" = 1 ]; then
        [ "$code" = 200 ] && grep -qF '<!-- the extracted .deb -->' "$T/page" ||
            fail "GET /: $code, not the extracted page: $(head -c 200 "$T/page")"
        code=$(curl -s --max-time 30 -o /dev/null -w '%{http_code}' "$URL/app.js")
        [ "$code" = 200 ] || fail "GET /app.js: $code"
        grep -q 'warning' "$T/serve.err" && fail "a warning with the page installed: $(cat "$T/serve.err")"
    else
        grep -qF "no index.html at $X/usr/bin/../share/ffd/web/index.html" "$T/serve.err" ||
            fail "no warning naming the missing page: $(cat "$T/serve.err")"
    fi
    kill -TERM "$PID"
    wait "$PID" || fail "ffd serve exited $? after SIGTERM: $(cat "$T/serve.err")"
    PID=
fi

[ "$failures" -eq 0 ] && echo "ok: the .deb (Depends, file list, extracted ffd serve$with)"
[ "$failures" -eq 0 ]
