#!/bin/sh
# Regenerates the charts of docs/study.md from the study's CSVs (snowsim study -o CSV).
# Usage: scripts/charts.sh [results.csv] [stability.csv] [output dir] [axes.csv]
# A chart whose rows are missing from the CSV is left as it is (and said so).
set -eu
csv=${1:-docs/study/results.csv}
stability=${2:-docs/study/stability.csv}
out=${3:-docs/charts}
axes=${4:-docs/study/axes.csv}
[ -r "$csv" ] || { echo "charts: cannot read $csv (run: snowsim study -o $csv)" >&2; exit 2; }
mkdir -p "$out"
out=$(cd "$out" && pwd)
[ -r "$stability" ] && stability=$(cd "$(dirname "$stability")" && pwd)/$(basename "$stability")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
touch "$work/axes_rows"

# Columns: 1 build 2 scene 3 solver 4 dt 5 refine 6 ppc 7 duration 8 E0 9 cell_size 10 status
# 11 wall_s 12 steps 13 particles 14 err_density 15 err_height_m 16 err_com_m 17 free_fall_err_m
# 18 ball_past_tower_m 19 pile_height_m 20 claim 21 message. Only the latest build's rows are
# drawn.
latest() { awk -F, -v b="$(tail -n 1 "$1" | cut -d, -f1)" 'NR > 1 && $1 == b' "$1"; }
latest "$csv" > "$work/rows"
[ -r "$axes" ] && latest "$axes" > "$work/axes_rows"
solvers="density_hybrid mpm_pic_flip mpm_apic mpm_mls mpm_apic_semi mpm_mls_semi"
for s in $solvers; do
  # error against wall time, every scene of the 2D report
  awk -F, -v s=$s '$3 == s && $14 != "" && $2 != "study_smash_3d" {print $11, $14}' \
    "$work/rows" > "$work/$s.cost"
  # convergence in dt: the free-fall error (exact answer) of the snowball drop, base grid, 9 per cell
  awk -F, -v s=$s '$3 == s && $2 == "snowball_drop" && $5 == 1 && $6 == 9 && $17 != "" \
    {print $4, $17}' "$work/rows" | sort -g > "$work/$s.dt"
  # convergence in the cell size: the smallest dt of the sweep, 9 per cell
  awk -F, -v s=$s '$3 == s && $2 == "snowball_drop" && $6 == 9 && $14 != "" {print $4, $9, $14}' \
    "$work/rows" | sort -g | awk 'NR == 1 {d = $1} $1 == d {print $2, $3}' | sort -g \
    > "$work/$s.h"
  # cost against particle count: every scene and resolution at one dt, runs that finished
  awk -F, -v s=$s '$3 == s && $4 == 0.0005 && $10 == "finished" {print $13, $11 / $12 * 1000}' \
    "$work/rows" > "$work/$s.n"
done
awk '{print}' "$work"/*.cost | sort -g | awk 'NR == 1 || $2 < best {best = $2; print}' \
  > "$work/front"
awk -F, '$3 == "density_hybrid" && $2 == "snowball_drop" && $4 == 0.001 && $5 == 1 && $6 == 9 {print $11 / $7}' \
  "$work/rows" | head -n 1 > "$work/table1.drop"
awk -F, '$3 == "density_hybrid" && $2 == "column_thrown_ball" && $4 == 0.001 && $5 == 1 && $6 == 9 {print $11 / $7}' \
  "$work/rows" | head -n 1 > "$work/table1.ball"

# The report's Fig. 6 claim: pile heights of critical density x2, x4, x8 against dt, 9 per cell.
for x in 2 4 8; do
  awk -F, -v s=critical_density_x$x '$2 == s && $6 == 9 && $19 != "" {print $4, $19 * 1000}' \
    "$work/rows" | sort -g > "$work/pile.x$x"
done
awk -F, '$2 == "critical_density_x8" && $20 != "" {print $4, $20}' "$work/rows" | sort -g |
  awk '{n[$1]++; if ($2 == "pass") p[$1]++} END {for (d in n) printf "%s %d %d\n", d, p[d], n[d]}' |
  sort -g > "$work/pile.claim"

plots=""
series() {  # series EXT STYLE: a gnuplot plot list of the solvers that have rows
  list=""
  for s in $solvers; do
    [ -s "$work/$s.$1" ] || continue
    title=$s
    list="$list${list:+, }\"$s.$1\" u 1:2 $2 t \"$title\""
  done
  echo "$list"
}

cd "$work"
{
  echo 'set terminal pngcairo size 760,500 font ",10" noenhanced'
  echo 'set grid; set key outside right'
  if [ -s front ]; then
    echo "set output '$out/error_vs_walltime.png'"
    echo 'set title "Error against wall time, 2D report scenes (line: Pareto front)"'
    echo 'set logscale xy; set xlabel "wall time (s)"; set ylabel "density-field error vs reference"'
    echo "plot $(series cost 'w p pt 7'), 'front' u 1:2 w steps lc rgb 'black' t 'Pareto front'"
    plots="$plots error_vs_walltime"
  fi
  if [ -n "$(series dt 'w lp')" ]; then
    echo "set output '$out/error_vs_dt.png'"
    echo 'set title "Convergence in dt: free fall against the exact parabola (snowball drop, 9 per cell)"'
    echo 'set logscale xy; set xlabel "dt (s)"; set ylabel "free-fall error (m)"'
    echo "plot $(series dt 'w lp pt 7'), x * 0.5 dt 2 lc rgb 'gray' t 'slope 1'"
    plots="$plots error_vs_dt"
  fi
  if [ -n "$(series h 'w lp')" ]; then
    echo "set output '$out/error_vs_cellsize.png'"
    echo 'set title "Convergence in the cell size (snowball drop, dt 1e-4, 9 per cell)"'
    echo 'set logscale xy; set xlabel "cell size (m)"; set ylabel "density-field error"'
    echo "plot $(series h 'w lp pt 7')"
    plots="$plots error_vs_cellsize"
  fi
  if [ -n "$(series n 'w p')" ]; then
    echo "set output '$out/walltime_vs_particles.png'"
    echo 'set title "Cost per step against particle count (dt 5e-4, every scene and resolution)"'
    echo 'unset logscale; set logscale xy; set xlabel "particles"; set ylabel "ms per step"'
    echo 'f(x) = a * x; a = 1e-3; set fit quiet logfile "/dev/null"'
    echo "fit f(x) 'mpm_mls.n' u 1:2 via a"
    echo "plot $(series n 'w p pt 7'), f(x) lc rgb 'black' t sprintf('mpm_mls fit: %.2g ms per particle-step', a)"
    plots="$plots walltime_vs_particles"
  fi
  if [ -s table1.drop ] && [ -s table1.ball ]; then
    echo "set output '$out/table1.png'"
    echo 'set title "Report Table 1 (i3-2100) beside snowsim: seconds per simulated second, dt 0.001"'
    echo 'unset logscale; set style data histograms; set style fill solid 0.8; set boxwidth 0.8'
    echo 'set logscale y; set ylabel "wall time per simulated second (s)"; set xlabel ""; set key top right'
    echo "\$table << EOD"
    echo "\"snowball drop\" 45.3 $(cat table1.drop)"
    echo "\"thrown ball\" 138 $(cat table1.ball)"
    echo "EOD"
    echo "plot \$table u 2:xtic(1) t 'report', '' u 3 t 'snowsim'"
    plots="$plots table1"
  fi
  if [ -s pile.x8 ]; then
    echo "set output '$out/pile_claim.png'"
    echo 'set title "Report Fig. 6 claim: pile height at 0.5 s, critical density x2 > x4 > x8 (9 per cell)"'
    echo 'unset logscale; set style fill empty; set logscale x; set xlabel "dt (s)"; set ylabel "pile height (mm, 90th percentile)"'
    echo 'set style data linespoints; set key top right'
    echo "plot 'pile.x2' u 1:2 pt 7 t 'x2', 'pile.x4' u 1:2 pt 7 t 'x4', 'pile.x8' u 1:2 pt 7 t 'x8'"
    plots="$plots pile_claim"
  fi
  # The study's axes (--preset axes): centre-of-mass error against dt, double, float and the
  # adaptive step (its dt is the cap), one panel per scene.
  axes_scenes=$(awk -F, '$3 == "mpm_mls_float" || $3 == "mpm_mls_adaptive" {print $2}' axes_rows |
    sort -u)
  if [ -n "$axes_scenes" ]; then
    echo "set output '$out/precision_and_step.png'"
    echo "set terminal pngcairo size $((380 * $(echo "$axes_scenes" | wc -l))),420 font ',10' noenhanced"
    echo "set multiplot layout 1,$(echo "$axes_scenes" | wc -l) title 'Explicit MLS against the reference: double, float, adaptive step (dt: its cap); runs that diverged are left out'"
    echo 'unset logscale; set logscale xy; set xlabel "dt (s)"; set ylabel "centre-of-mass error (m)"; set key inside top left'
    for scene in $axes_scenes; do
      for s in mpm_mls mpm_mls_float mpm_mls_adaptive; do
        awk -F, -v s=$s -v sc=$scene '$3 == s && $2 == sc && $16 != "" {print $4, $16}' axes_rows |
          sort -g > "axes.$scene.$s"
      done
      echo "set title '$scene'"
      echo "plot 'axes.$scene.mpm_mls' u 1:2 w lp pt 7 t 'double', 'axes.$scene.mpm_mls_float' u 1:2 w lp pt 6 ps 1.6 t 'float', 'axes.$scene.mpm_mls_adaptive' u 1:2 w lp pt 5 t 'adaptive'"
    done
    echo 'unset multiplot'
    plots="$plots precision_and_step"
  fi
  # Auto-sleep (--preset axes): the errors of explicit MLS awake and with auto-sleep against
  # dt, density field above and centre of mass below, one column per scene.
  sleep_scenes=$(awk -F, '$3 == "mpm_mls_sleep" {print $2}' axes_rows | sort -u)
  if [ -n "$sleep_scenes" ]; then
    columns=$(echo "$sleep_scenes" | wc -l)
    echo "set output '$out/auto_sleep.png'"
    echo "set terminal pngcairo size $((380 * columns)),700 font ',10' noenhanced"
    echo "set multiplot layout 2,$columns title 'Explicit MLS against the reference, awake and with auto-sleep (mpm.auto_sleep defaults); runs that diverged are left out'"
    echo 'unset logscale; set logscale xy; set xlabel "dt (s)"; set key inside top left'
    for row in 14 16; do
      [ $row = 14 ] && label="density-field error" || label="centre-of-mass error (m)"
      for scene in $sleep_scenes; do
        for s in mpm_mls mpm_mls_sleep; do
          awk -F, -v s=$s -v sc=$scene -v c=$row '$3 == s && $2 == sc && $c != "" {print $4, $c}' \
            axes_rows | sort -g > "sleep.$scene.$s.$row"
        done
        echo "set title '$scene'; set ylabel '$label'"
        echo "plot 'sleep.$scene.mpm_mls.$row' u 1:2 w lp pt 7 t 'awake', 'sleep.$scene.mpm_mls_sleep.$row' u 1:2 w lp pt 6 ps 1.6 t 'auto-sleep'"
      done
    done
    echo 'unset multiplot'
    plots="$plots auto_sleep"
  fi
} > charts.gp

# The stability map: dt against Young's modulus, one panel per solver, each run marked by how
# it ended; the explicit CFL bound of the adaptive step (mpm.cfl = 0.9) dt = 0.9 h / c,
# c = sqrt((lambda + 2 mu) / rho) for
# nu = 0.2, rho = 400 kg/m^2, h = 0.01 m (method-notes.md), drawn over it.
if [ -r "$stability" ]; then
  latest "$stability" | awk -F, '$2 == "column_thrown_ball"' > stab
  panels=$(cut -d, -f3 stab | sort -u)
  n=$(echo "$panels" | wc -l)
  {
    echo "set output '$out/stability_map.png'"
    echo "set terminal pngcairo size $((330 * n)),420 font ',10' noenhanced"
    echo "set multiplot layout 1,$n title 'Stability map: column_thrown_ball, 0.3 s (x: diverged, square: tunnelled, dot: finished; dashed: the adaptive step 0.9 h / c)'"
    echo 'set logscale xy; set xlabel "dt (s)"; set ylabel "E0 (Pa)"; set key off; set xrange [3e-5:0.03]; set yrange [7e3:3e6]'
    echo 'cfl(E) = 0.9 * 0.01 / sqrt(1.111 * E / 400)'
    echo 'set parametric; set trange [7e3:3e6]'
    for p in $panels; do
      for st in finished diverged tunnelled nan escaped; do
        awk -F, -v p=$p -v st=$st '$3 == p && $10 == st {print $4, ($8 > 0 ? $8 : 1.4e5)}' stab \
          > "map.$p.$st"
        [ -s "map.$p.$st" ] || echo "1 1" > "map.$p.$st"  # off the axes: keeps the plot valid
      done
      title=$p
      echo "set title \"$title\""
      echo "plot cfl(t), t w l lc rgb 'gray' dt 2, 'map.$p.finished' u 1:2 w p pt 7 ps 1.2 lc rgb '#2ca02c', 'map.$p.diverged' u 1:2 w p pt 2 ps 1.5 lc rgb '#d62728', 'map.$p.tunnelled' u 1:2 w p pt 5 ps 1.2 lc rgb '#ff7f0e', 'map.$p.nan' u 1:2 w p pt 3 lc rgb 'black', 'map.$p.escaped' u 1:2 w p pt 4 lc rgb 'purple'"
    done
    echo 'unset multiplot'
  } >> charts.gp
  plots="$plots stability_map"

  # The hardened states: the small sticky-wall smash with the paper's unbounded hardening and
  # with the flagship scenes' bounds, each solver a row against dt; the dashed line is the mean
  # step the default adaptive policy took (its run capped at the sweep's largest dt).
  latest "$stability" | awk -F, '$2 ~ /^study_smash_sticky/' > hard
  if [ -s hard ]; then
    scenes=$(cut -d, -f2 hard | sort -u)
    n=$(echo "$scenes" | wc -l)
    {
      echo "set output '$out/stability_hardened.png'"
      echo "set terminal pngcairo size $((420 * n)),300 font ',10' noenhanced"
      echo "set multiplot layout 1,$n title 'Hardened snow, sticky-wall smash, 0.15 s (x: diverged, dot: finished, square: other; dashed: default step)'"
      echo 'unset logscale; set logscale x; set xlabel "dt (s)"; unset ylabel; set key off; set xrange [3e-5:3e-3]; set yrange [0.5:3.5]'
      echo 'set ytics ("explicit MLS" 1, "adaptive, capped" 2, "semi-implicit APIC" 3)'
      for sc in $scenes; do
        for st in finished diverged other; do
          awk -F, -v sc=$sc -v st=$st '$2 == sc && ($10 == st ||
              (st == "other" && $10 != "finished" && $10 != "diverged")) {
              row = $3 == "mpm_mls" ? 1 : $3 == "mpm_mls_adaptive" ? 2 : $3 == "mpm_apic_semi" ? 3 : 0
              if (row) print $4, row}' hard > "hard.$sc.$st"
          [ -s "hard.$sc.$st" ] || echo "1 1" > "hard.$sc.$st"
        done
        mean=$(awk -F, -v sc=$sc '$2 == sc && $3 == "mpm_mls_adaptive" && $10 == "finished" \
          {if ($4 > cap) {cap = $4; step = $7 / $12}} END {if (cap) print step}' hard)
        echo "unset arrow"
        [ -n "$mean" ] && echo "set arrow from $mean, graph 0 to $mean, graph 1 nohead lc rgb 'gray' dt 2"
        echo "set title \"$sc\""
        echo "plot 'hard.$sc.finished' u 1:2 w p pt 7 ps 1.2 lc rgb '#2ca02c', 'hard.$sc.diverged' u 1:2 w p pt 2 ps 1.5 lc rgb '#d62728', 'hard.$sc.other' u 1:2 w p pt 5 ps 1.2 lc rgb '#ff7f0e'"
      done
      echo 'unset multiplot'
    } >> charts.gp
    plots="$plots stability_hardened"
  fi
fi

gnuplot charts.gp 2> gnuplot.log || { cat gnuplot.log >&2; exit 1; }
echo "charts: wrote$plots in $out"
[ -s pile.claim ] && awk '{printf "charts: Fig. 6 claim at dt %s: %d of %d particle counts pass\n", $1, $2, $3}' pile.claim
true
