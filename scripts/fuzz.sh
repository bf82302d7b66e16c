#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ with clang into build-fuzz/ and runs one (scene, ply, png,
# checkpoint) or all of them for SECONDS each, or until RUNS executions if given first.
# Usage: scripts/fuzz.sh [TARGET|all] [SECONDS] [RUNS]
# The seed corpus (fuzz/corpus/TARGET) is copied into build-fuzz/corpus/TARGET, which grows; a crash
# is written to build-fuzz/crashes/TARGET/ and fails the script. Each run ends with libFuzzer's
# statistics (stat::number_of_executed_units: the executions).
set -euo pipefail
cd "$(dirname "$0")/.."
target=${1:-all}
seconds=${2:-60}
runs=${3:--1}
case "$target" in
  all) targets=(scene ply png checkpoint) ;;
  scene | ply | png | checkpoint) targets=("$target") ;;
  *) echo "fuzz.sh: unknown target $target; allowed: scene, ply, png, checkpoint, all" >&2; exit 2 ;;
esac

cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=clang++ \
  -DSNOWSIM_FUZZ=ON -DSNOWSIM_BUILD_TESTS=OFF \
  -DSNOWSIM_BUILD_BENCH=OFF ${CMAKE_CXX_COMPILER_LAUNCHER:+-DCMAKE_CXX_COMPILER_LAUNCHER=$CMAKE_CXX_COMPILER_LAUNCHER} >/dev/null
cmake --build build-fuzz --parallel "${FUZZ_BUILD_JOBS:-2}" --target "${targets[@]/%/_fuzzer}"

for t in "${targets[@]}"; do
  corpus=build-fuzz/corpus/$t crashes=build-fuzz/crashes/$t/
  mkdir -p "$corpus" "$crashes"
  cp -n fuzz/corpus/"$t"/* "$corpus"/
  dict=()
  [ -f fuzz/"$t".dict ] && dict=(-dict=fuzz/"$t".dict)
  echo "== $t: $seconds s"
  # -rss_limit_mb: a reader must not need more than the largest real input does.
  log=build-fuzz/$t.log
  ./build-fuzz/fuzz/"$t"_fuzzer "$corpus" "${dict[@]}" -max_total_time="$seconds" -runs="$runs" \
    -print_final_stats=1 -rss_limit_mb=2048 -timeout=10 -artifact_prefix="$crashes" \
    >"$log" 2>&1 || true
  grep -E '^stat::(number_of_executed_units|average_exec_per_sec|peak_rss_mb)' "$log"
  if compgen -G "$crashes*" >/dev/null; then
    grep -A40 -E '^==[0-9]+==ERROR|runtime error|^SUMMARY' "$log" | head -60 >&2
    echo "fuzz.sh: $t found crashing inputs in $crashes (log: $log)" >&2
    exit 1
  fi
done
