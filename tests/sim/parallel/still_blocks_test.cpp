// What still blocks keep of a scatter and add back (sim/parallel/still_blocks.h).
#include "sim/parallel/still_blocks.h"

#include <gtest/gtest.h>

#include <vector>

using namespace snowsim;

namespace {

using V = Vec<2>;

// A partial grid as the schedule's: mass, momentum, and force unless the physics has none.
struct TestGrid {
  std::vector<Real> mass;
  std::vector<V> momentum, force;
};

// 12 x 11 cells in blocks of 3 cells: 4 x 4 blocks, the last row of blocks two cells tall.
const GridGeometry<2> kGrid(IVec<2>(12, 11), 1);
const IVec<2> kBlocks(4, 4);
constexpr int kBlockCells = 3;

int block(int bx, int by) {
  return bx + kBlocks[0] * by;
}

// Every node with a value of its own, force included when `forces`.
TestGrid numbered(bool forces) {
  TestGrid g;
  for (int k = 0; k < kGrid.nodeCount(); ++k) {
    g.mass.push_back(1 + k);
    g.momentum.push_back(V(k, 1));
    if (forces) g.force.push_back(V(2, k));
  }
  return g;
}

TestGrid zeros(bool forces) {
  TestGrid g;
  g.mass.assign(kGrid.nodeCount(), 0);
  g.momentum.assign(kGrid.nodeCount(), V::Zero());
  if (forces) g.force.assign(kGrid.nodeCount(), V::Zero());
  return g;
}

// Whether node k lies in the region of block (1, 1): the nodes its cells 3..5 reach, 2..7.
bool inRegionOfBlock11(int k) {
  const IVec<2> i = kGrid.coords(k);
  return i.x() >= 2 && i.x() <= 7 && i.y() >= 2 && i.y() <= 7;
}

}  // namespace

TEST(StillBlocks, ABlockIsKeptOnlyWhereItsParticlesWriteAsManyNodesAsItsRegionHolds) {
  StillBlocks<2, TestGrid, Real> still(kGrid, kBlocks, kBlockCells, true);
  // A region is 6 x 6 nodes; a particle writes 3 x 3 at least: 4 particles are worth it, 3 not.
  EXPECT_TRUE(still.mayKeep(block(1, 1), 4));
  EXPECT_FALSE(still.mayKeep(block(1, 1), 3));
  // The last block along x holds the far face's cell 12 too, whose particles reach node 14,
  // beyond its region (8..13). Along y the 11 cells leave the last block room for the face.
  EXPECT_FALSE(still.mayKeep(block(3, 1), 100));
  EXPECT_TRUE(still.mayKeep(block(1, 3), 4));
}

TEST(StillBlocks, InThreeDimensionsThirteenParticlesFillARegion) {
  // Blocks of 4 cells: a region of 7^3 = 343 nodes, a particle writing 27 at least; 13 * 27 =
  // 351 is enough, 12 * 27 = 324 not. 8 cells along each axis leave only the first block keepable.
  const GridGeometry<3> grid(IVec<3>(8, 8, 8), 1);
  struct Grid3 {
    std::vector<Real> mass;
    std::vector<Vec<3>> momentum, force;
  };
  StillBlocks<3, Grid3, Real> still(grid, IVec<3>(2, 2, 2), 4, false);
  EXPECT_TRUE(still.mayKeep(0, 13));
  EXPECT_FALSE(still.mayKeep(0, 12));
  EXPECT_FALSE(still.mayKeep(1, 100));
}

TEST(StillBlocks, KeepTakesTheBlocksRegionOutOfTheScratchAndAddGivesItBackScaled) {
  StillBlocks<2, TestGrid, Real> still(kGrid, kBlocks, kBlockCells, true);
  const TestGrid before = numbered(true);
  TestGrid scratch = before;
  still.keep(block(1, 1), 6, scratch);
  // The region emptied for the next block's scatter, the rest of the scratch untouched.
  for (int k = 0; k < kGrid.nodeCount(); ++k) {
    if (inRegionOfBlock11(k)) {
      EXPECT_EQ(scratch.mass[k], 0) << k;
      EXPECT_EQ(scratch.momentum[k], V::Zero()) << k;
      EXPECT_EQ(scratch.force[k], V::Zero()) << k;
    } else {
      EXPECT_EQ(scratch.mass[k], before.mass[k]) << k;
      EXPECT_EQ(scratch.momentum[k], before.momentum[k]) << k;
    }
  }
  // Added to a grid that holds the other blocks' scatter: mass and force as kept, the momentum
  // times the new step's scale (kept at unit scale).
  TestGrid g = zeros(true);
  g.mass.assign(kGrid.nodeCount(), 10);
  still.add(block(1, 1), g, 0.5);
  for (int k = 0; k < kGrid.nodeCount(); ++k) {
    const bool in = inRegionOfBlock11(k);
    EXPECT_EQ(g.mass[k], in ? 10 + before.mass[k] : 10) << k;
    EXPECT_EQ(g.momentum[k], in ? V(0.5 * before.momentum[k]) : V::Zero()) << k;
    EXPECT_EQ(g.force[k], in ? before.force[k] : V::Zero()) << k;
  }
}

TEST(StillBlocks, ABlockHoldsItsScatterForTheSameCountUntilForgotten) {
  StillBlocks<2, TestGrid, Real> still(kGrid, kBlocks, kBlockCells, true);
  EXPECT_FALSE(still.holds(block(1, 1), 6));  // nothing kept yet
  TestGrid scratch = numbered(true);
  still.keep(block(1, 1), 6, scratch);
  EXPECT_TRUE(still.holds(block(1, 1), 6));
  EXPECT_FALSE(still.holds(block(1, 1), 5));  // a particle came or went
  EXPECT_FALSE(still.holds(block(2, 1), 6));
  still.forget(block(1, 1));
  EXPECT_FALSE(still.holds(block(1, 1), 6));
  still.keep(block(1, 1), 6, scratch);
  still.keep(block(2, 2), 4, scratch);
  still.forgetAll();
  EXPECT_FALSE(still.holds(block(1, 1), 6));
  EXPECT_FALSE(still.holds(block(2, 2), 4));
}

TEST(StillBlocks, WithoutForcesTheGridsNeedNoForceArray) {
  // MLS puts the force into the momentum: its partial grids have no force array to copy.
  StillBlocks<2, TestGrid, Real> still(kGrid, kBlocks, kBlockCells, false);
  const TestGrid before = numbered(false);
  TestGrid scratch = before;
  still.keep(block(1, 1), 6, scratch);
  TestGrid g = zeros(false);
  still.add(block(1, 1), g, 1);
  for (int k = 0; k < kGrid.nodeCount(); ++k) {
    const bool in = inRegionOfBlock11(k);
    EXPECT_EQ(g.mass[k], in ? before.mass[k] : 0) << k;
    EXPECT_EQ(g.momentum[k], in ? before.momentum[k] : V::Zero()) << k;
  }
  EXPECT_TRUE(g.force.empty());
}
