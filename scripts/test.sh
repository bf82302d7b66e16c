#!/usr/bin/env bash
# Installs what snowsim needs, builds it and runs every test. This is what CI runs.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
cd build && ctest --output-on-failure --parallel "$(nproc)"
