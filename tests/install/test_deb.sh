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
source "$SRC/tests/install/lib.sh"

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
# ffd, and ffd-mpi when the build has MPI (FFD_MPI, docs/mpi.md)
grep -E '^-rwxr-xr-x ' "$T/deb.list" | grep -vqE '/bin/ffd(-mpi)?$' &&
    fail "executable files besides ffd and ffd-mpi: $(grep -E '^-rwxr-xr-x ' "$T/deb.list" | grep -vE '/bin/ffd(-mpi)?$')"
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
check_serve_bundled "the extracted .deb" "$X/usr/share/ffd" env LD_LIBRARY_PATH="$LIBDIR" "$X/usr/bin/ffd"

[ "$failures" -eq 0 ] && echo "ok: the .deb (Depends, file list, extracted ffd serve$with)"
[ "$failures" -eq 0 ]
