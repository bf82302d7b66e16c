#!/usr/bin/env bash
# Runs every shipped scene, and variants of the solvers' settings and of the MPM step's parts (open
# cracks, auto-sleep, precision, two MPI ranks), with two snowsim binaries and compares their PLY
# frames byte for byte: the check that a change of code changed no result.
# Usage: scripts/compare_frames.sh OLD_SNOWSIM NEW_SNOWSIM [WORK_DIR]
# Prints one line per case and exits 1 if any frame differs, 2 on bad arguments.
set -uo pipefail
usage() {
  echo "usage: scripts/compare_frames.sh OLD_SNOWSIM NEW_SNOWSIM [WORK_DIR]" >&2
  exit 2
}
if [ $# -lt 2 ] || [ $# -gt 3 ]; then usage; fi
# Paths are the caller's: resolved before the cd to the sources.
for binary in "$1" "$2"; do
  if [ ! -x "$binary" ]; then
    echo "compare_frames.sh: $binary is not an executable" >&2
    usage
  fi
done
old=$(realpath -e "$1")
new=$(realpath -e "$2")
work=$(realpath -m "${3:-$(mktemp -d)}")
cd "$(dirname "$0")/.."
mkdir -p "$work"

cases=()
for scene in scenes/*.json; do
  [ "$(basename "$scene")" = figures.json ] && continue
  cases+=("$scene --set time.duration=0.3")
done
fine2d=(--set 'grid.cells=[40,48]' --set grid.cell_size=0.0025)  # enough particles for threads
cases+=(
  "scenes/snowball_drop.json --set dimension=3 --set time.duration=0.3"
  "scenes/column_thrown_ball.json --set solver=mpm --set time.duration=0.3"
  "scenes/mpm_reference.json ${fine2d[*]} --set time.duration=0.2"
  "scenes/mpm_reference.json ${fine2d[*]} --set time.duration=0.2 --set mpm.transfer=apic"
  "scenes/mpm_reference.json ${fine2d[*]} --set time.duration=0.2 --set mpm.transfer=pic_flip"
  "scenes/mpm_reference.json ${fine2d[*]} --set time.duration=0.2 --set mpm.kernel=cubic"
  "scenes/mpm_reference.json --set time.duration=0.3 --set mpm.adaptive_dt=false --set time.dt=0.0004"
  "scenes/mpm_reference.json --set time.duration=0.3 --set mpm.integrator=semi_implicit --set mpm.adaptive_dt=false --set time.dt=0.002"
  "scenes/mpm_reference.json --set time.duration=0.3 --set mpm.initial_volume=grid_density"
  "scenes/mpm_snowball_wall.json --set time.duration=0.2 --set mpm.transfer=apic --set mpm.kernel=cubic"
  "scenes/mpm_snowball_drop_3d.json --set time.duration=0.1 --set mpm.integrator=semi_implicit --set mpm.adaptive_dt=false --set time.dt=0.002"
  "scenes/study_smash_3d.json --set mpm.transfer=pic_flip"
  # the step's parts: open cracks (2D double, 3D float), auto-sleep on and off, float and double
  "scenes/mpm_reference.json ${fine2d[*]} --set time.duration=0.2 --set material.fracture_strain=0.3 --set mpm.open_cracks=true --set mpm.transfer=mls"
  "scenes/flagship/smash_wall_cracks.json --scale 0.5 --set time.duration=0.1"
  "scenes/flagship/smash_wall_cracks.json --scale 0.25 --set time.duration=0.2"
  "scenes/flagship/drop_on_box.json --scale 0.25 --set time.duration=0.3"
  "scenes/flagship/drop_on_box.json --scale 0.25 --set time.duration=0.3 --set mpm.auto_sleep.enabled=false"
  "scenes/mpm_snowball_drop_3d.json --set time.duration=0.2 --set mpm.precision=double"
  "scenes/mpm_snowball_drop_3d.json --set time.duration=0.2 --set mpm.auto_sleep.enabled=true"
)
# The same across two MPI ranks (mpirun, in a build with MPI).
mpi_cases=(
  "scenes/mpm_snowball_drop_3d.json --set time.duration=0.2"
  "scenes/flagship/drop_on_box.json --scale 0.25 --set time.duration=0.3"
)
launchers=()
for c in "${cases[@]}"; do launchers+=(""); done
if command -v mpirun >/dev/null; then
  for c in "${mpi_cases[@]}"; do
    cases+=("$c")
    launchers+=("mpirun --allow-run-as-root --oversubscribe -np 2")
  done
fi

failed=0
n=0
for i in "${!cases[@]}"; do
  c=${cases[$i]}
  launch=${launchers[$i]}
  for threads in 1 2; do
    n=$((n + 1))
    for which in old new; do
      dir="$work/$n-$which"
      rm -rf "$dir"
      bin=$old
      [ $which = new ] && bin=$new
      # shellcheck disable=SC2086
      OMP_NUM_THREADS=$threads $launch "$bin" run $c -o "$dir" --no-png --no-mp4 >"$dir.log" 2>&1
      echo "exit $?" >>"$dir.log"
    done
    frames=$(ls "$work/$n-old"/*.ply 2>/dev/null | wc -l)
    same=yes
    for f in "$work/$n-old"/*.ply; do
      cmp -s "$f" "$work/$n-new/$(basename "$f")" || same=no
    done
    [ "$(ls "$work/$n-new"/*.ply 2>/dev/null | wc -l)" = "$frames" ] || same=no
    [ "$(tail -1 "$work/$n-old.log")" = "$(tail -1 "$work/$n-new.log")" ] || same=no
    [ $same = yes ] || failed=1
    printf '%-4s %s%s threads=%d frames=%d %s\n' "$same" "${launch:+$launch: }" "$c" "$threads" "$frames" \
      "$(tail -1 "$work/$n-new.log")"
  done
done
exit $failed
