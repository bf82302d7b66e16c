#!/usr/bin/env bash
# Builds snowsim and every test with AddressSanitizer + UndefinedBehaviorSanitizer into build-asan/
# and runs the tests (docs/sanitizers.md). Usage: scripts/sanitize.sh
# Any report fails the test that made it (halt_on_error, -fno-sanitize-recover). Build and test
# jobs: SANITIZE_JOBS (default 2); CMAKE_CXX_COMPILER_LAUNCHER (e.g. ccache) is passed on.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=${SANITIZE_JOBS:-2}

generator=()
command -v ninja >/dev/null && [ ! -f build-asan/CMakeCache.txt ] && generator=(-G Ninja)
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Release "${generator[@]}" \
  -DSNOWSIM_SANITIZE=address,undefined -DSNOWSIM_BUILD_BENCH=OFF \
  ${CMAKE_CXX_COMPILER_LAUNCHER:+-DCMAKE_CXX_COMPILER_LAUNCHER=$CMAKE_CXX_COMPILER_LAUNCHER} \
  >/dev/null
cmake --build build-asan --parallel "$jobs"
export ASAN_OPTIONS=detect_leaks=1:halt_on_error=1:abort_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp:print_suppressions=0
cd build-asan && ctest --output-on-failure --parallel "$jobs" --timeout 1800
