// What auto-sleep (mpm.auto_sleep) saves where most snow rests, and what it changes: a 3D slab of
// snow on the ground with a ball dropped onto its middle, run awake and with auto-sleep, each at
// the adaptive step. Prints each run's wall time, steps, particle-steps and the share of them the
// particles slept through, then how far the two runs end apart (the ball's centre, and the
// farthest any particle ends from its place in the awake run).
// Usage: sleep_bench [duration=0.4 s] [threads=0: the OpenMP default]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <utility>
#include <vector>

#include "sim/mpm/mpm_solver.h"
#include "sim/scene/json_fields.h"
#include "sim/scene/sampling.h"

using namespace snowsim;

namespace {

// Cell 1 cm, a slab 30 x 5 x 30 cm (36,000 particles) and a ball of radius 4 cm (2,100) dropped
// from 15 cm above it at 1 m/s, landing at about t = 0.1 s.
Json sceneJson(bool auto_sleep) {
  Json j = Json::parse(R"({"name": "sleep_bench", "dimension": 3, "solver": "mpm",
    "grid": {"cells": [34, 30, 34], "cell_size": 0.01},
    "time": {"dt": 0.002, "duration": 1, "fps": 10},
    "particles_per_cell": 8,
    "mpm": {"transfer": "mls", "kernel": "quadratic"}, "material": {"preset": "paper"},
    "bodies": [{"shape": "box", "center": [0.17, 0.035, 0.17], "size": [0.3, 0.05, 0.3]},
               {"shape": "ball", "center": [0.17, 0.24, 0.17], "radius": 0.04,
                "velocity": [0, -1, 0]}]})");
  j["mpm"]["auto_sleep"] = {{"enabled", auto_sleep}};
  return j;
}

struct Outcome {
  double seconds = 0;
  long steps = 0;
  SleepTally sleep;
  std::vector<Vec<3>> positions;  // by id
  Vec<3> ball = Vec<3>::Zero();
};

Outcome run(bool auto_sleep, double duration, int threads) {
  const Scene scene = parseScene(sceneJson(auto_sleep), "sleep_bench");
  MpmSolver<3> s(scene, sampleBodies<3>(scene), threads);
  const auto start = std::chrono::steady_clock::now();
  while (s.time() < duration - 1e-12) s.step(std::min(s.stableTimeStep(), duration - s.time()));
  Outcome o;
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  o.steps = s.steps();
  o.sleep = s.statistics().auto_sleep;
  o.positions = s.particles().positionsById();
  const Particles<3>& p = s.particles();
  int n = 0;
  for (int i = 0; i < p.size(); ++i)
    if (p.body[i] == 1) o.ball += p.x[i], ++n;
  o.ball /= n;
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  const double duration = argc > 1 ? std::atof(argv[1]) : 0.4;
  const int threads = argc > 2 ? std::atoi(argv[2]) : 0;
  if (duration <= 0 || threads < 0) {
    std::fprintf(stderr, "usage: sleep_bench [duration > 0 s] [threads >= 0]\n");
    return 2;
  }
  const Outcome awake = run(false, duration, threads), asleep = run(true, duration, threads);
  const long particles = static_cast<long>(awake.positions.size());
  std::printf("slab and dropped ball, 3D, %ld particles, %.2f s simulated\n", particles, duration);
  std::printf("%-8s %9s %7s %14s %14s %9s\n", "run", "wall (s)", "steps", "particle-steps",
              "worked", "asleep");
  for (const auto& [name, o] : {std::pair{"awake", &awake}, std::pair{"asleep", &asleep}}) {
    const long total = o->steps * particles;
    const long worked = total - o->sleep.asleep_steps;
    std::printf("%-8s %9.2f %7ld %14ld %14ld %8.1f%%\n", name, o->seconds, o->steps, total, worked,
                100.0 * o->sleep.asleep_steps / total);
  }
  double farthest = 0;
  for (long i = 0; i < particles; ++i)
    farthest = std::max(farthest, (asleep.positions[i] - awake.positions[i]).norm());
  std::printf(
      "speed-up %.2fx; the ball's centre ends %.2f mm from the awake run's; the farthest "
      "particle %.2f mm\n",
      awake.seconds / asleep.seconds, 1e3 * (asleep.ball - awake.ball).norm(), 1e3 * farthest);
  return 0;
}
