#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, -fsanitize=fuzzer,address,undefined,
# the project's sources compiled in) and runs each for SECONDS.
#   scripts/fuzz.sh [SECONDS] [TARGET...]      default: 30 seconds, every target
# Seeds: fuzz/corpus/<target> (hand-made cases and saved crash regressions)
# plus the meshes of data/ (those up to 1 MiB) for the mesh readers. The growing corpus
# is kept in build-fuzz/corpus/<target>; crashes go to build-fuzz/crashes/<target>/
# (copy each into fuzz/corpus/<target>/ once fixed: every build replays it).
# Prints one line per target: executions, coverage, corpus size.
# Exit status: 1 when a target found a crash, a leak or a timeout.
# FFD_FUZZ_SEED=N fixes libFuzzer's seed (CI's run: the same mutations in
# the same order on every run, so a CI result can be reproduced here with a
# fresh corpus directory: FFD_FUZZ_CORPUS=DIR); unset, each run explores anew.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
seconds=${1:-30}
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  targets=(fuzz_obj fuzz_ply fuzz_off fuzz_stl fuzz_gltf fuzz_vtk fuzz_vtu fuzz_msh fuzz_su2
           fuzz_xyz fuzz_npy fuzz_rig_json fuzz_rig_prm fuzz_session fuzz_http)
fi
build="$root/build-fuzz"
CC=clang cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFFD_FUZZ=ON \
    -DFFD_WERROR=OFF >/dev/null
cmake --build "$build" -j"$(nproc)" --target "${targets[@]}" >/dev/null
data="$root/data"
status=0
for t in "${targets[@]}"; do
  corpus="${FFD_FUZZ_CORPUS:-$build/corpus}/$t"
  crashes="$build/crashes/$t"
  mkdir -p "$corpus" "$crashes"
  seeds=("$root/fuzz/corpus/$t")
  case $t in
    fuzz_obj) ext=obj ;; fuzz_ply) ext=ply ;; fuzz_off) ext=off ;; fuzz_stl) ext=stl ;; fuzz_gltf) ext=glb ;;
    fuzz_vtk) ext=vtk ;; fuzz_vtu) ext=vtu ;; fuzz_msh) ext=msh ;; fuzz_su2) ext=su2 ;;
    fuzz_xyz) ext=xyz ;; fuzz_npy) ext=npy ;; *) ext= ;;
  esac
  if [ -n "$ext" ]; then
    mkdir -p "$build/seeds/$t"
    find "$data" "$data/volume" -maxdepth 1 -name "*.$ext" -size -2M -exec cp {} "$build/seeds/$t/" \;
    seeds+=("$build/seeds/$t")
  fi
  log="$build/$t.log"
  if ASAN_OPTIONS=detect_leaks=1 "$build/$t" -max_total_time="$seconds" -timeout=20 \
        -rss_limit_mb=2560 -max_len=1048576 -print_final_stats=1 ${FFD_FUZZ_SEED:+-seed="$FFD_FUZZ_SEED"} \
        -artifact_prefix="$crashes/" "$corpus" "${seeds[@]}" >"$log" 2>&1; then
    result=ok
  else
    result="FAILED (see $log; inputs in $crashes)"
    status=1
  fi
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo '?')
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || echo '?')
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || echo '?')
  size=$(find "$corpus" -type f | wc -l)
  printf '%-14s %8ss  %10s runs  cov %6s  ft %6s  corpus %5s  %s\n' "$t" "$seconds" "$runs" \
    "$cov" "$ft" "$size" "$result"
done
exit $status
