// Speed of MPM snow: particle-steps per second (median of repetitions), 2D and 3D explicit MLS with
// quadratic weights, in double and in float (mpm.precision), 1 and 2 threads (whether they agree
// bit for bit, and what two one-thread solvers side by side reach), bytes per particle; with
// "profile", also where each step's time goes, stage by stage and thread by thread.
// "cracks" (not in "all") prints what a step with open cracks costs against a plain step on the
// same snow, stretched and partly failed (measureCracks).
// Usage: mpm_bench [steps=100] [repetitions=5] [case: all | 2d-small | 2d-large | 3d | cracks]
//                  [double | float | both=both] [profile] [one-thread]
// "one-thread" runs only the one-thread solver: under callgrind (which runs one thread at a time)
// its instruction counts are those of the steps alone, where a side-by-side solver would step on
// while it waits for the other.
#include <omp.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#include "sim/mpm/mpm_solver.h"
#include "sim/scene/json_fields.h"
#include "sim/scene/sampling.h"

using namespace snowsim;

namespace {

// A block of snow thrown at the ground at 3 m/s from one cell above it: it hits the ground in the
// first steps and compacts for the rest of the run, so the plastic return mapping clamps (a block
// in free fall would never leave the elastic range and flatter the rate).
Json sceneJson(int dimension, int cells, double box) {
  Json j = Json::parse(R"({"name": "bench", "solver": "mpm", "particles_per_cell": 4,
    "material": {"preset": "paper"},
    "mpm": {"transfer": "mls", "kernel": "quadratic", "adaptive_dt": false}})");
  j["dimension"] = dimension;
  const double h = 1.0 / cells;
  const double lowest = box / 2 + h;  // centre height: the block's bottom one cell up
  if (dimension == 2) {
    j["grid"] = {{"cells", {cells, cells}}, {"cell_size", h}};
    j["bodies"] = {
        {{"shape", "box"}, {"center", {0.5, lowest}}, {"size", {box, box}}, {"velocity", {0, -3}}}};
  } else {
    j["grid"] = {{"cells", {cells, cells, cells}}, {"cell_size", h}};
    j["particles_per_cell"] = 8;
    j["bodies"] = {{{"shape", "box"},
                    {"center", {0.5, lowest, 0.5}},
                    {"size", {box, box, box}},
                    {"velocity", {0, -3, 0}}}};
  }
  return j;
}

double median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

// Each thread's stage times over one run (sim/parallel/team.h).
using StageProfile = std::vector<std::vector<StageTime>>;

// Particle-steps per second of one run of the scene on the given thread count; its positions,
// and, if asked for, how many times its particles were binned and its stage profile.
template <int D, class T>
double run(const Scene& scene, const Particles<D>& start, int threads, int steps,
           std::vector<Vec<D>>& positions, StageProfile* profile = nullptr,
           long* binnings = nullptr) {
  MpmSolver<D, T> s(scene, start, threads);
  const Real dt = 0.5 * s.cflTimeStep();
  s.profileStages(profile != nullptr);
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < steps; ++k) s.step(dt);
  const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  positions = s.particles().x;
  if (binnings != nullptr) *binnings = s.binnings();
  if (profile != nullptr) {
    profile->clear();
    for (int thread = 0; thread < s.profiledThreads(); ++thread)
      profile->push_back(s.stageTimes(thread));
  }
  return double(positions.size()) * steps / sec;
}

// Microseconds per step of each stage (median of the repetitions, 1 and 2 threads alternating):
// on one thread, and on each of two threads the work of its parts and the wait for the other.
// The binning's stages run every step in 3D but rarely in 2D (the bench prints how often), the
// sort's at most every 16th step: their figures are what they cost spread over the steps.
template <int D, class T>
void profile(const std::string& label, const Scene& scene, const Particles<D>& start, int steps,
             int reps) {
  enum Column { alone, work0, wait0, work1, wait1, columns };
  std::vector<std::string_view> stages;  // in the order first met
  std::map<std::string_view, std::array<std::vector<double>, columns>> samples;
  const auto add = [&](std::string_view stage, int column, double seconds) {
    if (samples.count(stage) == 0) stages.push_back(stage);
    samples[stage][column].push_back(seconds / steps * 1e6);
  };
  std::vector<Vec<D>> positions;
  StageProfile one, two;
  for (int r = 0; r < reps; ++r) {
    run<D, T>(scene, start, 1, steps, positions, &one);
    for (const StageTime& t : one[0]) add(t.stage, alone, t.work_seconds);
    run<D, T>(scene, start, 2, steps, positions, &two);
    for (int thread = 0; thread < std::min<int>(2, two.size()); ++thread)
      for (const StageTime& t : two[thread]) {
        add(t.stage, thread == 0 ? work0 : work1, t.work_seconds);
        add(t.stage, thread == 0 ? wait0 : wait1, t.wait_seconds);
      }
  }
  std::printf("%s, µs per step: 1 thread; 2 threads, each thread's work + wait\n", label.c_str());
  std::array<double, columns> sums{};
  for (const std::string_view stage : stages) {
    std::printf("  %-18.*s", int(stage.size()), stage.data());
    for (int c = 0; c < columns; ++c) {
      const std::vector<double>& v = samples[stage][c];
      const double value = v.empty() ? 0 : median(v);
      sums[c] += value;
      std::printf(c == work0 || c == work1 ? "  %7.1f"
                  : c == alone             ? "  %7.1f  |"
                                           : " + %5.1f",
                  value);
    }
    std::printf("\n");
  }
  std::printf("  %-18s  %7.1f  |  %7.1f + %5.1f  %7.1f + %5.1f  (sums of the medians)\n",
              "all stages", sums[alone], sums[work0], sums[wait0], sums[work1], sums[wait1]);
}

// Particle-steps per second of two one-thread solvers of the scene stepping side by side, one
// per thread, sharing nothing: what two cores deliver on this very work with no cut between
// them, the ceiling of the two-thread solver. Each counts its rate over its first `steps` steps
// and keeps stepping until the other has too, so that neither runs its last steps alone.
template <int D, class T>
double sideBySideRate(const Scene& scene, int steps) {
  std::atomic<int> ready{0}, finished{0};
  std::array<double, 2> rate{};
  const auto solve = [&](int k) {
    MpmSolver<D, T> s(scene, sampleBodies<D>(scene), 1);  // a solver without worker threads
    const Real dt = 0.5 * s.cflTimeStep();
    ready.fetch_add(1);
    while (ready.load() < 2) {
    }
    const auto t0 = std::chrono::steady_clock::now();
    for (int step = 0; step < steps; ++step) s.step(dt);
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    rate[k] = double(s.particles().size()) * steps / sec;
    finished.fetch_add(1);
    // Bounded: the bench's scene stays stable for several times `steps`.
    for (int extra = 0; finished.load() < 2 && extra < 4 * steps; ++extra) s.step(dt);
  };
  std::thread other(solve, 1);
  solve(0);
  other.join();
  return rate[0] + rate[1];
}

// One and two threads alternate, so a slow period of a shared machine hits both alike; the
// speed-up is the median of the ratios of each pair. The ceiling, two one-thread solvers side by
// side over the one-thread rate, is measured just before each pair.
template <int D, class T>
void measure(const std::string& label, const Json& j, int steps, int reps, bool one_thread_only) {
  const Scene scene = parseScene(j, "bench");
  const Particles<D> start = sampleBodies<D>(scene);
  std::vector<Vec<D>> one_thread, two_threads;
  std::vector<double> rate1, rate2, ratio, ceiling;
  long binnings = 0;
  if (one_thread_only) {
    for (int r = 0; r < reps; ++r) rate1.push_back(run<D, T>(scene, start, 1, steps, one_thread));
    std::printf("%s: %zu particles, 1 thread %.2f M particle-steps/s\n", label.c_str(),
                one_thread.size(), median(rate1) / 1e6);
    return;
  }
  for (int r = 0; r < reps; ++r) {
    const double side_by_side = sideBySideRate<D, T>(scene, steps);
    rate1.push_back(run<D, T>(scene, start, 1, steps, one_thread, nullptr, &binnings));
    ceiling.push_back(side_by_side / rate1.back());
    rate2.push_back(run<D, T>(scene, start, 2, steps, two_threads));
    ratio.push_back(rate2.back() / rate1.back());
  }
  // x, v; mass, volume, J_P, hardening and the spare buffer the particles are sorted through (a
  // scalar at a time); body, id, block, sorted order; F_E, C; the stress.
  const size_t bytes = sizeof(Vec<D, T>) * 2 + sizeof(T) * 5 + sizeof(int) * 4 +
                       sizeof(Mat<D, T>) * 2 + sizeof(Symmetric<D, T>);
  std::printf(
      "%s: %zu particles, 1 thread %.2f M particle-steps/s, 2 threads %.2f M/s (x%.2f; "
      "two solvers side by side x%.2f), bit-identical: %s, %zu bytes/particle, binned %ld "
      "times in %d steps\n",
      label.c_str(), one_thread.size(), median(rate1) / 1e6, median(rate2) / 1e6, median(ratio),
      median(ceiling), one_thread == two_threads ? "yes" : "NO", bytes, binnings, steps);
}

// The crack smash (scenes/flagship/smash_wall_cracks.json) at cell 10 mm: a ball of radius 0.1 m
// thrown at 4 m/s into a sticky wall, snow that fails past ln J_P = 0.3 (the full scene's strain,
// without its crack band); cracks open or not.
Json crackSceneJson(bool open_cracks) {
  Json j = Json::parse(R"({"name": "bench cracks", "dimension": 3, "solver": "mpm",
    "grid": {"cells": [60, 40, 40], "cell_size": 0.01}, "particles_per_cell": 8,
    "mpm": {"transfer": "mls", "kernel": "quadratic", "crack_friction": 0.6,
            "walls": {"type": "separating", "friction": 0.3}},
    "material": {"preset": "paper", "xi": 10, "hardening_min": 0.2, "hardening_max": 5,
                 "viscosity": 4, "fracture_strain": 0.3},
    "bodies": [{"shape": "ball", "center": [0.3, 0.2, 0.2], "radius": 0.1, "velocity": [4, 0, 0]}],
    "colliders": [{"shape": "box", "position": [0.55, 0.2, 0.2], "size": [0.1, 0.4, 0.4],
                   "type": "sticky"}]})");
  j["mpm"]["open_cracks"] = open_cracks;
  return j;
}

// The shares of snow stretched past J_P = 1 (damaged) and with no strength left (failed).
template <class T>
std::pair<double, double> damagedAndFailed(const SnowMaterial& m, const std::vector<T>& J_P) {
  long damaged = 0, failed = 0;
  for (const T j : J_P) {
    damaged += j > 1;
    failed += strengthLeft<T>(m, j) <= 0;
  }
  return {double(damaged) / J_P.size(), double(failed) / J_P.size()};
}

// A crack step against a plain step on the same particles: the crack smash run with cracks open
// through its impact, then its particles and their J_P (F_E starts unstrained) as the start of
// both solvers, one with cracks open, one without. Both step at the start's stable step; each
// pair of runs alternates, and the cost is the median of the pairs' ratios.
template <class T>
void measureCracks(int steps, int reps, bool profiled, bool one_thread_only) {
  constexpr Real impact = 0.05;  // s: the ball met the wall at 0.025 s
  Scene cracks = parseScene(crackSceneJson(true), "bench cracks");
  Scene plain = parseScene(crackSceneJson(false), "bench cracks");
  MpmSolver<3, T> warm(cracks, sampleBodies<3>(cracks), one_thread_only ? 1 : 2);
  for (Real t = 0; t < impact;) {
    const Real dt = std::min(warm.stableTimeStep(), impact - t);
    warm.step(dt);
    t += dt;
  }
  const Particles<3> start = warm.particles();
  auto points = std::make_shared<Snapshot>();
  points->plastic_j.assign(warm.plasticJ().begin(), warm.plasticJ().end());
  for (Scene* s : {&cracks, &plain}) s->bodies[0].points = points;
  const auto [damaged, failed] = damagedAndFailed(warm.material(), warm.plasticJ());
  std::printf("cracks, %s: %d particles at t = %.2f s, %.2f stretched past J_P = 1, %.2f failed\n",
              std::is_same_v<T, float> ? "float" : "double", start.size(), impact, damaged, failed);
  std::vector<Vec<3>> crack1, crack2, plain1, plain2;
  std::vector<double> rate[2][2], cost[2];  // [cracks open][threads - 1]; [threads - 1]
  const int most_threads = one_thread_only ? 1 : 2;
  for (int r = 0; r < reps; ++r)
    for (int threads = 1; threads <= most_threads; ++threads) {
      const double open = run<3, T>(cracks, start, threads, steps, threads == 1 ? crack1 : crack2);
      const double closed = run<3, T>(plain, start, threads, steps, threads == 1 ? plain1 : plain2);
      rate[1][threads - 1].push_back(open);
      rate[0][threads - 1].push_back(closed);
      cost[threads - 1].push_back(closed / open);
    }
  for (int threads = 1; threads <= most_threads; ++threads)
    std::printf(
        "  %d thread%s: cracks open %.2f M particle-steps/s, plain %.2f M/s: a crack step costs "
        "x%.2f a plain one\n",
        threads, threads == 1 ? "" : "s", median(rate[1][threads - 1]) / 1e6,
        median(rate[0][threads - 1]) / 1e6, median(cost[threads - 1]));
  if (!one_thread_only)
    std::printf("  %d steps; bit-identical on 1 and 2 threads: cracks open %s, plain %s\n", steps,
                crack1 == crack2 ? "yes" : "NO", plain1 == plain2 ? "yes" : "NO");
  if (profiled) {
    profile<3, T>("cracks open", cracks, start, steps, reps);
    profile<3, T>("plain", plain, start, steps, reps);
  }
}

// Nanoseconds for two threads to pass one cache line there and back: what each line costs that
// one thread writes and the other reads next. On a shared virtual machine it changes with where
// the two cores sit (the README's speed section); 0 if two threads did not run at once.
double coreToCoreRoundTrip() {
  constexpr int trips = 100000;
  std::atomic<int> ball{0};
  std::atomic<bool> give_up{false};
  double seconds = 0;
#pragma omp parallel num_threads(2)
  if (omp_get_num_threads() == 2) {
    const int me = omp_get_thread_num();
    const auto t0 = std::chrono::steady_clock::now();
    // Each thread waits for the ball to be on its side, then passes it; a time limit in case
    // both threads share one core.
    for (int i = 0; i < trips && !give_up.load(std::memory_order_relaxed); ++i) {
      for (long spins = 1; ball.load(std::memory_order_acquire) != me; ++spins)
        if (spins % 4096 == 0 && std::chrono::steady_clock::now() - t0 > std::chrono::seconds(1)) {
          give_up = true;
          break;
        }
      ball.store(1 - me, std::memory_order_release);
    }
    if (me == 0 && !give_up)
      seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  return seconds / trips * 1e9;
}

}  // namespace

int main(int argc, char** argv) {
  const int steps = argc > 1 ? std::atoi(argv[1]) : 100;
  const int reps = argc > 2 ? std::atoi(argv[2]) : 5;
  const std::string only = argc > 3 ? argv[3] : "all";
  if (only != "all" && only != "2d-small" && only != "2d-large" && only != "3d" &&
      only != "cracks") {
    std::fprintf(stderr, "mpm_bench: case '%s' is not one of all, 2d-small, 2d-large, 3d, cracks\n",
                 only.c_str());
    return 2;
  }
  std::string precision = "both";
  bool profiled = false, one_thread_only = false;
  for (int arg = 4; arg < argc; ++arg) {
    const std::string word = argv[arg];
    if (word == "profile") {
      profiled = true;
    } else if (word == "one-thread") {
      one_thread_only = true;
    } else if (word == "double" || word == "float" || word == "both") {
      precision = word;
    } else {
      std::fprintf(stderr, "mpm_bench: '%s' is none of double, float, both, profile, one-thread\n",
                   argv[arg]);
      return 2;
    }
  }
  if (only == "cracks") {
    if (precision != "float") measureCracks<double>(steps, reps, profiled, one_thread_only);
    if (precision != "double") measureCracks<float>(steps, reps, profiled, one_thread_only);
    return 0;
  }
  if (!one_thread_only) {
    if (const double round_trip = coreToCoreRoundTrip(); round_trip > 0)
      std::printf("core-to-core round trip %.0f ns\n", round_trip);
    else
      std::printf("core-to-core round trip not measured: two threads did not run at once\n");
  }
  const auto benchIn = [&]<int D, class T>(const std::string& label, const Json& scene) {
    measure<D, T>(label, scene, steps, reps, one_thread_only);
    if (profiled) {
      const Scene s = parseScene(scene, "bench");
      profile<D, T>(label, s, sampleBodies<D>(s), steps, reps);
    }
  };
  const auto bench = [&]<int D>(const std::string& label, const Json& scene) {
    if (precision != "float") benchIn.operator()<D, double>(label + ", double", scene);
    if (precision != "double") benchIn.operator()<D, float>(label + ", float", scene);
  };
  if (only == "all" || only == "2d-small")
    bench.operator()<2>("2D MLS quadratic, small", sceneJson(2, 64, 0.44));
  if (only == "all" || only == "2d-large")
    bench.operator()<2>("2D MLS quadratic, large", sceneJson(2, 128, 0.6));
  if (only == "all" || only == "3d") bench.operator()<3>("3D MLS quadratic", sceneJson(3, 32, 0.5));
}
