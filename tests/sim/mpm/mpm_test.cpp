// Physical tests of MPM snow (Stomakhin et al. 2013) with known answers.
#include "sim/mpm/mpm_solver.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <type_traits>

#include "sim/core/errors.h"
#include "sim/core/stencil.h"
#include "sim/scene/json_fields.h"
#include "sim/scene/sampling.h"
#include "sim/scene/scene_colliders.h"
#include "sim/simulation.h"
#include "tests/support/threaded_test.h"

using namespace snowsim;

namespace {

Json baseScene() {
  return Json::parse(R"({
    "name": "t", "dimension": 2, "solver": "mpm", "material": {"preset": "paper"},
    "grid": {"cells": [20, 20], "cell_size": 0.01},
    "time": {"dt": 0.001, "duration": 0.1, "fps": 10},
    "particles_per_cell": 4,
    "bodies": [{"shape": "ball", "center": [0.1, 0.1], "radius": 0.03}]
  })");
}

template <int D, class T = Real>
MpmSolver<D, T> makeSolver(const Json& j, int threads = 0) {
  const Scene scene = parseScene(j, "test.json");
  return MpmSolver<D, T>(scene, sampleBodies<D>(scene), threads);
}

template <class Solver>
void run(Solver& s, Real duration) {
  Real t = 0;
  while (t < duration - 1e-12) {
    const Real dt = std::min(s.stableTimeStep(), duration - t);
    s.step(dt);
    t += dt;
  }
}

// Angular momentum about the origin including APIC's affine part m (h^2/4)(C_10 - C_01) (Jiang et
// al. 2015, section 5.3; D_p = h^2/4 I for quadratic B-splines).
template <class T>
Real angularMomentum(const MpmSolver<2, T>& s, bool affine) {
  const Particles<2>& p = s.particles();
  const Real d = s.grid().h * s.grid().h / 4;
  Real L = 0;
  for (int i = 0; i < p.size(); ++i) {
    L += p.mass[i] * (p.x[i][0] * p.v[i][1] - p.x[i][1] * p.v[i][0]);
    if (affine) L += p.mass[i] * d * Real(s.affine()[i](1, 0) - s.affine()[i](0, 1));
  }
  return L;
}

template <class T>
Vec<2> linearMomentum(const MpmSolver<2, T>& s) {
  Vec<2> P = Vec<2>::Zero();
  for (int i = 0; i < s.particles().size(); ++i) P += s.particles().mass[i] * s.particles().v[i];
  return P;
}

Real meanY(const Particles<2>& p, int body) {
  Real y = 0;
  int n = 0;
  for (int i = 0; i < p.size(); ++i)
    if (p.body[i] == body) y += p.x[i][1], ++n;
  return y / n;
}

// An elastic disc spinning at 5 rad/s about its centre (0.2, 0.2), without gravity, in a grid
// whose walls it never reaches: v = omega (-(y - yc), x - xc).
template <class T = Real>
MpmSolver<2, T> spinningDisc(const Json& mpm) {
  Json j = baseScene();
  j["grid"]["cells"] = {40, 40};
  j["gravity"] = {0, 0};
  j["mpm"] = mpm;
  j["material"] = {{"preset", "paper"}, {"theta_c", 0.5}, {"theta_s", 0.5}};
  j["bodies"][0]["center"] = {0.2, 0.2};
  const Scene scene = parseScene(j, "test.json");
  Particles<2> p = sampleBodies<2>(scene);
  for (int i = 0; i < p.size(); ++i) p.v[i] = 5.0 * Vec<2>(-(p.x[i][1] - 0.2), p.x[i][0] - 0.2);
  return MpmSolver<2, T>(scene, std::move(p));
}

// The physical tests run in both precisions (mpm.precision). Their tolerances for round-off are
// per precision: double's carried over the steps, and float's (6e-8 relative per operation), which
// grows to what each float test states, measured in the comment beside it.
template <class T>
class MpmPhysics : public testing::Test {
 protected:
  static Real roundOff(Real in_double, Real in_float) {
    return std::is_same_v<T, float> ? in_float : in_double;
  }
};
struct PrecisionName {
  template <class T>
  static std::string GetName(int) {
    return std::is_same_v<T, float> ? "Float" : "Double";
  }
};
using Precisions = testing::Types<double, float>;
TYPED_TEST_SUITE(MpmPhysics, Precisions, PrecisionName);

}  // namespace

TYPED_TEST(MpmPhysics, FreeFallFollowsTheDiscreteParabola) {
  Json j = baseScene();
  j["grid"]["cells"] = {40, 60};
  j["bodies"][0]["center"] = {0.1, 0.45};
  j["bodies"][0]["velocity"] = {0.3, 0.5};
  j["mpm"] = {{"adaptive_dt", false}};
  auto s = makeSolver<2, TypeParam>(j);
  const Real position_round_off = this->roundOff(1e-11, 1e-5);  // float: 2.3e-6
  const Real strain_round_off = this->roundOff(1e-11, 1e-4);    // float: 3.1e-5
  const std::vector<Vec<2>> x0 = s.particles().x;  // stored in creation order until the first step
  const Real dt = 5e-5;  // below the CFL limit: round-off in the stress must not grow
  const int steps = 400;
  for (int n = 0; n < steps; ++n) s.step(dt);
  const Real t = steps * dt;
  // Symplectic Euler: x_n = x0 + v0 t + g dt^2 n (n + 1) / 2 = analytic + g t dt / 2. The solver
  // has stored the particles in block order since (the ids are no longer in order), and each
  // must still carry its own trajectory and state.
  const Vec<2> v0(0.3, 0.5), g(0, -9.81);
  const std::vector<int>& id = s.particles().id;
  EXPECT_FALSE(std::is_sorted(id.begin(), id.end()));
  for (int i = 0; i < s.particles().size(); ++i) {
    const Vec<2>& start = x0[id[i]];
    const Vec<2> expected = start + v0 * t + g * (dt * dt * steps * (steps + 1) / 2);
    EXPECT_LT((s.particles().x[i] - expected).norm(), position_round_off);
    EXPECT_LT((s.particles().x[i] - (start + v0 * t + 0.5 * g * t * t)).norm(),
              9.81 * t * dt / 2 + position_round_off);
    EXPECT_LT((s.elasticGradient()[i].template cast<Real>() - Mat<2>::Identity()).norm(),
              strain_round_off);
  }
}

TYPED_TEST(MpmPhysics, BallsOfDifferentDensityFallTogether) {
  Json j = baseScene();
  j["grid"]["cells"] = {30, 30};
  j["bodies"] = Json::parse(R"([
    {"shape": "ball", "center": [0.07, 0.2], "radius": 0.03, "density": 200},
    {"shape": "ball", "center": [0.22, 0.2], "radius": 0.03, "density": 400}])");
  auto s = makeSolver<2, TypeParam>(j);
  run(s, 0.15);  // before landing
  EXPECT_NEAR(meanY(s.particles(), 0), meanY(s.particles(), 1),
              this->roundOff(1e-9, 1e-6));  // float: 5.8e-8
  EXPECT_LT(meanY(s.particles(), 0), 0.2 - 0.09);
  run(s, 0.25);  // landed on the ground
  EXPECT_NEAR(meanY(s.particles(), 0), meanY(s.particles(), 1), 2e-3);
}

TYPED_TEST(MpmPhysics, AffineTransfersConserveMomentaOfASpinningDisc) {
  for (const char* transfer : {"apic", "mls"}) {
    auto s = spinningDisc<TypeParam>({{"transfer", transfer}});
    const Real L0 = angularMomentum(s, false);
    const Vec<2> P0 = linearMomentum(s);
    for (int n = 0; n < 300; ++n) s.step(s.stableTimeStep());
    EXPECT_NEAR(angularMomentum(s, true), L0,
                this->roundOff(1e-10, 5e-3) * std::abs(L0))  // float: 1.5e-3
        << transfer;
    EXPECT_LT((linearMomentum(s) - P0).norm(), this->roundOff(1e-12, 5e-5))  // float: 1.3e-5
        << transfer;
  }
}

TEST(Mpm, PicLosesAngularMomentum) {
  auto s = spinningDisc({{"transfer", "pic_flip"}, {"flip_alpha", 0.0}});
  const Real L0 = angularMomentum(s, false);
  for (int n = 0; n < 300; ++n) s.step(s.stableTimeStep());
  const Real loss = 1 - angularMomentum(s, false) / L0;
  std::printf("PIC (alpha = 0) lost %.1f%% of the angular momentum in 300 steps\n", 100 * loss);
  EXPECT_GT(loss, 0.5);
  EXPECT_LT(linearMomentum(s).norm(), 1e-12);
}

TYPED_TEST(MpmPhysics, BlockAtRestStaysAtRest) {
  Json j = baseScene();
  j["bodies"] = Json::parse(R"([{"shape": "box", "center": [0.1, 0.03], "size": [0.08, 0.06]}])");
  auto s = makeSolver<2, TypeParam>(j);
  run(s, 0.3);
  Real fastest = 0;
  for (const Vec<2>& v : s.particles().v) fastest = std::max(fastest, v.norm());
  EXPECT_LT(fastest, 0.02);
  EXPECT_NEAR(meanY(s.particles(), 0), 0.03, 2e-3);
}

TYPED_TEST(MpmPhysics, PlasticityBoundsAndCompaction) {
  Json j = baseScene();
  j["bodies"][0]["velocity"] = {0, -2};
  auto s = makeSolver<2, TypeParam>(j);
  run(s, 0.1);
  const SnowMaterial m = s.material();
  const Real round_off = this->roundOff(1e-9, 1e-6);  // float: within the bounds exactly
  int compacted = 0;
  for (int i = 0; i < s.particles().size(); ++i) {
    // Singular values of F_E as square roots of the eigenvalues of F_E^T F_E (in double):
    // independent of the solver's own SVD.
    const Mat<2> F = s.elasticGradient()[i].template cast<Real>();
    const Vec<2> sigma =
        Eigen::SelfAdjointEigenSolver<Mat<2>>(F.transpose() * F).eigenvalues().cwiseSqrt();
    EXPECT_GE(sigma.minCoeff(), 1 - m.theta_c - round_off);
    EXPECT_LE(sigma.maxCoeff(), 1 + m.theta_s + round_off);
    if (s.plasticJ()[i] < 0.95) {
      ++compacted;
      EXPECT_GT(s.lame(i).mu, m.mu0());  // hardening: compacted snow is stiffer
    }
  }
  EXPECT_GT(compacted, s.particles().size() / 10);
}

TEST(Mpm, NoParticleEndsInsideACollider) {
  Json j = baseScene();
  j["bodies"][0]["center"] = {0.1, 0.15};
  j["colliders"] = Json::parse(R"([
    {"shape": "sphere", "position": [0.1, 0.06], "radius": 0.03, "type": "sticky"},
    {"shape": "box", "position": [0.03, 0.05], "size": [0.02, 0.1], "velocity": [0.1, 0]}])");
  auto s = makeSolver<2>(j);
  for (int frame = 0; frame < 10; ++frame) {
    run(s, 0.03);
    for (const Vec<2>& x : s.particles().x) {
      for (const Collider<2>& c : s.colliders()) EXPECT_GE(c.phi(x), -1e-12);
    }
  }
}

// The lowest particle of snow come to rest on the floor, in cells above it.
template <int D>
Real restingHeight(Json j) {
  auto s = makeSolver<D>(j);
  run(s, 0.6);
  Real lowest = s.grid().extent()[1];
  for (const Vec<D>& x : s.particles().x) lowest = std::min(lowest, x[1]);
  return lowest / s.grid().h;
}

// Snow dropped on the floor rests on it: its grid nodes meet the floor a tenth of a cell inside
// (mpm.collider_inset), so the snow's lowest particles lie within a quarter cell of it, in 2D and
// 3D; nodes stopped on the floor itself (the paper's rule, inset 0) hold it over a cell up.
TEST(Mpm, SnowRestsOnTheFloorNotACellAboveIt) {
  Json flat = baseScene();
  Json deep = Json::parse(R"({
    "name": "t", "dimension": 3, "solver": "mpm", "material": {"preset": "paper"},
    "grid": {"cells": [8, 8, 8], "cell_size": 0.01},
    "time": {"dt": 0.001, "duration": 0.1, "fps": 10},
    "particles_per_cell": 8,
    "bodies": [{"shape": "box", "center": [0.04, 0.04, 0.04], "size": [0.03, 0.03, 0.03]}]
  })");
  EXPECT_LT(restingHeight<2>(flat), 0.25);
  EXPECT_LT(restingHeight<3>(deep), 0.25);
  flat["mpm"]["collider_inset"] = 0;
  deep["mpm"]["collider_inset"] = 0;
  EXPECT_GT(restingHeight<2>(flat), 1);
  EXPECT_GT(restingHeight<3>(deep), 1);
}

TEST(Mpm, SnapshotsCarryTheCollidersWhereTheyAre) {
  // A moving box and a sphere; the snapshot draws them where they are at its time, a 2D scene's
  // colliders at z = 0 and, run in 3D, through the slab.
  Json j = baseScene();
  j["bodies"][0]["center"] = {0.1, 0.15};
  j["colliders"] = Json::parse(R"([
    {"shape": "sphere", "position": [0.1, 0.06], "radius": 0.03},
    {"shape": "box", "position": [0.03, 0.05], "size": [0.02, 0.1], "velocity": [0.5, 0]}])");
  const Scene scene = parseScene(j, "test.json");
  auto simulation = makeSimulation(scene);
  simulation->advanceTo(0.02);
  const Snapshot s = simulation->snapshot(1);
  ASSERT_EQ(s.colliders.size(), 2u);
  EXPECT_EQ(s.colliders[0].shape, SnapshotCollider::Shape::Sphere);
  EXPECT_DOUBLE_EQ(s.colliders[0].radius, 0.03);
  EXPECT_EQ(s.colliders[1].shape, SnapshotCollider::Shape::Box);
  EXPECT_NEAR(s.colliders[1].position[0], 0.03 + 0.5 * s.time, 1e-12) << "moved with its velocity";
  EXPECT_DOUBLE_EQ(s.colliders[1].position[2], 0);

  const std::vector<SnapshotCollider> slab = collidersAt(scene, 3, 0);
  const double depth = scene.extent()[2];
  EXPECT_DOUBLE_EQ(slab[1].position[2], depth / 2);
  EXPECT_DOUBLE_EQ(slab[1].size[2], depth);
}

TEST(Mpm, SnapshotsKeepTheParticlesInCreationOrder) {
  // The solver stores the particles by grid block, which interleaves two balls side by side; the
  // snapshot (what images and files show) must list the first ball's particles first, each with
  // its own density, as the scene created them.
  Json j = baseScene();
  j["bodies"] = {{{"shape", "ball"}, {"center", {0.05, 0.1}}, {"radius", 0.03}},
                 {{"shape", "ball"}, {"center", {0.15, 0.1}}, {"radius", 0.03}, {"density", 200}}};
  auto solver = makeSolver<2>(j);
  solver.step(1e-4);
  const std::vector<int>& id = solver.particles().id;
  ASSERT_FALSE(std::is_sorted(id.begin(), id.end())) << "the balls must be stored interleaved";

  const Scene scene = parseScene(j, "test.json");
  const std::vector<int> body = sampleBodies<2>(scene).body;
  const int first_ball = static_cast<int>(std::count(body.begin(), body.end(), 0));
  auto simulation = makeSimulation(scene);
  simulation->advanceTo(0.01);
  const Snapshot snapshot = simulation->snapshot(1);
  for (int i = 0; i < static_cast<int>(snapshot.position.size()); ++i) {
    ASSERT_EQ(snapshot.position[i][0] < 0.1f, i < first_ball) << "particle " << i;
    ASSERT_EQ(snapshot.density[i] > 300, i < first_ball) << "particle " << i;
  }
}

// A float solver writes its snapshot's particles from its own arrays, without the double copy
// particles() makes: the snapshot must be the one that copy gives, value for value.
TEST(Mpm, FloatSnapshotIsTheOneOfItsDoubleCopy) {
  Json j = baseScene();
  j["bodies"] = {{{"shape", "ball"}, {"center", {0.05, 0.1}}, {"radius", 0.03}},
                 {{"shape", "ball"}, {"center", {0.15, 0.1}}, {"radius", 0.03}, {"density", 200}}};
  j["bodies"][0]["velocity"] = {1, -1};
  const Scene scene = parseScene(j, "test.json");
  MpmSolver<2, float> solver(scene, sampleBodies<2>(scene));
  for (int i = 0; i < 20; ++i) solver.step(1e-4);
  Snapshot direct, through_double;
  solver.snapshotParticles(scene, direct);
  putParticles(solver.particles(), scene, through_double);
  ASSERT_EQ(direct.position.size(), std::size_t(solver.particleCount()));
  EXPECT_EQ(direct.position, through_double.position);
  EXPECT_EQ(direct.velocity, through_double.velocity);
  EXPECT_EQ(direct.mass, through_double.mass);
  EXPECT_EQ(direct.radius, through_double.radius);
  EXPECT_NE(direct.velocity[0], (std::array<float, 3>{0, 0, 0})) << "a moving ball, not zeros";
}

TEST(Mpm, TwoAndThreeDimensionsAgreeOnAZUniformScene) {
  Json j = baseScene();
  j["bodies"][0]["velocity"] = {1, -1};
  j["mpm"] = {{"adaptive_dt", false}};
  auto s2 = makeSolver<2>(j);
  j["dimension"] = 3;
  j["particles_per_cell"] = 4;
  auto s3 = makeSolver<3>(j);
  for (int n = 0; n < 1500; ++n) {
    s2.step(5e-5);
    s3.step(5e-5);
  }
  // Measured: the centres of mass differ by 0.03 mm after 0.075 s. (3.8 mm with the paper's
  // grid-density volumes, mpm.initial_volume = grid_density: the one-cell-deep slab cuts the
  // kernel's z-support, which overestimates the 3D volumes and so the stress.)
  Vec<2> c2 = Vec<2>::Zero(), c3 = Vec<2>::Zero();
  for (const Vec<2>& x : s2.particles().x) c2 += x / s2.particles().size();
  for (const Vec<3>& x : s3.particles().x) c3 += x.head<2>() / s3.particles().size();
  EXPECT_LT((c2 - c3).norm(), 1e-4);
  for (const Vec<3>& v : s3.particles().v) EXPECT_EQ(v[2], 0);
}

TEST(Mpm, EmptySpaceAroundTheSnowCostsNothingAndChangesNothing) {
  // The grid stages touch only the nodes near the snow (the active box): the same ball thrown at
  // the left wall and onto the ground, in its 20x20 grid and in a 40x40 grid whose extra cells it
  // never reaches, must give bit-identical particles. Any node left stale outside the box, or any
  // node the box misses, would show here.
  for (const char* transfer : {"pic_flip", "mls"}) {
    Json j = baseScene();
    j["bodies"][0]["velocity"] = {-1.5, -0.5};
    j["mpm"] = {{"transfer", transfer}};
    auto small = makeSolver<2>(j);
    j["grid"]["cells"] = {40, 40};
    auto large = makeSolver<2>(j);
    run(small, 0.15);
    run(large, 0.15);
    const auto in_small = small.particles().positionsById(),
               in_large = large.particles().positionsById();
    for (size_t p = 0; p < in_small.size(); ++p)
      ASSERT_EQ(in_small[p], in_large[p]) << transfer << " particle " << p;
  }
}

TEST(Mpm, TheGridKeepsNoMassWhereTheSnowWas) {
  // The grid stage touches only the nodes near the snow, and must still zero the nodes the snow
  // has left: the images draw every node's density. After each step the grid holds exactly the
  // particles' mass (the transfer conserves it), never a leftover of an earlier step, even when
  // the snow jumped further than a step allows (the public stages do not check the step).
  Json j = baseScene();
  j["grid"]["cells"] = {40, 40};
  j["gravity"] = {0, 0};  // a jump without gravity keeps the energy the blow-up check watches
  j["bodies"][0]["velocity"] = {3, 0};
  auto s = makeSolver<2>(j);
  Real particle_mass = 0;
  for (const Real m : s.particles().mass) particle_mass += m;
  const auto gridMass = [&] {
    Real mass = 0;
    for (const Real m : s.fields().mass) mass += m;
    return mass;
  };
  for (int step = 0; step < 20; ++step) {
    s.step(0.0003);  // within the CFL limit
    ASSERT_NEAR(gridMass(), particle_mass, 1e-12 * particle_mass) << "step " << step;
  }
  const Real before_jump = s.particles().positionsById()[0][0];
  s.updateParticles(0.02);  // about 6 cells in one pass
  s.step(0.0001);
  EXPECT_GT(s.particles().positionsById()[0][0] - before_jump, 5 * s.grid().h);
  EXPECT_NEAR(gridMass(), particle_mass, 1e-12 * particle_mass);
}

// Two balls far apart, one still, one thrown along x: the grid stage visits only the blocks of
// nodes near the snow, not the whole box around both balls, and must still zero those the thrown
// ball leaves. After every step the grid holds exactly the particles' mass, and a node without mass
// has no velocity. Thrown away from the still ball, the thrown one leads the box and is binned
// anew as it goes; thrown towards a still ball at the domain's edge, a 2D row may drift along x
// without a binning. Then a jump of 8 cells, scattered by the public stage before the next step.
template <int D>
void expectNoStaleNodesBetweenTwoBalls(Real still_x, Real thrown_x, Real speed) {
  Json j = baseScene();
  j["dimension"] = D;
  j["grid"]["cells"] = D == 2 ? Json{48, 24} : Json{48, 24, 24};
  j["particles_per_cell"] = D == 2 ? 4 : 8;
  j["gravity"] = D == 2 ? Json{0, 0} : Json{0, 0, 0};
  const Json still = D == 2 ? Json{still_x, 0.05} : Json{still_x, 0.05, 0.05};
  const Json thrown = D == 2 ? Json{thrown_x, 0.18} : Json{thrown_x, 0.18, 0.18};
  // 3D: balls of 2,100 particles each, so that two threads bin them in two parts.
  const Real radius = D == 2 ? 0.025 : 0.04;
  j["bodies"] = {{{"shape", "ball"}, {"center", still}, {"radius", radius}},
                 {{"shape", "ball"},
                  {"center", thrown},
                  {"radius", radius},
                  {"velocity", D == 2 ? Json{speed, 0} : Json{speed, 0, 0}}}};
  auto s = makeSolver<D>(j, 2);
  Real particle_mass = 0;
  for (const Real m : s.particles().mass) particle_mass += m;
  const auto expectNoStaleNode = [&](int step) {
    Real grid_mass = 0;
    for (size_t k = 0; k < s.fields().mass.size(); ++k) {
      grid_mass += s.fields().mass[k];
      if (s.fields().mass[k] == 0) {
        ASSERT_EQ(s.fields().velocity[k], Vec<D>::Zero())
            << D << "D, step " << step << ", node " << k;
      }
    }
    ASSERT_NEAR(grid_mass, particle_mass, 1e-12 * particle_mass) << D << "D, step " << step;
  };
  const auto thrownX = [&] {
    Real sum = 0;
    int n = 0;
    for (int p = 0; p < s.particles().size(); ++p)
      if (s.particles().body[p] == 1) sum += s.particles().x[p][0], ++n;
    return sum / n;
  };
  for (int step = 0; step < 130; ++step) {
    s.step(0.0003);  // within the CFL limit; 0.12 of a cell per step at 4 m/s: 16 cells in all
    expectNoStaleNode(step);
  }
  EXPECT_GT(std::abs(thrownX() - thrown_x), 12 * s.grid().h) << D << "D: the thrown ball moved";
  // The public stages do not check the step.
  s.updateParticles(0.02);
  s.scatter(0.0001);
  s.step(0.0001);
  expectNoStaleNode(131);
}

TEST(Mpm, TheGridKeepsNoMassOrVelocityBetweenSeparateBalls) {
  expectNoStaleNodesBetweenTwoBalls<2>(0.05, 0.1, 4);
  expectNoStaleNodesBetweenTwoBalls<3>(0.05, 0.1, 4);
  expectNoStaleNodesBetweenTwoBalls<2>(0.045, 0.3, -4);
  expectNoStaleNodesBetweenTwoBalls<3>(0.045, 0.3, -4);
}

// 2D bins the particles anew once one has moved more than a cell (drift_cells,
// sim/parallel/row_binning.h) beyond its row's cells, and not before. A ball translating along y,
// sampled 2 x 2 per cell (a quarter and three quarters into each cell), must be binned anew each
// time it has moved 1 to 1.5 cells since the last binning: 2 cells less how far into its row's last
// cell the particle nearest the row's end sits. Allowing two cells, or none, would give 2-2.5 or
// 0-0.5.
TEST(Mpm, ParticlesAreBinnedAnewOnceOneMovesMoreThanACellBeyondItsRow) {
  for (const double vy : {2.0, -2.0}) {
    Json j = baseScene();
    j["grid"]["cells"] = {40, 40};
    j["gravity"] = {0, 0};
    j["bodies"][0]["center"] = {0.2, 0.2};
    j["bodies"][0]["radius"] = 0.05;
    j["bodies"][0]["velocity"] = {0, vy};
    auto s = makeSolver<2>(j);
    const Real h = s.grid().h, dt = 0.02 * h / std::abs(vy);  // a fiftieth of a cell a step
    // Every particle moves alike: the first one made, wherever the sorts have stored it.
    const auto height = [&] { return s.particles().positionsById()[0][1]; };
    Real y_at_binning = height();
    long binnings = s.binnings();
    std::vector<Real> moved;  // cells moved from one binning to the next
    for (int step = 0; step < 2000 && moved.size() < 4; ++step) {
      const Real y = height();
      s.step(dt);
      if (s.binnings() > binnings) {  // binned at the start of this step, where it found y
        moved.push_back(std::abs(y - y_at_binning) / h);
        y_at_binning = y;
        binnings = s.binnings();
      }
    }
    ASSERT_EQ(moved.size(), 4u) << "v_y " << vy;
    for (const Real cells : moved) {
      EXPECT_GT(cells, 1.0) << "v_y " << vy << ": " << cells;
      EXPECT_LE(cells, 1.5 + 0.02 + 1e-9) << "v_y " << vy << ": " << cells;
    }
  }
}

// The step's limit split into its terms: the particle that sets the CFL step, its speed, its
// elastic wave speed and the hardening that raised it, as the time-step policy sees them; the
// semi-implicit step has no wave term. The stages a step timed fit in the step's time.
TEST(Mpm, StepLimitNamesTheTermsOfTheStableStep) {
  Json j = baseScene();
  j["bodies"][0]["center"] = {0.1, 0.04};
  j["bodies"][0]["velocity"] = {0, -4};  // into the ground: it compacts and hardens
  auto s = makeSolver<2>(j);
  run(s, 0.02);
  const StepLimit limit = s.stepLimit();
  EXPECT_NEAR(limit.step, s.params().cfl * s.grid().h / (limit.wave_speed + limit.particle_speed),
              1e-12 * limit.step);
  EXPECT_LT(limit.plastic_j, 1) << "compacted";
  EXPECT_NEAR(limit.hardening, std::exp(s.material().xi * (1 - limit.plastic_j)),
              1e-9 * limit.hardening);
  const Real rest_wave = pWaveSpeed(hardenedLame(s.material(), Real(1)), Real(400));
  EXPECT_NEAR(limit.wave_speed, rest_wave * std::sqrt(limit.hardening), 1e-9 * limit.wave_speed);

  double staged = 0;
  for (const StageSeconds& stage : s.stageSeconds()) staged += stage.seconds;
  EXPECT_GT(staged, 0);
  EXPECT_LE(staged, s.stepSeconds());

  j["mpm"]["integrator"] = "semi_implicit";
  auto semi = makeSolver<2>(j);
  run(semi, 0.002);
  EXPECT_EQ(semi.stepLimit().wave_speed, 0);
  EXPECT_NEAR(semi.stepLimit().step,
              semi.params().cfl * semi.grid().h / semi.stepLimit().particle_speed,
              1e-12 * semi.stepLimit().step);
}

// Between binnings each row scatters the particles it was given into nodes its colour keeps for
// it. A ball thrown up and sideways without gravity crosses several rows: after every step the
// grid must hold all of its mass, 1 and 2 threads must agree bit for bit, and the particles must
// have been binned more than once but far less often than every step.
THREADED_TEST(Mpm, RowsHoldBetweenBinningsOnAnyThreadCount) {
  Json j = baseScene();
  j["grid"]["cells"] = {40, 40};
  j["gravity"] = {0, 0};
  j["particles_per_cell"] = 16;
  j["bodies"][0]["center"] = {0.14, 0.12};
  j["bodies"][0]["radius"] = 0.1;
  j["bodies"][0]["velocity"] = {2, 2.5};
  const int steps = 120;
  const auto runOn = [&](int threads) {
    auto s = makeSolver<2>(j, threads);
    EXPECT_GT(s.particles().size(), 2048) << "the threaded path must run";
    Real particle_mass = 0;
    for (const Real m : s.particles().mass) particle_mass += m;
    const Real dt = 0.5 * s.cflTimeStep(), y0 = s.particles().positionsById()[0][1];
    for (int step = 0; step < steps; ++step) {
      s.step(dt);
      Real grid_mass = 0;
      for (const Real m : s.fields().mass) grid_mass += m;
      EXPECT_NEAR(grid_mass, particle_mass, 1e-12 * particle_mass)
          << threads << " threads, step " << step;
    }
    EXPECT_GT(s.particles().positionsById()[0][1] - y0, 5 * s.grid().h) << "it must cross rows";
    EXPECT_GT(s.binnings(), 2) << threads << " threads";
    EXPECT_LT(s.binnings(), steps / 5) << threads << " threads";
    return s.particles().positionsById();
  };
  const auto one = runOn(1), two = runOn(2);
  EXPECT_TRUE(one == two) << "1 and 2 threads";
}

// The grid stage empties the partial grids as it sums them; a scatter of the public stages that
// no grid stage summed must not add to the next step's.
TEST(Mpm, AStepAfterAPublicScatterCountsOneScatter) {
  Json j = baseScene();
  j["bodies"][0]["velocity"] = {1, -2};
  auto plain = makeSolver<2>(j), scattered = makeSolver<2>(j);
  const Real dt = 2e-4;
  for (int step = 0; step < 20; ++step) {
    plain.step(dt);
    scattered.step(dt);
  }
  scattered.scatter(dt);
  plain.step(dt);
  scattered.step(dt);
  Real mass = 0, particle_mass = 0;
  for (const Real m : scattered.fields().mass) mass += m;
  for (const Real m : scattered.particles().mass) particle_mass += m;
  EXPECT_NEAR(mass, particle_mass, 1e-12 * particle_mass);
  const auto a = plain.particles().positionsById(), b = scattered.particles().positionsById();
  for (size_t p = 0; p < a.size(); ++p) ASSERT_NEAR((a[p] - b[p]).norm(), 0, 1e-12) << p;
}

TEST(Mpm, ScatteringTwiceGivesTheGridOfOneScatter) {
  // The stages are public: a second scatter before the grid stage replaces the first, it does
  // not add to it.
  for (const char* transfer : {"pic_flip", "mls"}) {
    Json j = baseScene();
    j["bodies"][0]["velocity"] = {1, -2};
    j["mpm"] = {{"transfer", transfer}};
    auto once = makeSolver<2>(j), twice = makeSolver<2>(j);
    once.scatter(0);
    once.updateGridVelocities(0);
    twice.scatter(0);
    twice.scatter(0);
    twice.updateGridVelocities(0);
    Real mass = 0;
    for (const Real m : once.fields().mass) mass += m;
    EXPECT_GT(mass, 0) << transfer;
    EXPECT_EQ(once.fields().mass, twice.fields().mass) << transfer;
    EXPECT_EQ(once.fields().velocity, twice.fields().velocity) << transfer;
    EXPECT_EQ(once.fields().force, twice.fields().force) << transfer;
  }
}

TEST(Mpm, ExplicitAboveTheCflLimitIsStopped) {
  // Measured on the snowball drop: explicit MPM is stable at a fixed dt of 0.001 s and blows up
  // at 0.0015 s; 0.003 s is well beyond.
  const std::string path = SNOWSIM_SOURCE_DIR "/scenes/snowball_drop.json";
  auto sim =
      makeSimulation(loadScene(path, {"solver=mpm", "mpm.adaptive_dt=false", "time.dt=0.003"}));
  std::string what;
  try {
    sim->advanceTo(1.0);
    FAIL() << "no blow-up detected";
  } catch (const SimulationError& e) {
    what = e.what();
  }
  EXPECT_NE(what.find("at step"), std::string::npos) << what;
  EXPECT_NE(what.find("largest speed"), std::string::npos) << what;
  EXPECT_NE(what.find("CFL limit"), std::string::npos) << what;
  EXPECT_EQ(what.find("nan"), std::string::npos) << what;

  // The time step it recommends runs.
  const std::string marker = "time.dt below ";
  ASSERT_NE(what.find(marker), std::string::npos) << what;
  const double recommended = std::stod(what.substr(what.find(marker) + marker.size()));
  EXPECT_LT(recommended, 0.003);
  auto rerun = makeSimulation(loadScene(
      path, {"solver=mpm", "mpm.adaptive_dt=false", "time.dt=" + std::to_string(recommended)}));
  EXPECT_NO_THROW(rerun->advanceTo(0.2));
}

TEST(Mpm, AnUnstableStepSlowerThanACellPerStepIsCaughtByTheEnergy) {
  // At a fixed dt of 0.001 s explicit MPM blows the snowball drop apart at 2-4 m/s: under a cell
  // per step, but its kinetic plus gravitational energy doubles. At 0.0005 s it falls intact.
  const std::string path = SNOWSIM_SOURCE_DIR "/scenes/snowball_drop.json";
  auto unstable =
      makeSimulation(loadScene(path, {"solver=mpm", "mpm.adaptive_dt=false", "time.dt=0.001"}));
  try {
    unstable->advanceTo(0.2);
    FAIL() << "the explosion was not caught";
  } catch (const SimulationError& e) {
    EXPECT_NE(std::string(e.what()).find("energy grew"), std::string::npos) << e.what();
  }
  auto stable =
      makeSimulation(loadScene(path, {"solver=mpm", "mpm.adaptive_dt=false", "time.dt=0.0005"}));
  EXPECT_NO_THROW(stable->advanceTo(0.2));
}

TEST(Mpm, BadInputNamesTheField) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"material.nu=0.5", "material.nu"},
      {"material.E0=0", "material.E0"},
      {"material.theta_c=1", "material.theta_c"},
      {"material.theta_s=0", "material.theta_s"},
      {"solver=fem", "solver"},
      {"mpm.transfer=sph", "mpm.transfer"},
      {"mpm.precision=half", "mpm.precision"},
      {"colliders=[{\"shape\":\"box\",\"position\":[0.05,0.05],\"size\":[-0.01,0.02]}]",
       "colliders[0].size"}};
  for (const auto& [assignment, field] : cases) {
    try {
      loadScene(SNOWSIM_SOURCE_DIR "/scenes/snowball_drop.json", {assignment});
      ADD_FAILURE() << assignment << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  }
  // Single precision runs the explicit integrator only.
  try {
    loadScene(SNOWSIM_SOURCE_DIR "/scenes/snowball_drop.json",
              {"mpm.precision=float", "mpm.integrator=semi_implicit"});
    ADD_FAILURE() << "a float semi-implicit scene was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mpm.precision"), std::string::npos) << e.what();
  }
}

// Runs the scene for 4 ms on 1 (twice), 2 and 3 threads, and on 3 threads then 2 on one solver,
// and expects the same positions bit for bit. Three threads on two cores: the work splits
// unevenly and the threads take turns.
template <int D, class T = Real>
void expectBitIdenticalOnAnyThreadCount(const Json& j, const std::string& what) {
  auto runWith = [&](int threads, int then_threads) {
    auto s = makeSolver<D, T>(j, threads);
    run(s, 0.002);
    s.setThreads(then_threads);
    run(s, 0.002);
    return s.particles().positionsById();
  };
  const auto one = runWith(1, 1), again = runWith(1, 1), two = runWith(2, 2), three = runWith(3, 3),
             fewer = runWith(3, 2);
  ASSERT_GT(one.size(), 2048u) << what << ": the threaded path must run";
  EXPECT_TRUE(one == again) << what << ", 1 thread twice";
  EXPECT_TRUE(one == two) << what << ", 2 threads";
  EXPECT_TRUE(one == three) << what << ", 3 threads";
  EXPECT_TRUE(one == fewer) << what << ", 3 threads then 2";
}

// The transfers compiled for AVX-512, AVX2 and the x86-64 baseline (chosen at run time by
// vectorIsa()) do the same arithmetic: the same positions bit for bit, 2D and 3D, double and
// float. Each build the processor runs is compared with the baseline; on one without AVX2 there is
// only the baseline.
template <int D, class T = Real>
void expectSameOnEveryVectorIsa(const Json& j, const std::string& what) {
  const VectorIsa best = vectorIsa();
  auto runWith = [&](VectorIsa isa) {
    vectorIsa() = isa;
    auto s = makeSolver<D, T>(j, 1);
    run(s, 0.004);
    return s.particles().positionsById();
  };
  const auto baseline = runWith(VectorIsa::baseline);
  if (best >= VectorIsa::avx2) {
    EXPECT_TRUE(runWith(VectorIsa::avx2) == baseline) << what << ", AVX2";
  }
  if (best >= VectorIsa::avx512) {
    EXPECT_TRUE(runWith(VectorIsa::avx512) == baseline) << what << ", AVX-512";
  }
  vectorIsa() = best;
}

// The crack opening's fields are summed per colour as the partial grids are: two blocks of j's
// grid pulled apart at 2 m/s, which stretches the snow where they touch from the first steps.
template <int D, class T = Real>
void expectCracksOpenBitIdenticallyOnAnyThreadCount(Json j) {
  j["mpm"] = {{"open_cracks", true}};
  j["material"] = {{"preset", "paper"}, {"fracture_strain", 0.02}};
  const Json block = j["bodies"][0];
  j["bodies"] = Json::array();
  for (const int side : {-1, 1}) {
    Json b = block;
    b["shape"] = "box";
    b.erase("radius");
    b["center"][0] = 0.2 + side * 0.05;
    b["size"] = D == 2 ? Json{0.1, 0.1} : Json{0.1, 0.1, 0.04};
    b["velocity"] = D == 2 ? Json{side * 2.0, 0} : Json{side * 2.0, 0, 0};
    j["bodies"].push_back(b);
  }
  auto s = makeSolver<D, T>(j, 1);
  run(s, 0.002);
  const auto& stages = s.stageSeconds();
  EXPECT_TRUE(std::any_of(stages.begin(), stages.end(), [](const StageSeconds& st) {
    return st.stage == "crack: scatter";
  })) << "the cracks' passes must run";
  expectBitIdenticalOnAnyThreadCount<D, T>(j, D == 2 ? "2D, cracks open" : "3D, cracks open");
}

THREADED_TEST(Mpm, SameSceneAndThreadCountsGiveBitIdenticalResults) {
  Json j = baseScene();
  j["bodies"][0]["velocity"] = {1, -2};
  j["bodies"][0]["center"] = {0.2, 0.15};
  j["bodies"][0]["radius"] = 0.1;
  j["particles_per_cell"] = 16;
  j["grid"]["cells"] = {40, 30};
  for (const char* transfer : {"pic_flip", "mls"}) {  // PIC/FLIP scatters forces too
    j["mpm"] = {{"transfer", transfer}};
    expectBitIdenticalOnAnyThreadCount<2>(j, transfer);
  }
  expectBitIdenticalOnAnyThreadCount<2, float>(j, "mls, float");
  expectCracksOpenBitIdenticallyOnAnyThreadCount<2>(j);
  expectSameOnEveryVectorIsa<2>(j, "2D MLS, transfers for any processor");
  expectSameOnEveryVectorIsa<2, float>(j, "2D MLS, float, transfers for any processor");
  j["mpm"] = {{"integrator", "semi_implicit"}};
  expectBitIdenticalOnAnyThreadCount<2>(j, "semi-implicit");
  // 3D: four colours of rows, blocks of 4^3 cells.
  j["dimension"] = 3;
  j["particles_per_cell"] = 8;
  j["grid"]["cells"] = {40, 30, 12};
  j["bodies"][0]["center"] = {0.2, 0.15, 0.06};
  j["bodies"][0]["radius"] = 0.05;
  j["bodies"][0]["velocity"] = {1, -2, 0.5};
  j["mpm"] = {{"transfer", "apic"}};
  expectBitIdenticalOnAnyThreadCount<3>(j, "3D APIC");
  expectBitIdenticalOnAnyThreadCount<3, float>(j, "3D APIC, float");
  expectCracksOpenBitIdenticallyOnAnyThreadCount<3, float>(j);
  expectSameOnEveryVectorIsa<3>(j, "3D APIC, transfers for any processor");
  expectSameOnEveryVectorIsa<3, float>(j, "3D APIC, float, transfers for any processor");
}

// The particles' stored order changes only round-off (the order of the scatter's sums within a
// block): each particle's state follows it through the sorts that store it in the sorted order.
// A sort that left one array behind would give that array's values to other particles, in a
// different way for each starting order.
TEST(Mpm, StoredOrderChangesOnlyRoundOff) {
  Json j = baseScene();
  j["bodies"][0]["velocity"] = {0.5, -3};  // into the ground: compaction, plastic flow
  j["bodies"][0]["center"] = {0.1, 0.04};
  const Scene scene = parseScene(j, "test.json");
  const auto stateById = [](const MpmSolver<2>& s) {
    const Particles<2>& p = s.particles();
    std::vector<Eigen::Matrix<Real, 10, 1>> by_id(p.size());
    for (int i = 0; i < p.size(); ++i)
      by_id[p.id[i]] << p.x[i], p.v[i], s.plasticJ()[i], s.elasticGradient()[i].reshaped(),
          s.affine()[i].norm();
    return by_id;
  };
  Particles<2> reversed = sampleBodies<2>(scene);
  for (auto* array : {&reversed.x, &reversed.v}) std::reverse(array->begin(), array->end());
  for (auto* array : {&reversed.mass, &reversed.volume}) std::reverse(array->begin(), array->end());
  for (auto* array : {&reversed.body, &reversed.id}) std::reverse(array->begin(), array->end());
  MpmSolver<2> as_sampled(scene, sampleBodies<2>(scene)), other_order(scene, reversed);
  for (int step = 0; step < 50; ++step) {  // stored sorted at 0, and after binnings
    as_sampled.step(2e-4);
    other_order.step(2e-4);
  }
  const auto a = stateById(as_sampled), b = stateById(other_order);
  Real worst = 0, plastic = 0;
  for (size_t p = 0; p < a.size(); ++p) {
    worst = std::max(worst, ((a[p] - b[p]).array().abs() / (1 + a[p].array().abs())).maxCoeff());
    plastic = std::max(plastic, std::abs(1 - a[p][4]));
  }
  EXPECT_GT(plastic, 1e-3) << "the snow must have compacted, so the state differs per particle";
  EXPECT_LT(worst, 1e-9) << "largest difference relative to 1 + |value|";
}

// The report's Fig. 8 scene with the MPM solver: the thrown ball (body 1) hits the tower (body 0)
// and stays on its side; the report's method lets it through at dt = 0.01
// (tests/sim/report/report_scenes_test.cpp keeps that failure).
TEST(Mpm, ThrownBallDoesNotPassThroughTheTower) {
  const std::string path = std::string(SNOWSIM_SOURCE_DIR) + "/scenes/column_thrown_ball.json";
  for (const char* transfer : {"pic_flip", "apic", "mls"}) {
    const Scene scene = loadScene(path, {"solver=mpm", std::string("mpm.transfer=") + transfer});
    MpmSolver<2> solver(scene, sampleBodies<2>(scene));
    const Particles<2>& p = solver.particles();
    // The ball does reach the tower: its front comes within a cell of the tower's left face.
    Real ball_front = 0;
    for (int k = 0; k < 50; ++k) {
      run(solver, 0.01);
      for (int i = 0; i < p.size(); ++i)
        if (p.body[i] == 1) ball_front = std::max(ball_front, p.x[i][0]);
    }
    const Real tower_left = 0.06;  // scenes/column_thrown_ball.json: centre 0.07, width 0.02
    EXPECT_GT(ball_front, tower_left - scene.cell_size) << transfer;
    Real tower_right = 0, tower_centre = 0, ball_centre = 0;
    int tower_n = 0, ball_n = 0, ball_beyond_centre = 0;
    for (int i = 0; i < p.size(); ++i)
      if (p.body[i] == 0)
        tower_right = std::max(tower_right, p.x[i][0]), tower_centre += p.x[i][0], ++tower_n;
    tower_centre /= tower_n;
    for (int i = 0; i < p.size(); ++i) {
      if (p.body[i] != 1) continue;
      ball_centre += p.x[i][0], ++ball_n;
      if (p.x[i][0] > tower_centre) ++ball_beyond_centre;
    }
    ball_centre /= ball_n;
    EXPECT_LT(ball_centre, tower_centre) << transfer;
    EXPECT_EQ(ball_beyond_centre, 0) << transfer;
  }
}

// An elastic bar (no plasticity, no hardening, nu = 0 so the axial stress is E times the strain)
// set ringing in its first free-free axial mode, u = A cos(pi x / L) sin(omega t): it vibrates
// at omega = pi c / L with c = sqrt(E / rho), period T = 2 L / c. Its end velocity is the mean
// axial velocity of the bar's right quarter.
template <class T>
struct RingingBar {
  // Its JSON body: centre 0.15, size 0.2.
  static constexpr Real length = 0.2, E = 1e5, rho = 400, amplitude = 0.05, left = 0.15 - 0.1;
  static Real period() { return 2 * length / std::sqrt(E / rho); }

  explicit RingingBar(Real viscosity)
      : scene(sceneWith(viscosity)), solver(scene, particlesOf(scene)) {}

  static Scene sceneWith(Real viscosity) {
    Json j = Json::parse(R"({
      "name": "bar", "dimension": 2, "solver": "mpm", "gravity": [0, 0],
      "grid": {"cells": [60, 12], "cell_size": 0.005},
      "time": {"dt": 0.001, "duration": 0.1, "fps": 10},
      "particles_per_cell": 4,
      "mpm": {"transfer": "apic"},
      "material": {"preset": "paper", "E0": 100000, "nu": 0, "theta_c": 0.9, "theta_s": 0.9, "xi": 0},
      "bodies": [{"shape": "box", "center": [0.15, 0.03], "size": [0.2, 0.02], "density": 400}]
    })");
    j["material"]["viscosity"] = viscosity;
    return parseScene(j, "bar.json");
  }
  static Particles<2> particlesOf(const Scene& scene) {
    Particles<2> particles = sampleBodies<2>(scene);
    for (int i = 0; i < particles.size(); ++i)
      particles.v[i] = Vec<2>(amplitude * std::cos(M_PI * (particles.x[i][0] - left) / length), 0);
    return particles;
  }
  Real endVelocity() const {
    const Particles<2>& p = solver.particles();
    Real v = 0;
    int n = 0;
    for (int i = 0; i < p.size(); ++i)
      if (p.x[i][0] > left + 0.75 * length) v += p.v[i][0], ++n;
    return v / n;
  }

  Scene scene;
  MpmSolver<2, T> solver;
};

// The bar vibrates at its analytic period, measured from the zero crossings of its end velocity.
TYPED_TEST(MpmPhysics, ElasticBarVibratesAtItsAnalyticFrequency) {
  RingingBar<TypeParam> bar(0);
  MpmSolver<2, TypeParam>& solver = bar.solver;
  const Real period = bar.period();
  // The end velocity starts at -amplitude-ish and crosses zero at T/4, 3T/4, 5T/4, ...
  std::vector<Real> crossings;
  Real t = 0, previous = bar.endVelocity();
  while (t < 2.2 * period && crossings.size() < 3) {
    const Real dt = solver.stableTimeStep();
    solver.step(dt);
    t += dt;
    const Real v = bar.endVelocity();
    if ((previous < 0) != (v < 0)) crossings.push_back(t - dt * v / (v - previous));
    previous = v;
  }
  ASSERT_EQ(crossings.size(), 3u);
  const Real measured = crossings[2] - crossings[0];
  // Measured 1.0007. With the paper's grid-density volumes (mpm.initial_volume = grid_density)
  // 0.912: the rasterised density is low near the bar's free surfaces, so V_p^0 and the
  // stiffness come out 23% too large on a bar four cells thick.
  EXPECT_NEAR(measured / period, 1.0, 0.02)
      << "measured period " << measured << " s, analytic " << period << " s";
}

// The same bar with a Kelvin-Voigt damper (material.viscosity): its axial stress gains
// 2 eta dv/dx, so the mode rings down as e^(-alpha t) with alpha = eta k^2 / rho, k = pi / L. The
// end velocity's peaks one period apart shrink by e^(-alpha T); without the damper they keep.
TYPED_TEST(MpmPhysics, DampedBarRingsDownAtTheDampersRate) {
  using Bar = RingingBar<TypeParam>;
  auto peakRatio = [&](Real eta) {
    Bar bar(eta);
    // The largest |v| of each half period between zero crossings.
    std::vector<Real> peaks;
    Real previous = bar.endVelocity(), peak = std::abs(previous);
    while (peaks.size() < 4 && bar.solver.time() < 3 * Bar::period()) {
      bar.solver.step(bar.solver.stableTimeStep());
      const Real v = bar.endVelocity();
      if ((previous < 0) != (v < 0)) peaks.push_back(peak), peak = 0;
      peak = std::max(peak, std::abs(v));
      previous = v;
    }
    return peaks.size() == 4 ? peaks[3] / peaks[1] : 0;  // whole half periods, a period apart
  };
  const Real eta = 32, k = M_PI / Bar::length;
  const Real expected = std::exp(-eta * k * k / Bar::rho * Bar::period());  // 0.607; measured 0.606
  const Real undamped = peakRatio(0), damped = peakRatio(eta);
  EXPECT_GT(undamped, 0.97) << "the bar alone keeps its ringing";
  EXPECT_NEAR(damped / undamped, expected, 0.01 * expected) << "damped " << damped;
  // Where the damper's step term and the wave's are alike, the adaptive step must heed both: with
  // the larger term alone these blew up.
  for (const Real alike : {7.0, 8.0, 9.0}) EXPECT_NO_THROW(peakRatio(alike)) << "eta " << alike;
}
