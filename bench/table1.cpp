// Reruns the report's Table 1: its six scenes at dt 0.001, 27 particles per cell, critical
// density x4, simulated for 0.1 / 0.5 / 1.0 / 5.0 s on the report's 10x12x1 slab, and prints our
// wall times beside the report's (Intel Core i3-2100) with the speed-up, plus the true-2D time.
// Usage: table1 [repeats]   (median of `repeats` runs per cell, default 3)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "sim/simulation.h"

namespace {

using namespace snowsim;

struct Row {
  const char* scene;
  const char* label;
  int report_particles;
  double report_seconds[4];
};

const double kDurations[4] = {0.1, 0.5, 1.0, 5.0};
const Row kTable[] = {
    {"snowball_drop", "Snowball drop", 76, {4.36, 22.9, 45.3, 225}},
    {"snow_column", "Snow column", 216, {10.3, 49.8, 101, 514}},
    {"column_with_ball", "Column with ball", 290, {13.1, 65.9, 131, 679}},
    {"column_thrown_ball", "Column, thrown ball", 290, {13.0, 65.0, 138, 667}},
    {"column_thrown_half_ball", "Column, thrown half ball", 290, {13.0, 67.8, 131, 672}},
    {"colliding_snowballs", "Colliding snowballs", 148, {7.35, 38.3, 73.7, 374}},
};

double medianSeconds(const std::string& path, int dimension, double duration, int repeats,
                     int* particles) {
  std::vector<double> times;
  for (int r = 0; r < repeats; ++r) {
    const Scene scene = loadScene(path, {"dimension=" + std::to_string(dimension),
                                         "time.duration=" + std::to_string(duration)});
    const auto start = std::chrono::steady_clock::now();
    auto simulation = makeSimulation(scene);
    simulation->advanceTo(duration);
    times.push_back(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    *particles = simulation->particleCount();
  }
  std::sort(times.begin(), times.end());
  return times[times.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const int repeats = argc > 1 ? std::max(1, std::atoi(argv[1])) : 3;
  std::printf(
      "| scene | particles (report / ours) | simulated s | report s | ours, slab s | "
      "speed-up | ours, true 2D s |\n|---|---|---|---|---|---|---|\n");
  for (const Row& row : kTable) {
    const std::string path = std::string(SNOWSIM_SOURCE_DIR) + "/scenes/" + row.scene + ".json";
    for (int k = 0; k < 4; ++k) {
      int slab_particles = 0, flat_particles = 0;
      const double slab = medianSeconds(path, 3, kDurations[k], repeats, &slab_particles);
      const double flat = medianSeconds(path, 2, kDurations[k], repeats, &flat_particles);
      std::printf("| %s | %d / %d | %.1f | %.3g | %.4f | %.0fx | %.4f |\n", row.label,
                  row.report_particles, slab_particles, kDurations[k], row.report_seconds[k], slab,
                  row.report_seconds[k] / slab, flat);
    }
  }
  return 0;
}
