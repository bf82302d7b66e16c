#!/usr/bin/env bash
# Configures and builds snowsim (Release) into build/. Usage: scripts/build.sh [extra cmake args]
set -euo pipefail
cd "$(dirname "$0")/.."
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
[ -f build/CMakeCache.txt ] && generator=()
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "${generator[@]}" "$@"
cmake --build build --parallel "$(nproc)"
