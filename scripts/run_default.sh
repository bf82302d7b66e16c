#!/usr/bin/env bash
# Installs what snowsim needs, builds it and renders the default scene (the report's Fig. 1,
# a snowball dropped on the ground) into out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
# --overwrite: a second call replaces the first call's frames (and no other file in out/).
./build/app/snowsim run scenes/snowball_drop.json -o out --overwrite
echo "snowsim: PNG and PLY frames, snowball_drop.mp4 and run.json written to $(pwd)/out"
