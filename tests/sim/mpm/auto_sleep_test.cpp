// Auto-sleep (mpm.auto_sleep): snow at rest stops gathering, deforming and moving, still holds up
// what lies on it, wakes where it is hit, survives a checkpoint and gives the same results on any
// thread count.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "sim/core/errors.h"
#include "sim/mpm/mpm_solver.h"
#include "sim/scene/json_fields.h"
#include "sim/scene/sampling.h"
#include "tests/support/threaded_test.h"

using namespace snowsim;

namespace {

// A slab of snow 8 cm deep across a 60 x 40 cell box (cell 1 cm), and a ball of radius 3 cm
// dropped onto its middle from 25 cm above it, landing at about t = 0.22 s. The floor's nodes
// stop the slab where it was sampled (mpm.collider_inset 0), so that it rests from the start.
Json pileAndBall(int particles_per_cell = 4) {
  Json j = Json::parse(R"({
    "name": "t", "dimension": 2, "solver": "mpm", "material": {"preset": "paper"},
    "grid": {"cells": [60, 40], "cell_size": 0.01},
    "time": {"dt": 0.001, "duration": 0.5, "fps": 10},
    "bodies": [{"shape": "box", "center": [0.3, 0.04], "size": [0.56, 0.08]},
               {"shape": "ball", "center": [0.3, 0.36], "radius": 0.03}],
    "mpm": {"auto_sleep": {"enabled": true}, "collider_inset": 0}
  })");
  j["particles_per_cell"] = particles_per_cell;
  return j;
}

template <int D = 2, class T = Real>
MpmSolver<D, T> makeSolver(const Json& j, int threads = 0) {
  const Scene scene = parseScene(j, "test.json");
  return MpmSolver<D, T>(scene, sampleBodies<D>(scene), threads);
}

// 3D, in float (the 3D default): a slab 4 cm deep across a 16 x 16 cell floor (cell 1 cm), and a
// ball of radius 2.5 cm dropped onto its middle from 23.5 cm above it, landing at about 0.22 s;
// the slab rests from the start, as pileAndBall's.
Json pileAndBall3d() {
  return Json::parse(R"({
    "name": "t", "dimension": 3, "solver": "mpm", "material": {"preset": "paper"},
    "grid": {"cells": [16, 36, 16], "cell_size": 0.01},
    "time": {"dt": 0.001, "duration": 0.5, "fps": 10},
    "particles_per_cell": 8,
    "bodies": [{"shape": "box", "center": [0.08, 0.02, 0.08], "size": [0.16, 0.04, 0.16]},
               {"shape": "ball", "center": [0.08, 0.3, 0.08], "radius": 0.025}],
    "mpm": {"auto_sleep": {"enabled": true}, "collider_inset": 0}
  })");
}
using Solver3d = MpmSolver<3, float>;

// A solver of scene j resumed from a checkpoint of s, as `snowsim resume` does.
Solver3d resumedFrom(const Solver3d& s, const Json& j, int threads) {
  StateWriter saved;
  s.saveState(saved);
  Solver3d resumed = makeSolver<3, float>(j, threads);
  StateReader reader(saved.bytes(), "test checkpoint");
  resumed.loadState(reader);
  reader.finish();
  return resumed;
}

// Steps at the stable step until the solver's clock reaches `until`.
template <class Solver>
void runUntil(Solver& s, Real until) {
  while (s.time() < until - 1e-12) s.step(std::min(s.stableTimeStep(), until - s.time()));
}

// The share of body's particles asleep among those `where` picks.
template <int D, class T, class Where>
double asleepShare(const MpmSolver<D, T>& s, int body, Where&& where) {
  const Particles<D>& p = s.particles();
  int asleep = 0, picked = 0;
  for (int i = 0; i < p.size(); ++i)
    if (p.body[i] == body && where(p.x[i])) ++picked, asleep += s.asleep(i);
  return picked > 0 ? double(asleep) / picked : 0;
}

template <int D>
Vec<D> centre(const Particles<D>& p, int body) {
  Vec<D> c = Vec<D>::Zero();
  int n = 0;
  for (int i = 0; i < p.size(); ++i)
    if (p.body[i] == body) c += p.x[i], ++n;
  return c / n;
}

// With the scene's default inset the floor's nodes are free: the slab first settles by about a
// millimetre onto the floor, then sleeps.
TEST(AutoSleep, BlockAtRestFallsAsleepAndStaysPut) {
  Json j = pileAndBall();
  j["bodies"].erase(1);
  j["mpm"].erase("collider_inset");
  auto asleep = makeSolver(j);
  j["mpm"]["auto_sleep"]["enabled"] = false;
  auto awake = makeSolver(j);
  runUntil(asleep, 0.5);
  runUntil(awake, 0.5);
  EXPECT_EQ(asleepShare(asleep, 0, [](const Vec<2>&) { return true; }), 1);
  EXPECT_EQ(asleep.statistics().auto_sleep.particles, asleep.particles().size());
  EXPECT_EQ(asleep.statistics().auto_sleep.asleep_now, asleep.particles().size());
  // Where the awake block is, within half a millimetre: the awake block rings elastically under
  // gravity at up to 2 cm/s, about 0.3 mm apart from the sleeping one.
  const Particles<2>&a = asleep.particles(), &b = awake.particles();
  Real moved_apart = 0;
  for (int i = 0; i < a.size(); ++i) moved_apart = std::max(moved_apart, (a.x[i] - b.x[i]).norm());
  EXPECT_LT(moved_apart, 5e-4);
  EXPECT_NEAR(centre(a, 0)[1], 0.039, 5e-4);
  Real fastest = 0;
  for (const Vec<2>& v : a.v) fastest = std::max(fastest, v.norm());
  EXPECT_EQ(fastest, 0);  // asleep, it keeps no drift
}

// With a damper (material.viscosity) a particle falls asleep ringing a little: it takes the
// damper's stress of that last velocity gradient out with it, and keeps scattering its elastic
// stress alone.
TEST(AutoSleep, ASleepingDampedBlockKeepsOnlyItsElasticStress) {
  Json j = pileAndBall();
  j["bodies"].erase(1);
  j["material"] = {{"preset", "paper"}, {"viscosity", 16}};
  auto solver = makeSolver(j);
  runUntil(solver, 0.3);
  ASSERT_EQ(solver.statistics().auto_sleep.asleep_now, solver.particles().size());
  Real largest = 0, furthest = 0;
  for (size_t p = 0; p < solver.stress().size(); ++p) {
    const Mat<2>& F = solver.elasticGradient()[p];
    const Mat<2> elastic =
        fixedCorotatedKirchhoffUpper<2, Real>(F, polarRotation<2>(F), solver.lame(int(p))).matrix();
    largest = std::max(largest, elastic.norm());
    furthest = std::max(furthest, (solver.stress()[p].matrix() - elastic).norm());
  }
  EXPECT_GT(largest, 100) << "the block's weight stresses it (Pa)";
  EXPECT_LT(furthest, 1e-9 * largest);
}

TEST(AutoSleep, SleepingPileHitByABallWakesWhereHitAndStopsTheBall) {
  Json j = pileAndBall();
  auto asleep = makeSolver(j);
  j["mpm"]["auto_sleep"]["enabled"] = false;
  auto awake = makeSolver(j);
  const auto all = [](const Vec<2>&) { return true; };
  // Before the ball lands the pile sleeps.
  runUntil(asleep, 0.15);
  EXPECT_EQ(asleepShare(asleep, 0, all), 1);
  // The first step that wakes any of the pile wakes it under the ball only, within 6 cm of the
  // ball's axis (the impact's elastic wave then crosses the pile and wakes what it shakes).
  while (asleepShare(asleep, 0, all) == 1 && asleep.time() < 0.3)
    asleep.step(asleep.stableTimeStep());
  ASSERT_LT(asleepShare(asleep, 0, all), 1) << "the ball never woke the pile";
  EXPECT_EQ(asleepShare(asleep, 0, [](const Vec<2>& x) { return std::abs(x[0] - 0.3) > 0.06; }), 1);
  // The sleeping pile stops the ball where the awake one does: the ball's centre within half a
  // millimetre (measured: 0.2 mm lower), resting on the pile; and the pile asleep again.
  runUntil(asleep, 0.5);
  runUntil(awake, 0.5);
  const Vec<2> on_sleeping = centre(asleep.particles(), 1), on_awake = centre(awake.particles(), 1);
  EXPECT_NEAR(on_sleeping[1], on_awake[1], 5e-4);
  EXPECT_NEAR(on_sleeping[0], on_awake[0], 5e-4);
  EXPECT_GT(on_sleeping[1], 0.08 + 0.02);
  EXPECT_GT(asleepShare(asleep, 0, all), 0.95);
}

// At the default inset the pile first settles onto the floor; a ball thrown up from high above
// lands on it after it sleeps (about 0.49 s) and is stopped where the awake pile stops it.
TEST(AutoSleep, AtTheDefaultInsetTheSettledPileSleepsAndStopsTheBall) {
  Json j = pileAndBall();
  j["mpm"].erase("collider_inset");
  j["grid"]["cells"] = {60, 90};
  j["bodies"][1]["center"] = {0.3, 0.8};
  j["bodies"][1]["velocity"] = {0, 1};
  auto asleep = makeSolver(j);
  j["mpm"]["auto_sleep"]["enabled"] = false;
  auto awake = makeSolver(j);
  const auto all = [](const Vec<2>&) { return true; };
  runUntil(asleep, 0.45);
  EXPECT_EQ(asleepShare(asleep, 0, all), 1);
  runUntil(asleep, 0.8);
  runUntil(awake, 0.8);
  const Vec<2> on_sleeping = centre(asleep.particles(), 1), on_awake = centre(awake.particles(), 1);
  EXPECT_LT((on_sleeping - on_awake).norm(), 1e-3);
  EXPECT_GT(on_sleeping[1], 0.08 + 0.02) << "on the pile, not sunk into it";
  EXPECT_LT(on_sleeping[1], 0.08 + 0.04) << "landed";
}

// The solvers' own checkpoint state, written and read back as `snowsim resume` does.
TEST(AutoSleep, ResumedFromACheckpointTheSleepStateTakesTheSameSteps) {
  const Json j = pileAndBall();
  auto through = makeSolver(j);
  runUntil(through, 0.2);  // the pile asleep, the ball about to land
  ASSERT_GT(through.statistics().auto_sleep.asleep_now, 0);
  StateWriter saved;
  through.saveState(saved);
  auto resumed = makeSolver(j);
  StateReader reader(saved.bytes(), "test checkpoint");
  resumed.loadState(reader);
  reader.finish();
  runUntil(through, 0.3);  // through the impact: the pile wakes and sleeps again
  runUntil(resumed, 0.3);
  ASSERT_EQ(resumed.steps(), through.steps());
  const Particles<2>&a = through.particles(), &b = resumed.particles();
  EXPECT_TRUE(a.x == b.x && a.v == b.v && a.id == b.id);
  EXPECT_TRUE(through.elasticGradient() == resumed.elasticGradient());
  EXPECT_TRUE(through.plasticJ() == resumed.plasticJ());
  int same_sleep = 0;
  for (int i = 0; i < a.size(); ++i) same_sleep += through.asleep(i) == resumed.asleep(i);
  EXPECT_EQ(same_sleep, a.size());
  EXPECT_EQ(through.statistics().auto_sleep.asleep_steps,
            resumed.statistics().auto_sleep.asleep_steps);
  EXPECT_EQ(through.statistics().auto_sleep.particle_steps,
            resumed.statistics().auto_sleep.particle_steps);
}

// 16 particles per cell: over the 2048 that take the threaded path.
THREADED_TEST(AutoSleep, SameResultsOnOneAndTwoThreads) {
  const Json j = pileAndBall(16);
  auto one = makeSolver(j, 1), two = makeSolver(j, 2);
  ASSERT_GT(one.particles().size(), 2048);
  runUntil(one, 0.23);
  runUntil(two, 0.23);
  ASSERT_GT(one.statistics().auto_sleep.asleep_now, 0);
  ASSERT_LT(one.statistics().auto_sleep.asleep_now,
            one.particles().size());  // the ball has woken some
  EXPECT_TRUE(one.particles().positionsById() == two.particles().positionsById());
  EXPECT_EQ(one.statistics().auto_sleep.asleep_steps, two.statistics().auto_sleep.asleep_steps);
}

// In 3D, a block of particles that all slept through the last step adds the scatter it kept
// (sim/parallel/still_blocks.h). The pile's kept scatters hold the ball up where the awake pile
// does, and the ball, landing, wakes the blocks under it, which scatter afresh.
TEST(AutoSleep, StillBlocksHoldTheBallWhereTheAwakePileDoes) {
  Json j = pileAndBall3d();
  auto asleep = makeSolver<3, float>(j);
  j["mpm"]["auto_sleep"]["enabled"] = false;
  auto awake = makeSolver<3, float>(j);
  const auto all = [](const Vec<3>&) { return true; };
  runUntil(asleep, 0.2);
  EXPECT_EQ(asleepShare(asleep, 0, all), 1);
  const long kept_before_landing = asleep.keptScatters();
  const long asleep_before_landing = asleep.statistics().auto_sleep.asleep_steps;
  EXPECT_GT(kept_before_landing, 0);
  runUntil(asleep, 0.45);
  runUntil(awake, 0.45);
  EXPECT_EQ(awake.keptScatters(), 0);
  // Kept on after the landing too, but for the blocks the landing woke and those on the far
  // walls (x and z cells 12-15), which never keep theirs: measured 38% of the sleeping
  // particles' scatters.
  EXPECT_GT(asleep.keptScatters() - kept_before_landing,
            0.3 * (asleep.statistics().auto_sleep.asleep_steps - asleep_before_landing));
  const Vec<3> on_sleeping = centre(asleep.particles(), 1), on_awake = centre(awake.particles(), 1);
  EXPECT_LT((on_sleeping - on_awake).norm(), 1e-3);
  EXPECT_GT(on_sleeping[1], 0.04 + 0.015);  // on the pile, not sunk into it
  // The grid holds every particle's mass, the kept blocks' included (to float round-off).
  double particle_mass = 0, grid_mass = 0;
  for (const Real m : asleep.particles().mass) particle_mass += m;
  for (const float m : asleep.fields().mass) grid_mass += m;
  EXPECT_NEAR(grid_mass, particle_mass, 1e-5 * particle_mass);
}

// A kept scatter is the scatter made afresh, to round-off: the grid after a step in which the
// pile adds what its blocks kept, against the grid the same state gives scattered particle by
// particle (inside the walls, which the step's grid stage alone applies). MLS keeps the stress's
// share of the momentum, APIC its force.
class StillBlocksTransfer : public testing::TestWithParam<const char*> {};

TEST_P(StillBlocksTransfer, GiveTheGridAFreshScatterGives) {
  Json j = pileAndBall3d();
  j["mpm"]["transfer"] = GetParam();
  auto kept = makeSolver<3, float>(j, 1);
  runUntil(kept, 0.2);  // the pile asleep, the ball falling
  auto fresh = resumedFrom(kept, j, 1);
  const long kept_before = kept.keptScatters();
  const Real dt = kept.stableTimeStep();
  kept.step(dt);
  ASSERT_GT(kept.keptScatters() - kept_before, kept.particles().size() / 2);
  fresh.scatter(dt);
  fresh.updateGridVelocities(dt);
  const GridGeometry<3>& grid = kept.grid();
  int compared = 0;
  for (int k = 0; k < grid.nodeCount(); ++k) {
    const IVec<3> node = grid.coords(k);
    if ((node.array() < 3).any() || (node.array() > grid.cells.array() - 3).any()) continue;
    const float m = fresh.fields().mass[k];
    if (m == 0) continue;
    ++compared;
    ASSERT_NEAR(kept.fields().mass[k], m, 1e-5 * m) << node.transpose();
    ASSERT_LT((kept.fields().velocity[k] - fresh.fields().velocity[k]).norm(), 1e-6)
        << node.transpose();
  }
  EXPECT_GT(compared, 500);
}

INSTANTIATE_TEST_SUITE_P(AutoSleep, StillBlocksTransfer, testing::Values("mls", "apic"));

// The pile on a floor 18 cells wide, whose last blocks (cells 16-17) keep their scatter too.
Json widePileAndBall3d() {
  Json j = pileAndBall3d();
  j["grid"]["cells"] = {18, 36, 18};
  return j;
}

// A block whose still particles share it with moving ones adds what the still ones kept and
// scatters the moving ones afresh: while the pile the ball woke falls asleep again, most of the
// sleeping particles' scatters are kept (measured 0.98 of them; those of blocks where one fell
// asleep that step are made anew), and a resumed run, whose blocks keep theirs anew, agrees.
TEST(AutoSleep, ABlockKeepsItsStillParticlesScatterBesideItsMovingOnes) {
  const Json j = widePileAndBall3d();
  auto kept = makeSolver<3, float>(j, 1);
  runUntil(kept, 0.24);  // the ball landed at about 0.22 s and woke the pile
  ASSERT_LT(kept.statistics().auto_sleep.asleep_now, kept.particles().size() / 10);
  const long kept_before = kept.keptScatters();
  const long asleep_before = kept.statistics().auto_sleep.asleep_steps;
  runUntil(kept, 0.3);
  auto resumed = resumedFrom(kept, j, 1);
  runUntil(kept, 0.4);
  const double kept_share = double(kept.keptScatters() - kept_before) /
                            (kept.statistics().auto_sleep.asleep_steps - asleep_before);
  EXPECT_GT(kept_share, 0.9);
  runUntil(resumed, 0.4);
  EXPECT_TRUE(kept.particles().positionsById() == resumed.particles().positionsById());
}

// Kept scatters depend on the steps alone: the same on one and two threads, and the same after a
// checkpoint, where the blocks keep their scatters anew.
TEST(AutoSleep, StillBlocksGiveTheSameResultsOnOneAndTwoThreadsAndAfterAResume) {
  const Json j = pileAndBall3d();
  auto one = makeSolver<3, float>(j, 1), two = makeSolver<3, float>(j, 2);
  ASSERT_GT(one.particles().size(), 2048);
  runUntil(one, 0.2);
  runUntil(two, 0.2);
  auto resumed = resumedFrom(one, j, 2);
  for (Solver3d* s : {&one, &two, &resumed}) runUntil(*s, 0.3);  // the ball lands
  ASSERT_GT(one.keptScatters(), 0);
  EXPECT_EQ(one.keptScatters(), two.keptScatters());
  const std::vector<Vec<3>> x = one.particles().positionsById();
  EXPECT_TRUE(x == two.particles().positionsById());
  EXPECT_TRUE(x == resumed.particles().positionsById());
  EXPECT_EQ(one.statistics().auto_sleep.asleep_steps, two.statistics().auto_sleep.asleep_steps);
  EXPECT_EQ(one.statistics().auto_sleep.asleep_steps, resumed.statistics().auto_sleep.asleep_steps);
}

// With open cracks (mpm.open_cracks): the 3D pile, and a ball thrown down onto it that its
// landing stretches past J_P = 1 (fracture strain 0.05).
Json crackedPileAndBall3d() {
  Json j = pileAndBall3d();
  j["material"] = {{"preset", "paper"}, {"fracture_strain", 0.05}};
  j["mpm"]["open_cracks"] = true;
  j["bodies"][1]["velocity"] = {0, -3, 0};
  return j;
}

// The shares of the damaged snow (J_P > 1) asleep, and of all the snow.
template <class Solver>
std::pair<double, double> damagedAndAllAsleep(const Solver& s) {
  int damaged = 0, damaged_asleep = 0, asleep = 0;
  for (int i = 0; i < s.particles().size(); ++i) {
    damaged += s.plasticJ()[i] > 1;
    damaged_asleep += s.asleep(i) && s.plasticJ()[i] > 1;
    asleep += s.asleep(i);
  }
  return {damaged > 0 ? double(damaged_asleep) / damaged : 0,
          double(asleep) / s.particles().size()};
}

// In 3D with open cracks, the damaged ball falls asleep on the pile too, its nodes' velocities
// those of its own fields, and still blocks keep their scatter, damaged or not. One and two
// threads and a resume agree bit for bit, and the sleeping ball rests where the awake one does.
THREADED_TEST(AutoSleep, WithOpenCracksDamagedSnowSleepsOnAnyThreadCountAndAfterAResume) {
  Json j = crackedPileAndBall3d();
  auto one = makeSolver<3, float>(j, 1), two = makeSolver<3, float>(j, 2);
  ASSERT_GT(one.particles().size(), 2048);
  runUntil(one, 0.15);
  runUntil(two, 0.15);
  auto resumed = resumedFrom(one, j, 2);
  for (Solver3d* s : {&one, &two, &resumed}) runUntil(*s, 0.25);
  j["mpm"]["auto_sleep"]["enabled"] = false;
  auto awake = makeSolver<3, float>(j, 2);
  runUntil(awake, 0.25);
  const auto [damaged_asleep, asleep] = damagedAndAllAsleep(one);
  EXPECT_GT(damaged_asleep, 0.9);
  EXPECT_GT(asleep, 0.9);
  // The awake ball keeps ringing: the sleeping one stops within half a millimetre of it.
  EXPECT_LT((centre(one.particles(), 1) - centre(awake.particles(), 1)).norm(), 5e-4);
  EXPECT_TRUE(one.particles().positionsById() == two.particles().positionsById());
  EXPECT_TRUE(one.particles().positionsById() == resumed.particles().positionsById());
  EXPECT_EQ(one.keptScatters(), two.keptScatters());
  EXPECT_EQ(one.statistics().auto_sleep.asleep_steps, two.statistics().auto_sleep.asleep_steps);
  EXPECT_EQ(one.statistics().auto_sleep.asleep_steps, resumed.statistics().auto_sleep.asleep_steps);
}

// With open cracks, the damaged ball asleep on the pile wakes where a second ball lands on it,
// and holds that ball up as the awake one does.
TEST(AutoSleep, WithOpenCracksSleepingDamagedSnowWakesWhereHit) {
  Json j = crackedPileAndBall3d();
  j["grid"]["cells"] = {16, 56, 16};
  j["bodies"].push_back({{"shape", "ball"}, {"center", {0.08, 0.54, 0.08}}, {"radius", 0.012}});
  auto asleep = makeSolver<3, float>(j, 2);
  j["mpm"]["auto_sleep"]["enabled"] = false;
  auto awake = makeSolver<3, float>(j, 2);
  const auto above_pile = [](const Vec<3>& x) { return x[1] > 0.06; };
  runUntil(asleep, 0.28);  // the second ball lands at about 0.29 s
  EXPECT_GT(asleepShare(asleep, 1, above_pile), 0.9);
  runUntil(asleep, 0.3);
  EXPECT_LT(asleepShare(asleep, 1, above_pile), 0.5);
  runUntil(asleep, 0.4);
  runUntil(awake, 0.4);
  EXPECT_GT(asleepShare(asleep, 1, above_pile), 0.9);
  // It rests at the awake heap's height (measured 1.5 mm higher: the awake heap keeps creeping);
  // on the awake heap it also slides 4 mm off the axis it fell along, the sleeping heap keeps it
  // on.
  const Vec<3> on_sleeping = centre(asleep.particles(), 2), on_awake = centre(awake.particles(), 2);
  EXPECT_NEAR(on_sleeping[1], on_awake[1], 2e-3);
  EXPECT_LT((on_sleeping - on_awake).norm(), 5e-3);
}

// With open cracks, the blocks of the damaged ball asleep on the pile keep their scatter, the
// crack's fields with it, as the blocks without damage do: a fifth of the snow is damaged, and
// nearly every sleeping particle's scatter is kept.
TEST(AutoSleep, WithOpenCracksSleepingDamagedSnowKeepsItsScatter) {
  Json j = widePileAndBall3d();
  j["material"] = {{"preset", "paper"}, {"fracture_strain", 0.05}};
  j["mpm"]["open_cracks"] = true;
  j["bodies"][1]["velocity"] = {0, -3, 0};
  j["bodies"][1]["radius"] = 0.035;
  auto s = makeSolver<3, float>(j, 1);
  runUntil(s, 0.25);
  const auto [damaged_asleep, asleep] = damagedAndAllAsleep(s);
  ASSERT_GT(damaged_asleep, 0.9);
  int damaged = 0;
  for (const float J_P : s.plasticJ()) damaged += J_P > 1;
  ASSERT_GT(damaged, s.particles().size() / 10);
  const long kept_before = s.keptScatters();
  s.step(s.stableTimeStep());
  const long asleep_now = s.statistics().auto_sleep.asleep_now;
  EXPECT_GT(s.keptScatters() - kept_before, asleep_now * 9 / 10);  // measured 0.97
}

TEST(AutoSleep, SceneFieldsAreCheckedAndWrittenBack) {
  const std::string scene = SNOWSIM_SOURCE_DIR "/scenes/snowball_drop.json";
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"mpm.auto_sleep.speed=0", "mpm.auto_sleep.speed"},
      {"mpm.auto_sleep.speed=-1", "mpm.auto_sleep.speed"},
      {"mpm.auto_sleep.steps=0", "mpm.auto_sleep.steps"},
      {"mpm.auto_sleep.enabled=\"yes\"", "mpm.auto_sleep.enabled"},
      {"mpm.auto_sleep.delay=3", "mpm.auto_sleep.delay"}};
  for (const auto& [assignment, field] : bad) {
    try {
      loadScene(scene, {assignment});
      ADD_FAILURE() << assignment << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("snowball_drop.json"), std::string::npos) << e.what();
    }
  }
  EXPECT_FALSE(loadScene(scene).mpm.auto_sleep.enabled);  // off unless asked for
  const Scene on = loadScene(scene, {"mpm.auto_sleep.speed=0.02", "mpm.auto_sleep.steps=7"});
  EXPECT_TRUE(on.mpm.auto_sleep.enabled);  // the object given turns it on
  const Scene again = parseScene(sceneToJson(on), "again.json");
  EXPECT_TRUE(again.mpm.auto_sleep.enabled);
  EXPECT_EQ(again.mpm.auto_sleep.speed, 0.02);
  EXPECT_EQ(again.mpm.auto_sleep.steps, 7);
}

}  // namespace
