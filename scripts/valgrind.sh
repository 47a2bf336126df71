#!/usr/bin/env bash
# Runs the release test binaries under valgrind memcheck: no invalid access,
# no use of uninitialised values, no definite or indirect leak (exit 99 on any).
#   scripts/valgrind.sh [BUILD_DIR] [TEST...]   (default: build, every build/test_*)
# OMP_NUM_THREADS=1: memcheck serialises threads anyway, and one thread keeps
# libgomp's thread pool (and OpenBLAS's, OPENBLAS_NUM_THREADS=1) out of the
# picture. FFD_VALGRIND_SKIP (space-separated names; default: test_alloc_sweep,
# thousands of failing runs that take over 15 minutes under memcheck and are
# checked by their own live-block count and by LeakSanitizer in the ASan
# build) leaves tests out; see docs/reliability.md ("Allocation failures and
# valgrind").
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
shift || true
command -v valgrind >/dev/null || { echo "valgrind: not installed (scripts/setup.sh)" >&2; exit 1; }
if [ $# -gt 0 ]; then
  tests=("$@")
else
  tests=()
  for t in "$build"/test_*; do
    [ -x "$t" ] && [ -f "$t" ] && tests+=("$(basename "$t")")
  done
fi
supp=()
[ -s "$root/scripts/valgrind.supp" ] && supp=(--suppressions="$root/scripts/valgrind.supp")
# FFD_TEST_QUICK: tests that loop over many rigs (test_deformer) run one per
# method under memcheck; the release and sanitizer builds run them all.
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 FFD_TEST_QUICK=1
skip=${FFD_VALGRIND_SKIP-test_alloc_sweep}
failed=()
start=$(date +%s)
for t in "${tests[@]}"; do
  case " $skip " in *" $t "*) echo "== $t: skipped (FFD_VALGRIND_SKIP)"; continue ;; esac
  t0=$(date +%s)
  log="$build/valgrind-$t.log"
  if (cd "$build" && valgrind --tool=memcheck --leak-check=full \
        --errors-for-leak-kinds=definite,indirect --show-leak-kinds=definite,indirect \
        --error-exitcode=99 --num-callers=30 "${supp[@]}" --log-file="$log" \
        "./$t" >"$build/valgrind-$t.out" 2>&1); then
    echo "== $t: ok ($(( $(date +%s) - t0 )) s)"
  else
    rc=$?
    echo "== $t: FAILED (exit $rc, $(( $(date +%s) - t0 )) s); valgrind log: $log" >&2
    grep -E "ERROR SUMMARY|definitely lost|indirectly lost|Invalid|uninitialised" "$log" | head -20 >&2 || true
    tail -5 "$build/valgrind-$t.out" >&2 || true
    failed+=("$t")
  fi
done
echo "valgrind: ${#tests[@]} test binaries in $(( $(date +%s) - start )) s"
if [ ${#failed[@]} -gt 0 ]; then
  echo "valgrind: failed: ${failed[*]}" >&2
  exit 1
fi
