// Prints the comparison behind docs/report-readings.md: each reading of the report's vague
// passages (what "the density of a single particle" is, where the walls act, what the FLIP
// increment is measured from) against the outcomes its figures show.
// Usage: report_readings [2|3]   (true 2D, default, or the report's one-cell-deep slab)
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "sim/report/density_hybrid.h"
#include "sim/scene/sampling.h"

namespace {

using namespace snowsim;

template <int D>
struct Outcome {
  DensityHybridSolver<D> solver;
  Real time = 0;
  explicit Outcome(const Scene& scene) : solver(scene, sampleBodies<D>(scene)) {}
  void until(const Scene& scene, Real t) {
    while (time < t - 1e-9) solver.step(scene.dt), time += scene.dt;
  }
  // Highest particle of body (or all with -1), and the centre of a body along an axis.
  Real top(int body = -1) const {
    Real y = -1;
    const auto& p = solver.particles();
    for (int i = 0; i < p.size(); ++i)
      if (body < 0 || p.body[i] == body) y = std::max(y, p.x[i][1]);
    return y;
  }
  Real right(int body) const {
    Real x = -1;
    const auto& p = solver.particles();
    for (int i = 0; i < p.size(); ++i)
      if (p.body[i] == body) x = std::max(x, p.x[i][0]);
    return x;
  }
  Real centre(int body, int axis) const {
    Real c = 0;
    int n = 0;
    const auto& p = solver.particles();
    for (int i = 0; i < p.size(); ++i)
      if (p.body[i] == body) c += p.x[i][axis], ++n;
    return c / n;
  }
};

Scene scene(const std::string& name, const std::vector<std::string>& reading, int dim,
            std::vector<std::string> extra = {}) {
  std::vector<std::string> overrides = reading;
  overrides.push_back("dimension=" + std::to_string(dim));
  overrides.insert(overrides.end(), extra.begin(), extra.end());
  return loadScene(std::string(SNOWSIM_SOURCE_DIR) + "/scenes/" + name + ".json", overrides);
}

template <int D>
void printRow(const std::vector<std::string>& reading, const std::string& label) {
  Real column[3];
  const int multipliers[3] = {2, 4, 8};
  for (int k = 0; k < 3; ++k) {
    const Scene s = scene("snow_column", reading, D,
                          {"density_hybrid.critical_multiplier=" + std::to_string(multipliers[k])});
    Outcome<D> run(s);
    run.until(s, 0.5);
    column[k] = run.top();
  }
  const Scene drop = scene("snowball_drop", reading, D);
  Outcome<D> pile(drop);
  pile.until(drop, 1.0);

  Real past[2];
  const char* thrown[2] = {"column_thrown_ball", "column_thrown_ball_dt001"};
  for (int k = 0; k < 2; ++k) {
    const Scene s = scene(thrown[k], reading, D);
    Outcome<D> run(s);
    run.until(s, 0.5);
    past[k] = run.centre(1, 0) - run.right(0);
  }

  const Scene balls = scene("equal_balls_different_density", reading, D);
  Outcome<D> run(balls);
  Real landed[2] = {-1, -1};
  while (run.time < 1.0 && (landed[0] < 0 || landed[1] < 0)) {
    run.until(balls, run.time + balls.dt);
    for (int b = 0; b < 2; ++b)
      if (landed[b] < 0 && run.centre(b, 1) <= balls.cell_size) landed[b] = run.time;
  }

  const bool ordered = column[0] > column[1] && column[1] > column[2];
  std::printf("| %s | %.1f / %.1f / %.1f | %s | %.1f | %s | %+.0f ms |\n", label.c_str(),
              1e3 * column[0], 1e3 * column[1], 1e3 * column[2], ordered ? "yes" : "no",
              1e3 * pile.top(), past[1] > 0 && past[0] < 0 ? "yes" : "no",
              1e3 * (landed[0] - landed[1]));
}

template <int D>
void printTable() {
  std::printf("Readings on %s (column starts 38.3 mm tall, the ball 19 mm across)\n\n",
              D == 2 ? "true 2D" : "the 10x12x1 slab");
  std::printf(
      "| reading (critical reference, walls, FLIP from) | column top at 0.5 s, x2 / x4 / "
      "x8 (mm) | x2 > x4 > x8 | drop: pile top at 1 s (mm) | Fig. 8 (passes at dt "
      "0.01 only) | equal balls: dense lands later by |\n|---|---|---|---|---|---|\n");
  for (const char* reference : {"particle_mass_per_cell", "rest_density"})
    for (const char* walls : {"hold_grid", "slip_grid", "particles_only"})
      for (const char* flip : {"rasterised", "equalised"}) {
        const std::vector<std::string> reading = {
            std::string("density_hybrid.critical_reference=") + reference,
            std::string("density_hybrid.walls=") + walls,
            std::string("density_hybrid.flip_reference=") + flip};
        printRow<D>(reading, std::string(reference) + ", " + walls + ", " + flip);
      }
}

}  // namespace

int main(int argc, char** argv) {
  const int dimension = argc > 1 ? std::atoi(argv[1]) : 2;
  if (dimension == 3)
    printTable<3>();
  else
    printTable<2>();
  return 0;
}
