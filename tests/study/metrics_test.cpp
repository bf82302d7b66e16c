// The study's metrics on cases with known answers: identical runs, a shifted run, free fall,
// a coarse run against a fine one.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "sim/simulation.h"
#include "study/metrics.h"

namespace snowsim {
namespace {

Snapshot blob(double time, double cx, double cy, int n) {
  Snapshot s;
  s.time = time;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    s.position.push_back({float(cx + 0.01 * std::cos(a)), float(cy + 0.01 * std::sin(a)), 0});
    s.velocity.push_back({0, 0, 0});
  }
  return s;
}

Frames shifted(const Frames& frames, float dx, float dy) {
  Frames out = frames;
  for (Snapshot& s : out)
    for (auto& p : s.position) p[0] += dx, p[1] += dy;
  return out;
}

const FieldGrid kGrid{2, {0.1, 0.12, 0}, 64};

TEST(Metrics, IdenticalRunsHaveZeroError) {
  const Frames a = {blob(0, 0.05, 0.06, 40), blob(0.02, 0.05, 0.05, 40)};
  EXPECT_EQ(densityFieldError(a, a, kGrid), 0);
  EXPECT_EQ(heightProfileError(a, a, kGrid), 0);
  EXPECT_EQ(centreOfMassPathError(a, a), 0);
}

TEST(Metrics, ShiftedRunGivesTheShift) {
  const Frames a = {blob(0, 0.05, 0.06, 40), blob(0.02, 0.05, 0.05, 40)};
  EXPECT_NEAR(centreOfMassPathError(shifted(a, 0.003f, 0.004f), a), 0.005, 1e-6);
  // A vertical shift moves every column's top by the shift.
  EXPECT_NEAR(heightProfileError(shifted(a, 0, 0.004f), a, kGrid), 0.004, 1e-6);
  // Moved by more than the blob's size, the density fields no longer overlap.
  EXPECT_NEAR(densityFieldError(shifted(a, 0.04f, 0), a, kGrid), 1.0, 1e-9);
  EXPECT_GT(densityFieldError(shifted(a, 0.002f, 0), a, kGrid), 0.0);
  EXPECT_LT(densityFieldError(shifted(a, 0.002f, 0), a, kGrid),
            densityFieldError(shifted(a, 0.006f, 0), a, kGrid));
}

TEST(Metrics, DensityFieldDoesNotDependOnParticleCount) {
  const Frames few = {blob(0, 0.05, 0.06, 400)};
  const Frames many = {blob(0, 0.05, 0.06, 1600)};
  EXPECT_LT(densityFieldError(few, many, kGrid), 0.01);
}

TEST(Metrics, FreeFallOfABallisticPathIsExact) {
  Frames frames;
  const double g = -9.81, vx = 0.5;
  for (int f = 0; f <= 5; ++f) {
    const double t = 0.02 * f;
    Snapshot s = blob(t, 0.02 + vx * t, 0.08 + 0.5 * g * t * t, 20);
    for (auto& v : s.velocity) v = {float(vx), float(g * t), 0};
    frames.push_back(s);
  }
  EXPECT_LT(freeFallError(frames, {0, g, 0}, 1.0), 1e-6);
  EXPECT_LT(momentumDrift(frames, {0, g, 0}, 1.0), 1e-5);
  EXPECT_NEAR(freeFallError(frames, {0, 0, 0}, 1.0), 0.5 * 9.81 * 0.1 * 0.1, 1e-6);
}

TEST(Metrics, LandingTimeAndFrequency) {
  Frames frames;
  for (int f = 0; f <= 10; ++f) frames.push_back(blob(0.01 * f, 0.05, 0.06 - 0.005 * f, 8));
  // The blob's lowest point (centre - 0.01) reaches 0.0 + margin 0.001 at centre 0.011: f = 10.
  EXPECT_DOUBLE_EQ(landingTime(frames, membersLeftOf(frames[0], 1.0), 0.0, 0.0011), 0.1);
  EXPECT_EQ(landingTime(frames, membersLeftOf(frames[0], 1.0), -1.0, 0.0), -1);
  std::vector<double> t, y;
  for (int i = 0; i < 1000; ++i)
    t.push_back(i * 0.001), y.push_back(std::sin(2 * M_PI * 3 * t.back() + 0.3));
  EXPECT_NEAR(oscillationFrequency(t, y), 3.0, 0.01);
}

TEST(Metrics, ThrownBallClaim) {
  Snapshot start = blob(0, 0.02, 0.03, 20);
  Snapshot tower = blob(0, 0.07, 0.02, 20);
  start.position.insert(start.position.end(), tower.position.begin(), tower.position.end());
  Snapshot stopped = start, through = start;
  for (int i = 0; i < 20; ++i) stopped.position[i][0] += 0.03f, through.position[i][0] += 0.07f;
  EXPECT_TRUE(thrownBallStaysOutside({start, stopped}, 0.055));
  EXPECT_FALSE(thrownBallStaysOutside({start, through}, 0.055));
  // The ball's centre moves from x = 0.02 to 0.09; the tower (not moved) has its far face at its
  // largest x.
  double far_face = 0;
  for (int i = 20; i < 40; ++i) far_face = std::max(far_face, double(start.position[i][0]));
  EXPECT_NEAR(ballPastTower({start, through}, 0.055), 0.09 - far_face, 1e-6);
}

TEST(Metrics, PileHeightOrdering) {
  const Snapshot tall = blob(0, 0.05, 0.04, 50), mid = blob(0, 0.05, 0.03, 50),
                 low = blob(0, 0.05, 0.02, 50);
  EXPECT_TRUE(pileHeightsOrdered(tall, mid, low));
  EXPECT_FALSE(pileHeightsOrdered(low, mid, tall));
}

// With a real solver: a coarser time step lands farther from the reference than a finer one.
Frames runDrop(double dt) {
  const Scene scene = loadScene(std::string(SNOWSIM_SOURCE_DIR) + "/scenes/snowball_drop.json",
                                {"time.dt=" + std::to_string(dt), "time.duration=0.2"});
  auto sim = makeSimulation(scene);
  Frames frames;
  for (int f = 0; f <= scene.frameCount(); ++f) {
    sim->advanceTo(f / scene.fps);
    frames.push_back(sim->snapshot(f));
  }
  return frames;
}

TEST(Metrics, CoarserRunHasLargerError) {
  const Frames reference = runDrop(0.00025), fine = runDrop(0.001), coarse = runDrop(0.008);
  EXPECT_EQ(centreOfMassPathError(reference, reference), 0);
  EXPECT_LT(centreOfMassPathError(fine, reference), centreOfMassPathError(coarse, reference));
  EXPECT_LT(densityFieldError(fine, reference, kGrid), densityFieldError(coarse, reference, kGrid));
  // Before it lands the ball falls freely, within a fraction of a cell.
  EXPECT_LT(freeFallError(fine, {0, -9.81, 0}, 0.08), 0.002);
}

// --- clumps -------------------------------------------------------------------------------------

Snapshot lattice(int nx, int ny, int nz, double spacing, std::array<double, 3> origin) {
  Snapshot s;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k)
        s.position.push_back({float(origin[0] + i * spacing), float(origin[1] + j * spacing),
                              float(origin[2] + k * spacing)});
  return s;
}

void append(Snapshot& to, const Snapshot& from) {
  to.position.insert(to.position.end(), from.position.begin(), from.position.end());
}

TEST(Clumps, TwoBlocksAndScatteredParticles) {
  const double spacing = 0.005;
  Snapshot s = lattice(4, 4, 4, spacing, {0, 0, 0});        // 64 particles
  append(s, lattice(3, 3, 3, spacing, {0.1, 0, 0}));        // 27, far from the first block
  append(s, lattice(1, 1, 1, spacing, {0.05, 0.05, 0}));    // a single particle
  append(s, lattice(2, 1, 1, spacing, {0.05, 0.0, 0.05}));  // a pair
  const ClumpStats c = findClumps(s, 1.5 * spacing, 10);
  EXPECT_EQ(c.particles, 94);
  EXPECT_EQ(c.clumps, 4);
  EXPECT_EQ(c.largest, 64);
  EXPECT_EQ(c.chunks, 2);
  EXPECT_DOUBLE_EQ(c.clumped_share, 91.0 / 94);
  EXPECT_DOUBLE_EQ(c.single_share, 1.0 / 94);
  EXPECT_EQ(c.clump_of[0], 0);
  EXPECT_EQ(c.clump_of[64], 1);
  EXPECT_EQ(c.clump_of[91], 2);
  EXPECT_EQ(c.clump_of[92], c.clump_of[93]);
}

TEST(Clumps, LinkDistanceDecidesWhatIsConnected) {
  const double spacing = 0.01;
  const Snapshot s = lattice(5, 1, 1, spacing, {0.2, 0.3, 0.4});  // a row
  EXPECT_EQ(findClumps(s, 1.01 * spacing, 1).clumps, 1);
  EXPECT_EQ(findClumps(s, 0.99 * spacing, 1).clumps, 5);
  EXPECT_DOUBLE_EQ(findClumps(s, 0.99 * spacing, 2).clumped_share, 0);
  EXPECT_DOUBLE_EQ(findClumps(s, 0.99 * spacing, 2).single_share, 1);
  // A chain links end to end across many cells of the hash.
  EXPECT_EQ(findClumps(lattice(200, 1, 1, spacing, {0, 0, 0}), 1.5 * spacing, 1).largest, 200);
}

// The cell hash finds every pair within the link: the same clumps as comparing all pairs.
TEST(Clumps, MatchesAllPairsOnRandomPoints) {
  std::mt19937 random(7);
  std::uniform_real_distribution<float> coordinate(0, 0.1f);
  Snapshot s;
  for (int i = 0; i < 600; ++i)
    s.position.push_back({coordinate(random), coordinate(random), coordinate(random)});
  const double link = 0.008;
  const ClumpStats c = findClumps(s, link, 3);
  // Flood fill over all pairs.
  std::vector<int> label(s.size(), -1);
  int clumps = 0;
  for (int seed = 0; seed < s.size(); ++seed) {
    if (label[seed] >= 0) continue;
    std::vector<int> stack{seed};
    label[seed] = clumps;
    while (!stack.empty()) {
      const int p = stack.back();
      stack.pop_back();
      for (int q = 0; q < s.size(); ++q) {
        double d2 = 0;
        for (int k = 0; k < 3; ++k)
          d2 += double(s.position[p][k] - s.position[q][k]) *
                double(s.position[p][k] - s.position[q][k]);
        if (label[q] < 0 && d2 <= link * link) label[q] = clumps, stack.push_back(q);
      }
    }
    ++clumps;
  }
  EXPECT_EQ(c.clumps, clumps);
  EXPECT_GT(clumps, 10);  // the density is chosen so that there are many clumps and singles
  EXPECT_LT(clumps, 500);
  for (int p = 0; p < s.size(); ++p) EXPECT_EQ(c.clump_of[p], label[p]) << p;
}

TEST(Clumps, RejectsBadArguments) {
  const Snapshot s = lattice(2, 2, 2, 0.01, {0, 0, 0});
  EXPECT_THROW(findClumps(s, 0, 1), std::invalid_argument);
  EXPECT_THROW(findClumps(s, 0.01, 0), std::invalid_argument);
  Snapshot bad = s;
  bad.position[3][1] = std::nanf("");
  EXPECT_THROW(findClumps(bad, 0.015, 1), std::invalid_argument);
  EXPECT_EQ(findClumps(Snapshot{}, 0.01, 1).clumps, 0);
}

}  // namespace
}  // namespace snowsim
