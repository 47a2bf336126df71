#!/usr/bin/env bash
# The shared library exports exactly the public API: the functions that
# `nm -D --defined-only` lists in libffd.so are the functions declared in
# include/*.h, and each of those declarations is marked FFD_API.
# usage: bash check_exports.sh LIBFFD_SO INCLUDE_DIR
set -u
lib=$1
inc=$2
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
command -v nm >/dev/null || { echo "FAIL: nm is not installed (binutils)"; exit 1; }
[ -f "$lib" ] || { echo "FAIL: $lib: no such library"; exit 1; }
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT

# every identifier followed by '(' in the headers outside comments, types
# (typedefs of function pointers name '(*x)') and macros: the declared functions
strip() { # the headers' text without comments and preprocessor lines, one declaration a line
    sed -e 's://.*$::' "$inc"/*.h | perl -0777 -pe 's:/\*.*?\*/::gs; s/^\s*#.*$//mg; s/\s+/ /g; s/;/;\n/g; s/\{/{\n/g; s/\}/}\n/g'
}
strip | grep -v '^ *typedef' | grep -oE '\bffd_[A-Za-z0-9_]+ *\(' | sed 's/ *($//' | sort -u >"$T/declared"
strip | grep -v '^ *typedef' | grep -E '\bffd_[A-Za-z0-9_]+ *\(' | grep -v '^ *FFD_API ' >"$T/unmarked"
# functions (T, W, i); any other exported symbol is an error too, except the
# locks of named `#pragma omp critical` sections, which GCC makes global on purpose
nm -D --defined-only "$lib" | awk '$2 ~ /^[TWi]$/ {print $3}' | sort -u >"$T/exported"
nm -D --defined-only "$lib" | awk '$2 !~ /^[TWi]$/ {print $3}' | grep -v '^\.gomp_critical_user_' >"$T/data"

[ -s "$T/declared" ] || fail "no function declarations found in $inc/*.h"
[ -s "$T/unmarked" ] && fail "declarations without FFD_API in $inc/*.h:$(sed 's/^/\n  /' "$T/unmarked")"
extra=$(comm -13 "$T/declared" "$T/exported")
missing=$(comm -23 "$T/declared" "$T/exported")
[ -n "$extra" ] && fail "$lib exports symbols no public header declares:$(echo "$extra" | sed 's/^/\n  /')"
[ -s "$T/data" ] && fail "$lib exports data symbols:$(sed 's/^/\n  /' "$T/data")"
[ -n "$missing" ] && fail "$lib lacks declared public functions:$(echo "$missing" | sed 's/^/\n  /')"
if [ "$fails" -eq 0 ]; then
    echo "ok: $(wc -l <"$T/declared") public functions declared, marked and exported, nothing else"
fi
[ "$fails" -eq 0 ]
