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
