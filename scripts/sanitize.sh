#!/usr/bin/env bash
# Builds snowsim and its tests with sanitizers and runs the tests (docs/sanitizers.md).
# Usage: scripts/sanitize.sh [address | thread]
#   address (default): AddressSanitizer + UndefinedBehaviorSanitizer into build-asan/, every test
#   thread: ThreadSanitizer into build-tsan/, the tests labelled "threaded" (ctest -L threaded)
# Any report fails the test that made it (halt_on_error, -fno-sanitize-recover). Build and test
# jobs: SANITIZE_JOBS (default 2); CMAKE_CXX_COMPILER_LAUNCHER (e.g. ccache) is passed on.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=${SANITIZE_JOBS:-2}
mode=${1:-address}

case "$mode" in
  address)
    dir=build-asan sanitizers=address,undefined
    # every target; the tests run in full
    targets=() tests=()
    export ASAN_OPTIONS=detect_leaks=1:halt_on_error=1:abort_on_error=1
    export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
    export LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp:print_suppressions=0
    ;;
  thread)
    dir=build-tsan sanitizers=thread
    # The binaries holding THREADED_TEST declarations, and snowsim (tests/CMakeLists.txt)
    targets=(--target threaded_tests)
    tests=(-L threaded)
    export TSAN_OPTIONS=halt_on_error=1:abort_on_error=1:second_deadlock_stack=1
    # llvmpipe rasterises on the calling thread: its own workers meet through Mesa's atomics,
    # which TSan cannot see in the uninstrumented library (docs/sanitizers.md)
    export LP_NUM_THREADS=0
    ;;
  *)
    echo "scripts/sanitize.sh: '$mode' is neither address nor thread" >&2
    exit 2
    ;;
esac

generator=()
command -v ninja >/dev/null && [ ! -f "$dir/CMakeCache.txt" ] && generator=(-G Ninja)
cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Release "${generator[@]}" \
  -DSNOWSIM_SANITIZE="$sanitizers" -DSNOWSIM_BUILD_BENCH=OFF \
  ${CMAKE_CXX_COMPILER_LAUNCHER:+-DCMAKE_CXX_COMPILER_LAUNCHER=$CMAKE_CXX_COMPILER_LAUNCHER} \
  >/dev/null
cmake --build "$dir" --parallel "$jobs" "${targets[@]}"
cd "$dir"
run_tests() { ctest --output-on-failure --parallel "$jobs" --timeout 1800 "$@"; }
if [ "$mode" = address ]; then
  # Open MPI's own allocations are told apart by the libraries on their stacks, which the fast
  # unwinder does not reach through its plugins (tests/lsan.supp): the MPI tests unwind in full.
  status=0
  run_tests -LE mpi || status=$?
  ASAN_OPTIONS=$ASAN_OPTIONS:fast_unwind_on_malloc=0 run_tests -L mpi || status=$?
  exit "$status"
fi
run_tests "${tests[@]}"
