#!/usr/bin/env bash
# Installing and linking libffd (README "Install" and "Link", docs/api.md
# "Linking"): the shared library exports only the public API
# (check_exports.sh); `cmake --install` into a temporary prefix installs the
# libraries, headers, ffd.pc, the CMake package, ffd, the page (when web/dist
# is built) and the example meshes; a program built with pkg-config (shared)
# and one built with find_package(ffd) (ffd::ffd, and ffd::ffd_static) run
# and deform a cube; the installed `ffd serve` with no mesh opens its
# installed bunny and serves its page and /api/state (or, when the page was
# never built, warns naming the paths it tried). The .deb: test_deb.sh.
# Nothing is installed outside the temporary directory.
# usage: bash test_install.sh BUILD_DIR SOURCE_DIR [SANITIZER_FLAGS]
set -u
BUILD=$(cd "$1" && pwd)
SRC=$(cd "$2" && pwd)
SAN=${3:-}
source "$SRC/tests/install/lib.sh"
for tool in cc pkg-config curl cmake; do
    command -v $tool >/dev/null || { echo "FAIL: $tool is not installed (scripts/setup.sh)"; exit 1; }
done

bash "$SRC/tests/install/check_exports.sh" "$BUILD/libffd.so" "$SRC/include" || fail "exports"

# ---- cmake --install into a temporary prefix ----
P=$T/prefix
cmake --install "$BUILD" --prefix "$P" >"$T/install.log" 2>&1 || fail "cmake --install: $(cat "$T/install.log")"
LIBDIR=$(dirname "$(find "$P" -name 'libffd.so.0' | head -1)")
[ -d "$LIBDIR" ] || { fail "no libffd.so.0 under $P: $(cd "$P" && find . | head -50)"; exit 1; }
for f in "$LIBDIR/libffd.so" "$LIBDIR/libffd.a" "$LIBDIR/pkgconfig/ffd.pc" \
    "$LIBDIR/cmake/ffd/ffdConfig.cmake" "$LIBDIR/cmake/ffd/ffdConfigVersion.cmake" \
    "$LIBDIR/cmake/ffd/ffdTargets.cmake" "$P/include/ffd.h" "$P/include/ffd_lattice.h" \
    "$P/include/ffd_methods.h" "$P/bin/ffd" "$P/share/ffd/examples/lattice/bunny.obj"; do
    [ -e "$f" ] || fail "not installed: ${f#"$P"/}"
done
PAGE=0
if [ -f "$SRC/web/dist/index.html" ]; then
    PAGE=1
    [ -f "$P/share/ffd/web/index.html" ] || fail "web/dist is built but share/ffd/web/index.html is not installed"
fi
readelf -d "$LIBDIR/libffd.so.0" 2>/dev/null | grep -q 'SONAME.*libffd\.so\.0' ||
    fail "libffd.so.0 has no soname libffd.so.0: $(readelf -d "$LIBDIR/libffd.so.0" | grep SONAME)"

# ---- a program linked with pkg-config (the shared library) ----
export PKG_CONFIG_PATH=$LIBDIR/pkgconfig
# shellcheck disable=SC2046,SC2086
cc -std=c11 $SAN -o "$T/cube_pc" "$SRC/tests/install/cube.c" $(pkg-config --cflags --libs ffd) -lm \
    2>"$T/cc.err" || fail "cc with pkg-config ffd: $(cat "$T/cc.err")"
if [ -x "$T/cube_pc" ]; then
    readelf -d "$T/cube_pc" | grep -q 'NEEDED.*libffd\.so\.0' || fail "cube_pc is not linked to libffd.so.0"
    LD_LIBRARY_PATH=$LIBDIR "$T/cube_pc" >"$T/pc.out" 2>&1 || fail "cube (pkg-config): $(cat "$T/pc.out")"
    grep -q 'corner x 1.5, centre x 0.5625' "$T/pc.out" || fail "cube (pkg-config) printed: $(cat "$T/pc.out")"
fi
# the static library with pkg-config --static
# shellcheck disable=SC2046,SC2086
cc -std=c11 $SAN -o "$T/cube_pc_static" "$SRC/tests/install/cube.c" "$LIBDIR/libffd.a" \
    $(pkg-config --cflags --libs --static ffd | sed 's/-lffd//') -lm 2>"$T/cc.err" ||
    fail "cc with pkg-config --static ffd: $(cat "$T/cc.err")"
if [ -x "$T/cube_pc_static" ]; then
    "$T/cube_pc_static" >"$T/pcs.out" 2>&1 || fail "cube (pkg-config --static): $(cat "$T/pcs.out")"
fi

# ---- a CMake project with find_package(ffd) (tests/install/CMakeLists.txt) ----
for target in ffd::ffd ffd::ffd_static; do
    B=$T/cmake-${target#ffd::}
    cmake -S "$SRC/tests/install" -B "$B" -DCMAKE_PREFIX_PATH="$P" -DFFD_TARGET=$target \
        -DCMAKE_C_FLAGS="$SAN" -DCMAKE_EXE_LINKER_FLAGS="$SAN" >"$T/cm.log" 2>&1 &&
        cmake --build "$B" >>"$T/cm.log" 2>&1 || { fail "find_package(ffd) with $target: $(tail -30 "$T/cm.log")"; continue; }
    "$B/cube" >"$T/cm.out" 2>&1 || fail "cube ($target): $(cat "$T/cm.out")"
    grep -q 'corner x 1.5, centre x 0.5625' "$T/cm.out" || fail "cube ($target) printed: $(cat "$T/cm.out")"
done
readelf -d "$T/cmake-ffd/cube" 2>/dev/null | grep -q 'NEEDED.*libffd\.so\.0' ||
    fail "find_package(ffd)'s ffd::ffd is not the shared library"

# ---- the installed ffd serve, no mesh argument ----
check_serve_bundled "the installed ffd" "$P/share/ffd" "$P/bin/ffd"

[ "$failures" -eq 0 ] && echo "ok: install, link (pkg-config, find_package), serve"
[ "$failures" -eq 0 ]
