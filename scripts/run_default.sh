#!/usr/bin/env bash
# Installs what snowsim needs, builds it and renders the default scene into out/: the flagship
# snowball smashed into a wall, with cracks that open, drawn as the snow's surface (the draft,
# at twice the flagship's cell: about 30 s on two cores).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
# --overwrite: a second call replaces the first call's frames (and no other file in out/).
./build/app/snowsim run scenes/flagship/smash_wall_cracks.json --scale 0.5 -o out --overwrite
echo "snowsim: PNG and PLY frames, flagship_smash_wall_cracks.mp4 and run.json written to $(pwd)/out"
