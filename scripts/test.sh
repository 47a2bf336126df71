#!/usr/bin/env bash
# Installs what is needed, builds, and runs the whole test suite: a release
# build (then its test binaries under valgrind memcheck), an AddressSanitizer +
# UndefinedBehaviorSanitizer build, and every libFuzzer target for 30 seconds.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/setup.sh" --test
jobs=$(nproc)
echo "== release build and tests"
bash "$root/scripts/build.sh" "$root/build"
(cd "$root/build" && ctest --output-on-failure -j"$jobs")
echo "== valgrind memcheck (release test binaries)"
bash "$root/scripts/valgrind.sh" "$root/build"
echo "== ASan + UBSan build and tests"
bash "$root/scripts/build.sh" "$root/build-asan" -DCMAKE_BUILD_TYPE=Debug -DFFD_SANITIZE=ON
(cd "$root/build-asan" && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
    ctest --output-on-failure -j"$jobs")
echo "== fuzzing: every libFuzzer target for 30 seconds (scripts/fuzz.sh)"
FFD_FUZZ_SEED=${FFD_FUZZ_SEED:-1} bash "$root/scripts/fuzz.sh" 30
echo "all tests passed (release and sanitizer builds, fuzzing)"
