#!/bin/sh
# Regenerates every chart of docs/study.md from the study's CSV (snowsim study -o CSV).
# Usage: scripts/charts.sh [results.csv] [output dir]
set -eu
csv=${1:-docs/study/results.csv}
out=${2:-docs/charts}
[ -r "$csv" ] || { echo "charts: cannot read $csv (run: snowsim study -o $csv)" >&2; exit 2; }
mkdir -p "$out"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Columns: 1 build 2 scene 3 solver 4 dt 5 refine 6 ppc 7 duration 8 cell_size 9 status
# 10 wall_s 11 steps 12 particles 13 err_density 14 err_height_m 15 err_com_m 16 free_fall_err_m
# Only the latest build's rows are drawn.
build=$(tail -n 1 "$csv" | cut -d, -f1)
awk -F, -v b="$build" 'NR > 1 && $1 == b' "$csv" > "$work/rows"
for scene in snowball_drop column_thrown_ball; do
  awk -F, -v s=$scene '$2 == s && $13 != "" {print $10, $13, $15}' "$work/rows" > "$work/$scene.cost"
  # Pareto front: sorted by wall time, keep each run that beats every faster one.
  sort -g "$work/$scene.cost" | awk 'NR == 1 || $2 < best {best = $2; print}' > "$work/$scene.front"
  awk -F, -v s=$scene '$2 == s && $5 == 1 && $6 == 9 && $13 != "" {print $4, $13, $15, $16}' \
    "$work/rows" | sort -g > "$work/$scene.dt"
  awk -F, -v s=$scene '$2 == s && $4 == 0.0005 && $6 == 9 && $13 != "" {print $8, $13, $15}' \
    "$work/rows" | sort -g > "$work/$scene.h"
  awk -F, -v s=$scene '$2 == s && $4 == 0.001 {print $12, $10}' "$work/rows" > "$work/$scene.n"
  awk -F, -v s=$scene '$2 == s && $4 == 0.001 && $5 == 1 && $6 == 9 {print $10}' "$work/rows" \
    > "$work/$scene.table1"
done

cd "$work"
gnuplot <<GP
set terminal pngcairo size 720,480 font ",10"
set key top right
set grid

set output "$OLDPWD/$out/error_vs_walltime.png"
set key bottom left opaque box
set title "Error against wall time (density field vs reference; line: Pareto front)"
set logscale xy
set xlabel "wall time (s)"; set ylabel "density-field error (half L1 of mass fractions)"
plot "snowball_drop.cost" u 1:2 w p pt 7 lc rgb "#1f77b4" t "density\\\_hybrid: snowball drop", \
     "snowball_drop.front" u 1:2 w steps lc rgb "#1f77b4" notitle, \
     "column_thrown_ball.cost" u 1:2 w p pt 5 lc rgb "#d62728" t "density\\\_hybrid: thrown ball", \
     "column_thrown_ball.front" u 1:2 w steps lc rgb "#d62728" notitle

set output "$OLDPWD/$out/error_vs_dt.png"
set key bottom right opaque box
set title "Convergence in the time step (cell 0.01 m, 9 particles per cell)"
set xlabel "dt (s)"; set ylabel "error"
plot "snowball_drop.dt" u 1:4 w lp pt 7 t "free-fall error (m), snowball drop", \
     "snowball_drop.dt" u 1:3 w lp pt 5 t "centre-of-mass path error (m), snowball drop", \
     "column_thrown_ball.dt" u 1:3 w lp pt 9 t "centre-of-mass path error (m), thrown ball", \
     x * 0.07 dt 2 lc rgb "gray" t "first order (slope 1)"

set output "$OLDPWD/$out/error_vs_cellsize.png"
set title "Error against cell size (dt 0.0005 s, 9 particles per cell)"
set xlabel "cell size (m)"; set ylabel "error"
plot "snowball_drop.h" u 1:2 w lp pt 7 t "density field, snowball drop", \
     "column_thrown_ball.h" u 1:2 w lp pt 5 t "density field, thrown ball", \
     "snowball_drop.h" u 1:3 w lp pt 9 t "centre of mass (m), snowball drop", \
     "column_thrown_ball.h" u 1:3 w lp pt 11 t "centre of mass (m), thrown ball"

unset logscale
set output "$OLDPWD/$out/walltime_vs_particles.png"
set title "Wall time against particle count (1 s simulated, dt 0.001 s)"
set xlabel "particles"; set ylabel "wall time (s)"
f(x) = a * x + b
a = 1e-4; b = 1e-3
set fit quiet logfile "/dev/null"
fit f(x) "< cat snowball_drop.n column_thrown_ball.n" u 1:2 via a, b
plot "snowball_drop.n" u 1:2 w p pt 7 t "snowball drop", \
     "column_thrown_ball.n" u 1:2 w p pt 5 t "thrown ball", \
     f(x) lc rgb "black" t sprintf("fit: %.3g s per particle + %.3g s", a, b)

set output "$OLDPWD/$out/table1.png"
set title "Report Table 1 (1 s simulated, i3-2100) beside snowsim (dt 0.001, 9 per cell)"
set style data histograms; set style fill solid 0.8; set boxwidth 0.8
set logscale y; set ylabel "wall time (s)"; set xlabel ""
set key top left
\$table << EOD
"snowball drop" 45.3 $(cat snowball_drop.table1)
"thrown ball" 138 $(cat column_thrown_ball.table1)
EOD
plot \$table u 2:xtic(1) t "report", "" u 3 t "snowsim"
GP
echo "charts: wrote $(ls "$OLDPWD/$out" | tr '\n' ' ')in $out"
