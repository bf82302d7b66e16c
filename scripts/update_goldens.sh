#!/bin/sh
# Regenerates the golden images of tests/render/golden/ from tests/render/golden/cases.txt with the built
# snowsim. Run it on purpose, after a change that is meant to alter the pictures, and look at
# every image before committing. The tests never write to tests/render/golden/.
# Usage: scripts/update_goldens.sh [path/to/snowsim]
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
snowsim=${1:-$root/build/app/snowsim}
[ -x "$snowsim" ] || { echo "update_goldens: no snowsim at $snowsim (build first)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
grep -v '^#' "$root/tests/render/golden/cases.txt" | while IFS='|' read -r name scene options; do
  # shellcheck disable=SC2086 # options is a list of words
  "$snowsim" run "$root/scenes/$scene.json" -o "$work/$name" --no-ply --no-mp4 $options
  cp "$work/$name/frame_00001.png" "$root/tests/render/golden/$name.png"
  echo "update_goldens: wrote tests/render/golden/$name.png"
done
