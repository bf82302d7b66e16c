#!/bin/sh
# Measures what "model no more than a scene needs" saves (docs/study.md): each choice snowsim
# makes against its naive alternative, as median wall times of 3 runs (run.json's wall_time).
#   1. a 2D scene in 2D against the same scene as the report ran it, a one-cell 3D slab;
#   2. MPM's grid stages on the nodes the snow can reach, shown by growing the domain around
#      the same snowball (the report's method still sweeps its whole grid: the contrast);
#   3. MPM's adaptive step at the stability limit against a fixed small step.
# Usage: scripts/savings.sh [path/to/snowsim]
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
snowsim=${1:-$root/build/app/snowsim}
[ -x "$snowsim" ] || { echo "savings: no snowsim at $snowsim (build first)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# median_wall SCENE [--set ...]: median wall time (s) and steps of 3 runs without outputs.
median_wall() {
  scene=$1
  shift
  for r in 1 2 3; do
    "$snowsim" run "$root/scenes/$scene.json" -o "$work/run" --overwrite --no-ply --no-png --no-mp4 "$@" \
      >/dev/null
    sed -n 's/.*"wall_time": \([0-9.e-]*\).*/\1/p' "$work/run/run.json"
  done | sort -g | sed -n 2p | tr '\n' ' '
  sed -n 's/.*"steps": \([0-9]*\).*/\1 steps/p' "$work/run/run.json"
}

echo "1. 2D against the report's one-cell 3D slab (1 s simulated)"
for solver in density_hybrid mpm; do
  for scene in snowball_drop column_thrown_ball; do
    echo "  $scene $solver 2D: $(median_wall $scene --set solver=$solver)"
    echo "  $scene $solver slab: $(median_wall $scene --set solver=$solver --set dimension=3)"
  done
done

echo "2. The same snowball in a larger domain (cells 10x12, 20x24, 40x48, 80x96; 1 s)"
for solver in density_hybrid mpm; do
  for cells in 10,12 20,24 40,48 80,96; do
    echo "  snowball_drop $solver [$cells]: $(median_wall snowball_drop --set solver=$solver \
      --set "grid.cells=[$cells]")"
  done
done

echo "3. MPM time step: adaptive at the CFL limit against fixed (snowball drop, 1 s)"
echo "  adaptive (mpm.cfl 0.9): $(median_wall snowball_drop --set solver=mpm)"
for dt in 0.0007 0.0001; do
  echo "  fixed dt $dt: $(median_wall snowball_drop --set solver=mpm \
    --set mpm.adaptive_dt=false --set time.dt=$dt)"
done
