// The report's method stage by stage: the critical-density rule on hand-made cells, mass and
// momentum through rasterisation, the ground rule, and free fall away from packed snow.
#include <gtest/gtest.h>

#include <numeric>

#include "sim/core/errors.h"
#include "sim/report/density_hybrid.h"
#include "sim/scene/sampling.h"

namespace snowsim {
namespace {

TEST(ClampTowardsPacked, NeighbourMovingAwayAtLeastAsFastLeavesTheComponent) {
  EXPECT_EQ(clampTowardsPacked(2.0, 3.0), 2.0);
  EXPECT_EQ(clampTowardsPacked(2.0, 2.0), 2.0);
  EXPECT_EQ(clampTowardsPacked(-2.0, -5.0), -2.0);
}

TEST(ClampTowardsPacked, SlowerNeighbourInTheSameDirectionIsMatched) {
  EXPECT_EQ(clampTowardsPacked(2.0, 0.5), 0.5);
  EXPECT_EQ(clampTowardsPacked(-2.0, -0.5), -0.5);
}

TEST(ClampTowardsPacked, NeighbourMovingTheOtherWayOrStillStopsTheComponent) {
  EXPECT_EQ(clampTowardsPacked(2.0, -1.0), 0.0);
  EXPECT_EQ(clampTowardsPacked(-2.0, 1.0), 0.0);
  EXPECT_EQ(clampTowardsPacked(2.0, 0.0), 0.0);
}

// A 4x4-cell grid of unit cells; cells are addressed by node coordinates.
struct HandMadeGrid {
  GridGeometry<2> grid{IVec<2>(4, 4), 1.0};
  std::vector<Real> density = std::vector<Real>(grid.nodeCount(), 0.0);
  std::vector<Vec<2>> in = std::vector<Vec<2>>(grid.nodeCount(), Vec<2>::Zero());
  std::vector<Vec<2>> out = std::vector<Vec<2>>(grid.nodeCount(), Vec<2>::Zero());
  int at(int i, int j) const { return grid.index(IVec<2>(i, j)); }
  void run() { equaliseTowardsPacked<2>(grid, density, /*critical_density=*/10.0, in, out); }
};

TEST(EqualiseTowardsPacked, EachBranchOnHandMadeCells) {
  HandMadeGrid g;
  g.density[g.at(2, 2)] = 10.0;  // packed: exactly at the critical density
  g.in[g.at(2, 2)] = Vec<2>(1.0, -1.0);
  g.in[g.at(1, 2)] = Vec<2>(2.0, 0.0);   // pushes right into the packed cell, which is slower
  g.in[g.at(2, 1)] = Vec<2>(0.0, 3.0);   // pushes up, the packed cell moves down
  g.in[g.at(3, 2)] = Vec<2>(-1.0, 0.0);  // pushes left, the packed cell moves right (away)
  g.in[g.at(2, 3)] = Vec<2>(0.0, -0.5);  // pushes down, the packed cell falls faster
  g.in[g.at(0, 0)] = Vec<2>(5.0, 5.0);   // neighbours are not packed
  g.density[g.at(1, 0)] = 9.99;
  g.run();
  EXPECT_EQ(g.out[g.at(1, 2)], Vec<2>(1.0, 0.0));
  EXPECT_EQ(g.out[g.at(2, 1)], Vec<2>(0.0, 0.0));
  EXPECT_EQ(g.out[g.at(3, 2)], Vec<2>(0.0, 0.0));
  EXPECT_EQ(g.out[g.at(2, 3)], Vec<2>(0.0, -0.5));
  EXPECT_EQ(g.out[g.at(0, 0)], Vec<2>(5.0, 5.0));
  EXPECT_EQ(g.out[g.at(2, 2)], Vec<2>(1.0, -1.0)) << "its own neighbours are empty";
}

TEST(EqualiseTowardsPacked, ReadsOldValuesSoCellOrderDoesNotMatter) {
  HandMadeGrid g;
  // A row of packed cells moving right ever slower: each is clamped to its neighbour's OLD value,
  // so the first becomes 2 (not 1, which an in-place sweep from the right would give).
  for (int i = 0; i <= 3; ++i) g.density[g.at(i, 1)] = 20.0;
  g.in[g.at(0, 1)] = Vec<2>(3.0, 0.0);
  g.in[g.at(1, 1)] = Vec<2>(2.0, 0.0);
  g.in[g.at(2, 1)] = Vec<2>(1.0, 0.0);
  g.in[g.at(3, 1)] = Vec<2>(0.0, 0.0);
  g.run();
  EXPECT_EQ(g.out[g.at(0, 1)][0], 2.0);
  EXPECT_EQ(g.out[g.at(1, 1)][0], 1.0);
  EXPECT_EQ(g.out[g.at(2, 1)][0], 0.0);
}

Scene ballScene() {
  Scene s;
  s.file = "test";
  s.name = "ball";
  Body ball;
  ball.center = {0.05, 0.06, 0};
  ball.radius = 0.02;
  ball.particles_per_cell = 9;
  ball.velocity = {0.3, -0.2, 0};
  s.bodies = {ball};
  return s;
}

TEST(DensityHybrid, RasterisationConservesMassAndMomentum) {
  for (KernelType kernel : {KernelType::Cubic, KernelType::Quadratic}) {
    Scene scene = ballScene();
    scene.density_hybrid.kernel = kernel;
    DensityHybridSolver<2> solver(scene, sampleBodies<2>(scene));
    solver.rasterise();
    const auto& p = solver.particles();
    const auto& f = solver.fields();
    Real particle_mass = 0, grid_mass = 0;
    Vec<2> particle_momentum = Vec<2>::Zero(), grid_momentum = Vec<2>::Zero();
    for (int i = 0; i < p.size(); ++i) {
      particle_mass += p.mass[i];
      particle_momentum += p.mass[i] * p.v[i];
    }
    for (size_t k = 0; k < f.mass.size(); ++k) {
      grid_mass += f.mass[k];
      grid_momentum += f.mass[k] * f.velocity[k];
    }
    EXPECT_GT(p.size(), 100);
    EXPECT_NEAR(grid_mass / particle_mass, 1, 1e-13);
    EXPECT_LT((grid_momentum - particle_momentum).norm(), 1e-13 * particle_momentum.norm());
  }
}

TEST(DensityHybrid, GroundTakesOnlyTheDownwardVelocityOfParticlesAtOrBelowIt) {
  Scene scene = ballScene();
  Particles<2> particles;
  particles.add(Vec<2>(0.05, 0.0), Vec<2>(0.3, -1.0), 1e-3, 0);    // on the ground, falling
  particles.add(Vec<2>(0.06, 0.0), Vec<2>(0.3, 0.5), 1e-3, 0);     // on the ground, rising
  particles.add(Vec<2>(0.07, 0.001), Vec<2>(0.3, -1.0), 1e-3, 0);  // above the ground
  DensityHybridSolver<2> solver(scene, particles);
  solver.collideWithGround();
  const auto& v = solver.particles().v;
  EXPECT_EQ(v[0], Vec<2>(0.3, 0.0));
  EXPECT_EQ(v[1], Vec<2>(0.3, 0.5));
  EXPECT_EQ(v[2], Vec<2>(0.3, -1.0));
}

TEST(DensityHybrid, FreeFallAwayFromPackedSnowIsExact) {
  // With a critical density no cell reaches, a body falls as one: symplectic Euler gives
  // x_n = x_0 + v_0 n dt + g dt^2 n (n + 1) / 2 for every particle.
  Scene scene = ballScene();
  scene.bodies[0].center = {0.04, 0.07, 0};  // stays two cells from the held wall nodes
  scene.density_hybrid.critical_multiplier = 1e6;
  scene.gravity = {0, -9.81, 0};
  const Particles<2> start = sampleBodies<2>(scene);
  DensityHybridSolver<2> solver(scene, start);
  const Real dt = 1e-3;
  const int steps = 50;
  for (int n = 0; n < steps; ++n) solver.step(dt);
  for (int i = 0; i < start.size(); ++i) {
    const Vec<2> v0(0.3, -0.2), g(0, -9.81);
    const Vec<2> expected = start.x[i] + v0 * steps * dt + g * dt * dt * steps * (steps + 1) / 2;
    EXPECT_LT((solver.particles().x[i] - expected).norm(), 1e-12);
  }
}

TEST(DensityHybrid, CriticalDensityReadings) {
  Scene scene = ballScene();
  const Particles<2> particles = sampleBodies<2>(scene);
  const Real h = scene.cell_size;

  DensityHybridSolver<2> per_cell(scene, particles);
  per_cell.step(1e-3);
  EXPECT_NEAR(per_cell.criticalDensity(), 4.0 * particles.mass[0] / (h * h), 1e-9);

  scene.density_hybrid.critical_reference = CriticalReference::RestDensity;
  DensityHybridSolver<2> rest(scene, particles);
  rest.step(1e-3);
  const Particles<2>& after = rest.particles();
  Real sum = 0;
  for (int p = 0; p < after.size(); ++p) sum += after.mass[p] / after.volume[p];  // rho_p
  const Real mean = sum / after.size();
  EXPECT_NEAR(rest.criticalDensity(), 4.0 * mean, 1e-9 * mean);
  // The smoothed field of a small body is below the material density everywhere.
  EXPECT_LT(mean, 400.0);
  EXPECT_GT(mean, 100.0);
}

// A ball too fast for any step of the box would be stopped on the wall with finite values and
// "finish"; the check stops it at the first step instead, saying how fast and what dt would do.
TEST(DensityHybrid, ABallThatCrossesTheDomainInOneStepDiverges) {
  for (double speed : {1e300, 200.0}) {
    Scene scene = ballScene();
    scene.bodies[0].velocity = {speed, 0, 0};
    DensityHybridSolver<2> solver(scene, sampleBodies<2>(scene));
    try {
      solver.step(1e-3);
      FAIL() << speed << " m/s was not stopped";
    } catch (const SimulationError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("step 1 "), std::string::npos) << message;
      EXPECT_NE(message.find("crossed the whole domain"), std::string::npos) << message;
    }
  }
}

// The report's dt = 0.01 tunnelling (Fig. 8) moves the ball 1.5 cells a step: not divergence.
TEST(DensityHybrid, AFewCellsAStepIsNotDivergence) {
  Scene scene = ballScene();
  scene.bodies[0].velocity = {3.0, 0, 0};  // 3 cells per step of 0.01 s
  DensityHybridSolver<2> solver(scene, sampleBodies<2>(scene));
  EXPECT_NO_THROW(solver.step(1e-2));
}

}  // namespace
}  // namespace snowsim
