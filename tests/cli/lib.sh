# Shared prelude of the CLI test scripts (sourced, not run by ctest).
# usage in a script: source "$(dirname "$0")/lib.sh" "$@"   (args: PATH_TO_ffd SOURCE_DIR)
FFD=$1
SRC=$2
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
failures=0

fail() {
    echo "FAIL: $*"
    failures=$((failures + 1))
}

# ok ARGS...: runs ffd ARGS, expecting exit status 0; stdout in $T/stdout, stderr in $T/stderr.
ok() {
    "$FFD" "$@" >"$T/stdout" 2>"$T/stderr" || fail "ffd $* exited $?: $(cat "$T/stderr")"
}
# bad CODE ARGS...: runs ffd ARGS, expecting exit status CODE.
bad() {
    local code=$1
    shift
    "$FFD" "$@" >"$T/stdout" 2>"$T/stderr"
    local rc=$?
    [ "$rc" -eq "$code" ] || fail "ffd $* exited $rc, expected $code: $(cat "$T/stderr")"
}
has() { # has FILE FRAGMENT
    grep -qF -- "$2" "$T/$1" || fail "$1 lacks '$2': $(cat "$T/$1")"
}
