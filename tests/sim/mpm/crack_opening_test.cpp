// Snow that fails (material.fracture_strain) and cracks that open (mpm.open_cracks,
// sim/mpm/crack_opening.h).
#include "sim/mpm/crack_opening.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "sim/core/errors.h"
#include "sim/mpm/mpm_solver.h"
#include "sim/scene/json_fields.h"
#include "sim/scene/sampling.h"
#include "tests/support/threaded_test.h"

using namespace snowsim;

namespace {

template <class Solver>
void runFor(Solver& s, Real duration) {
  for (Real t = 0; t < duration - 1e-12;) {
    const Real dt = std::min(s.stableTimeStep(), duration - t);
    s.step(dt);
    t += dt;
  }
}

// A bar 0.4 m long and 0.1 m tall whose halves slide past each other at 0.5 m/s each, the upper
// one forwards, without gravity, along a band of failed snow one cell thick at y = 0.1 (J_P = 2,
// past the fracture strain 0.3); with resting_box, a box of snow at rest 0.1 m above it.
struct ShearedBar {
  static constexpr Real middle = 0.1, speed = 0.5;
  Scene scene;
  Particles<2> particles;
  std::vector<Real> y0;  // each particle's height at the start, by id

  explicit ShearedBar(bool open_cracks, bool resting_box = false, bool auto_sleep = false) {
    Json j = Json::parse(R"({
      "name": "bar", "dimension": 2, "solver": "mpm", "gravity": [0, 0],
      "grid": {"cells": [80, 20], "cell_size": 0.01},
      "particles_per_cell": 4,
      "material": {"preset": "paper", "fracture_strain": 0.3},
      "bodies": [{"shape": "box", "center": [0.4, 0.1], "size": [0.4, 0.1]}]
    })");
    j["mpm"] = {{"open_cracks", open_cracks}, {"auto_sleep", {{"enabled", auto_sleep}}}};
    if (resting_box) {
      j["grid"]["cells"] = {80, 40};
      j["bodies"].push_back({{"shape", "box"}, {"center", {0.4, 0.3}}, {"size", {0.4, 0.1}}});
    }
    scene = parseScene(j, "bar.json");
    particles = sampleBodies<2>(scene);
    auto start = std::make_shared<Snapshot>();  // J_P as a points body's file gives it
    for (int p = 0; p < particles.size(); ++p) {
      const Real y = particles.x[p][1];
      y0.push_back(y);
      if (particles.body[p] != 0) continue;
      particles.v[p] = Vec<2>(y < middle ? -speed : speed, 0);
      start->plastic_j.push_back(std::abs(y - middle) < 0.005 ? 2.0f : 1.0f);
    }
    scene.bodies[0].points = start;
  }

  // The mean x velocity of the intact snow below and above the band.
  std::pair<Real, Real> halvesSpeeds(const MpmSolver<2>& s) const {
    const Particles<2>& p = s.particles();
    Real sum[2] = {0, 0};
    int count[2] = {0, 0};
    for (int i = 0; i < p.size(); ++i) {
      const Real y = y0[p.id[i]];
      if (p.body[i] != 0 || std::abs(y - middle) < 0.005) continue;
      const int half = y < middle ? 0 : 1;
      sum[half] += p.v[i][0];
      ++count[half];
    }
    return {sum[0] / count[0], sum[1] / count[1]};
  }
};

}  // namespace

TEST(Fracture, SnowLosesItsStrengthBetweenNoStretchAndTheFractureStrain) {
  SnowMaterial m;
  m.hardening_min = 0.2;
  m.hardening_max = 5;
  const Real bounded = hardeningFactor(m, std::exp(0.15));
  EXPECT_EQ(strengthLeft(m, 2.0), 1) << "no fracture strain: the paper's model";
  m.fracture_strain = 0.3;
  EXPECT_DOUBLE_EQ(hardeningFactor(m, 0.9), std::exp(1.0)) << "compacted snow keeps it";
  EXPECT_EQ(strengthLeft(m, 1.0), 1);
  EXPECT_NEAR(strengthLeft(m, std::exp(0.15)), 0.5, 1e-15);
  EXPECT_NEAR(hardeningFactor(m, std::exp(0.15)), 0.5 * bounded, 1e-15);
  EXPECT_EQ(hardeningFactor(m, std::exp(0.3) * 1.001), 0) << "failed snow has no strength";
  EXPECT_EQ(strengthLeft<float>(m, 10.0f), 0);
}

// With a crack band width (material.fracture_length) the solver's snow fails at the strain that
// takes a band one cell wide the same energy at every cell: fracture_strain l_f / h.
TEST(Fracture, AFractureLengthGivesEachCellTheStrainOfItsBand) {
  Json j = Json::parse(R"({
    "name": "t", "dimension": 2, "solver": "mpm",
    "grid": {"cells": [20, 20], "cell_size": 0.01},
    "material": {"preset": "paper", "fracture_strain": 0.3, "fracture_length": 0.005},
    "bodies": [{"shape": "ball", "center": [0.05, 0.05], "radius": 0.02}]
  })");
  const auto strainAt = [&](Real cell, const Json& material) {
    Json scene = j;
    scene["grid"] = {{"cells", {int(0.1 / cell), int(0.1 / cell)}}, {"cell_size", cell}};
    scene["material"] = material;
    const Scene parsed = parseScene(scene, "t.json");
    return MpmSolver<2>(parsed, sampleBodies<2>(parsed), 1).material().fracture_strain;
  };
  const Json band = j["material"];
  EXPECT_NEAR(strainAt(0.01, band), 0.15, 1e-15);
  EXPECT_EQ(strainAt(0.005, band), 0.3) << "at the band's own cell, the strain given";
  EXPECT_NEAR(strainAt(0.0025, band), 0.6, 1e-15);
  EXPECT_EQ(strainAt(0.01, {{"preset", "paper"}, {"fracture_strain", 0.3}}), 0.3)
      << "no band: every cell alike";
  const Scene parsed = parseScene(j, "t.json");
  EXPECT_EQ(parseScene(sceneToJson(parsed), "again.json").material.fracture_length, 0.005);
  for (const Json& bad : {Json{{"preset", "paper"}, {"fracture_length", 0.005}},
                          Json{{"fracture_strain", 0.3}, {"fracture_length", -1}}}) {
    Json scene = j;
    scene["material"] = bad;
    try {
      parseScene(scene, "t.json");
      ADD_FAILURE() << bad.dump() << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("material.fracture_length"), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find("t.json"), std::string::npos) << e.what();
    }
  }
}

// With one velocity a node the two halves share the nodes along the band and drag each other
// to a stop; with two sides a node they slide past each other as they started.
TEST(CrackOpening, TheHalvesOfAShearedBarSlideAlongAFailedBand) {
  for (const bool open : {false, true}) {
    ShearedBar bar(open);
    MpmSolver<2> s(bar.scene, bar.particles, 1);
    runFor(s, 0.02);
    const auto [below, above] = bar.halvesSpeeds(s);
    if (open) {
      EXPECT_NEAR(below, -ShearedBar::speed, 0.01);
      EXPECT_NEAR(above, ShearedBar::speed, 0.01);
    } else {
      EXPECT_LT(above - below, 1.6 * ShearedBar::speed) << "one velocity a node";
    }
  }
}

// A 2D snapshot's node densities (density cells, the PLY's node element) hold the mass of every
// field: the grid's own holds side 0's only near an open crack.
TEST(CrackOpening, SnapshotNodeMassHoldsEveryField) {
  ShearedBar bar(true);
  MpmSolver<2> s(bar.scene, bar.particles, 1);
  runFor(s, 0.005);
  int failed = 0;  // the band's snow, in the grains' field
  for (const Real J_P : s.plasticJ()) failed += J_P >= std::exp(0.3);
  ASSERT_GT(failed, 0);
  Snapshot snapshot;
  s.describe(snapshot);
  Real mass = 0, node_mass = 0;
  for (const Real m : s.particles().mass) mass += m;
  const Real area = bar.scene.cell_size * bar.scene.cell_size;
  for (const float d : snapshot.grid.node_density) node_mass += d * area;
  EXPECT_NEAR(node_mass, mass, 1e-6 * mass);
}

// Each particle scatters to and gathers from one field of each node, so the particles' momentum
// is the grid's and the grid's the particles': two balls that collide and break keep their total
// momentum to round-off.
TEST(CrackOpening, CollidingBallsThatBreakKeepTheirMomentum) {
  Json j = Json::parse(R"({
    "name": "balls", "dimension": 2, "solver": "mpm", "gravity": [0, 0],
    "grid": {"cells": [60, 30], "cell_size": 0.01},
    "particles_per_cell": 4,
    "material": {"preset": "paper", "fracture_strain": 0.05},
    "mpm": {"open_cracks": true},
    "bodies": [{"shape": "ball", "center": [0.2, 0.15], "radius": 0.06, "velocity": [3, 0.5]},
               {"shape": "ball", "center": [0.4, 0.14], "radius": 0.05, "velocity": [-3, 0]}]
  })");
  const Scene scene = parseScene(j, "balls.json");
  MpmSolver<2> s(scene, sampleBodies<2>(scene), 1);
  const auto momentum = [&] {
    Vec<2> P = Vec<2>::Zero();
    for (int i = 0; i < s.particles().size(); ++i) P += s.particles().mass[i] * s.particles().v[i];
    return P;
  };
  const Vec<2> before = momentum();
  runFor(s, 0.03);
  int failed = 0;
  for (const Real J_P : s.plasticJ()) failed += J_P >= std::exp(0.05);
  EXPECT_GT(failed, 20) << "the balls must break for the crack's fields to take part";
  Real mass = 0;
  for (const Real m : s.particles().mass) mass += m;
  EXPECT_LT((momentum() - before).norm(), 1e-12 * mass * 3) << momentum().transpose();
}

// With auto-sleep, the box at rest falls asleep (within 30 steps) while the bar's halves slide on,
// awake beside their failed band.
TEST(CrackOpening, RestingSnowSleepsWhileTheBrokenBarSlides) {
  ShearedBar asleep_bar(true, true, true), awake_bar(true, true, false);
  MpmSolver<2> asleep(asleep_bar.scene, asleep_bar.particles, 1);
  MpmSolver<2> awake(awake_bar.scene, awake_bar.particles, 1);
  runFor(asleep, 0.02);
  runFor(awake, 0.02);
  int box = 0, box_asleep = 0, bar_asleep = 0;
  for (int i = 0; i < asleep.particles().size(); ++i) {
    const bool b = asleep.particles().body[i] == 1;
    box += b;
    (b ? box_asleep : bar_asleep) += asleep.asleep(i);
  }
  ASSERT_GT(box, 0);
  EXPECT_EQ(box_asleep, box);
  EXPECT_EQ(bar_asleep, 0);
  EXPECT_EQ(asleep.statistics().auto_sleep.asleep_now, box);
  // The bar as without sleep, bit for bit: the box sleeps far from damage, whose field and
  // references its stencils do not reach, so every node's damage, reference and sides are the
  // awake run's.
  EXPECT_TRUE(asleep.particles().positionsById() == awake.particles().positionsById());
  const auto [below, above] = asleep_bar.halvesSpeeds(asleep);
  EXPECT_NEAR(below, -ShearedBar::speed, 0.01);
  EXPECT_NEAR(above, ShearedBar::speed, 0.01);
}

// Two threads decide which snow sleeps, and the sides, as one does.
THREADED_TEST(CrackOpening, WithAutoSleepSameResultsOnOneAndTwoThreads) {
  ShearedBar bar(true, true, true);
  MpmSolver<2> one(bar.scene, bar.particles, 1), two(bar.scene, bar.particles, 2);
  ASSERT_GT(one.particles().size(), 2048);
  runFor(one, 0.02);
  runFor(two, 0.02);
  ASSERT_GT(one.statistics().auto_sleep.asleep_now, 0);
  EXPECT_TRUE(one.particles().positionsById() == two.particles().positionsById());
  EXPECT_EQ(one.statistics().auto_sleep.asleep_steps, two.statistics().auto_sleep.asleep_steps);
}

// Across MPI ranks (OpenCracks::sumShares): each rank's share of a node, the sum over its own
// colours, added on both gives both ranks the same fields, bit for bit, and one process's when the
// second rank's colours come after the first's; the reference is the largest on both.
TEST(CrackOpening, TwoRanksSharesAddUpToOneProcessFields) {
  using Cracks = CrackOpening<2, double>;
  using Rows = TensorStencil<2, QuadraticBSpline, double>;
  const GridGeometry<2> grid(IVec<2>(8, 8), 0.1);
  const int nodes = grid.nodeCount();
  const double inertia_inverse = 4 / (grid.h * grid.h);
  Cracks one(nodes, 9, 3, 1, 0.6), first(nodes, 9, 3, 1, 0.6), second(nodes, 9, 3, 1, 0.6);
  struct Grain {
    Vec<2> x;
    double mass, damage;
    int colour;
    Cracks* rank;
  };
  const Grain grains[] = {{Vec<2>(0.31, 0.33), 1.0, 0.3, 0, &first},
                          {Vec<2>(0.36, 0.29), 1.3, 0.7, 4, &first},
                          {Vec<2>(0.34, 0.41), 0.7, 1.0, 7, &second}};
  const auto withRows = [&](const Grain& g, auto&& f) {
    const Stencil<2, QuadraticBSpline, double> s(g.x, 1 / grid.h);  // the rows refer to it
    f(Rows(grid, s, g.x));
  };
  const auto share = [&](int k) {
    Cracks::NodeShare a, b;
    const bool from_first = first.shareAt(k, a), from_second = second.shareAt(k, b);
    if (from_second) first.addShare(b);
    if (from_first) second.addShare(a);
  };
  const auto same = [&](const char* what) {
    int damaged = 0;
    for (int k = 0; k < nodes; ++k) {
      Cracks::NodeState o, a, b;
      damaged += one.stateAt(k, o);
      first.stateAt(k, a);
      second.stateAt(k, b);
      for (const Cracks::NodeState* s : {&a, &b}) {
        EXPECT_EQ(s->damage, o.damage) << what << " at node " << k;
        EXPECT_EQ(s->grains, o.grains) << what << " at node " << k;
        EXPECT_EQ(s->reference, o.reference) << what << " at node " << k;
      }
    }
    EXPECT_GT(damaged, 9) << what;
  };
  for (const Grain& g : grains)
    for (Cracks* c : {&one, g.rank})
      withRows(g, [&](const Rows& t) { c->primeDamage(t, g.mass, g.damage, g.colour); });
  for (int k = 0; k < nodes; ++k) {
    share(k);
    for (Cracks* c : {&one, &first, &second}) c->sumPrimedDamage(k);
  }
  same("damage field");
  for (const Grain& g : grains)
    for (Cracks* c : {&one, g.rank})
      withRows(g, [&](const Rows& t) { c->primeReference(t, inertia_inverse, g.colour); });
  for (int k = 0; k < nodes; ++k) {
    share(k);
    for (Cracks* c : {&one, &first, &second}) c->sumPrimedReference(k);
  }
  same("references");
}

TEST(CrackOpening, BadSettingsNameTheField) {
  Json j = Json::parse(R"({
    "name": "t", "dimension": 2, "solver": "mpm", "material": {"preset": "paper"},
    "grid": {"cells": [20, 20], "cell_size": 0.01},
    "bodies": [{"shape": "ball", "center": [0.1, 0.1], "radius": 0.03}]
  })");
  const auto problem = [&](const Json& mpm, Real fracture_strain) -> std::string {
    Json scene = j;
    scene["mpm"] = mpm;
    scene["material"] = {{"preset", "paper"}, {"fracture_strain", fracture_strain}};
    try {
      refuseWhatIsNotDistributed(parseScene(scene, "t.json"), 2);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(problem({{"open_cracks", true}}, 0).find("material.fracture_strain > 0"),
            std::string::npos);
  EXPECT_NE(problem({{"open_cracks", true}, {"transfer", "apic"}}, 0.3).find("mpm.open_cracks"),
            std::string::npos);
  EXPECT_EQ(problem({{"open_cracks", true}}, 0.3), "") << "cracks run across MPI ranks too";
  EXPECT_NE(problem(Json::object(), -1).find("material.fracture_strain"), std::string::npos);
  // Auto-sleep runs with open cracks: the scene and the solver take the pair.
  Json both = j;
  both["mpm"] = {{"open_cracks", true}, {"auto_sleep", {{"enabled", true}}}};
  both["material"] = {{"preset", "paper"}, {"fracture_strain", 0.3}};
  const Scene scene = parseScene(both, "t.json");
  EXPECT_TRUE(scene.mpm.open_cracks && scene.mpm.auto_sleep.enabled);
  EXPECT_NO_THROW(MpmSolver<2>(scene, sampleBodies<2>(scene), 1));
}
