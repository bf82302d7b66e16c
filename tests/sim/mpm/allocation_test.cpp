// "No allocation inside a step": this binary replaces the global operator new with a counting
// one, so it runs alone (tests/CMakeLists.txt) and counts every heap allocation of a step.
#include <gtest/gtest.h>

// The replacements below pair malloc with free, which GCC cannot see through operator new.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <new>

#include "sim/mpm/mpm_solver.h"
#include "sim/scene/json_fields.h"
#include "sim/scene/sampling.h"
#include "tests/support/threaded_test.h"

namespace {
std::atomic<long> allocations{0};
std::atomic<long> bytes_allocated{0};
}  // namespace

void* operator new(std::size_t size) {
  ++allocations;
  bytes_allocated += long(size);
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  return operator new(size);
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}

namespace snowsim {
namespace {

// A snowball thrown at the ground and the right wall, so collisions and plasticity run too.
// particles_per_cell 36 (2,800 particles) puts the 2D ball above the solver's threading threshold.
template <int D>
long allocationsPerStepAfterTheFirst(const std::string& integrator, int particles_per_cell = 0,
                                     int threads = 1) {
  Json j = Json::parse(
      R"({"name": "alloc", "solver": "mpm", "material": {"preset": "paper"}, "particles_per_cell": 4,
    "time": {"dt": 0.001, "duration": 1, "fps": 10}})");
  j["dimension"] = D;
  j["mpm"] = {{"transfer", "mls"}, {"integrator", integrator}};
  if (D == 2) {
    j["grid"] = {{"cells", {24, 24}}, {"cell_size", 0.01}};
    j["bodies"] = {
        {{"shape", "ball"}, {"center", {0.12, 0.08}}, {"radius", 0.05}, {"velocity", {2, -2}}}};
  } else {
    j["grid"] = {{"cells", {12, 12, 12}}, {"cell_size", 0.01}};
    j["particles_per_cell"] = 8;
    j["bodies"] = {{{"shape", "ball"},
                    {"center", {0.06, 0.05, 0.06}},
                    {"radius", 0.03},
                    {"velocity", {2, -2, 0}}}};
  }
  if (particles_per_cell > 0) j["particles_per_cell"] = particles_per_cell;
  const Scene scene = parseScene(j, "alloc.json");
  const long at_start = allocations.load();
  MpmSolver<D> solver(scene, sampleBodies<D>(scene), threads);
  EXPECT_GT(allocations.load() - at_start, 0) << "the counter counts: construction allocates";
  // The first steps size the work buffers (the semi-implicit solve's grow with the contact area).
  for (int n = 0; n < 100; ++n) solver.step(std::min(solver.stableTimeStep(), 1e-3));
  const long before = allocations.load();
  for (int n = 0; n < 50; ++n) solver.step(std::min(solver.stableTimeStep(), 1e-3));
  return allocations.load() - before;
}

TEST(NoAllocation, ExplicitStep2D) {
  EXPECT_EQ(allocationsPerStepAfterTheFirst<2>("explicit"), 0);
}
THREADED_TEST(NoAllocation, ExplicitStep2DOnTwoThreads) {
  EXPECT_EQ(allocationsPerStepAfterTheFirst<2>("explicit", 36, 2), 0);
}
TEST(NoAllocation, ExplicitStep3D) {
  EXPECT_EQ(allocationsPerStepAfterTheFirst<3>("explicit"), 0);
}
TEST(NoAllocation, SemiImplicitStep2D) {
  EXPECT_EQ(allocationsPerStepAfterTheFirst<2>("semi_implicit"), 0);
}

// A float run writes its frames from its own arrays: a frame allocates the snapshot's arrays (32
// bytes a particle in 3D: position, velocity, mass, radius) and no double copy of the particles
// (their x and v alone would be 48 bytes a particle more).
TEST(NoAllocation, FloatFrameAllocatesOnlyTheSnapshot) {
  Json j = Json::parse(
      R"({"name": "alloc", "solver": "mpm", "material": {"preset": "paper"}, "dimension": 3,
    "grid": {"cells": [12, 12, 12], "cell_size": 0.01}, "particles_per_cell": 8,
    "mpm": {"precision": "float"}, "time": {"dt": 0.001, "duration": 1, "fps": 10},
    "bodies": [{"shape": "ball", "center": [0.06, 0.05, 0.06], "radius": 0.03,
                "velocity": [2, -2, 0]}]})");
  const Scene scene = parseScene(j, "alloc.json");
  MpmSolver<3, float> solver(scene, sampleBodies<3>(scene), 1);
  for (int n = 0; n < 10; ++n) solver.step(std::min(solver.stableTimeStep(), 1e-3));
  const long particles = solver.particleCount();
  Snapshot snapshot;
  const long before = bytes_allocated.load();
  solver.snapshotParticles(scene, snapshot);
  const long bytes = bytes_allocated.load() - before;
  EXPECT_GE(bytes, 32 * particles) << "the counter sees the snapshot's own arrays";
  EXPECT_LT(bytes, 48 * particles);
}

}  // namespace
}  // namespace snowsim
