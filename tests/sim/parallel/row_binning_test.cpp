// Where each particle goes in a coloured scatter (sim/parallel/row_binning.h): 2D rows of blocks
// of 3 x 3 cells, three colours, one cell of drift; 3D blocks of 4^3, binned every step.
#include "sim/parallel/row_binning.h"

#include <gtest/gtest.h>

#include <set>
#include <vector>

#include "sim/parallel/team.h"
#include "sim/parallel/work_shares.h"

using namespace snowsim;

namespace {

using V = Vec<2>;

// The binning of particles at x in `parts` parts of equal shares, on the calling thread.
struct Binned {
  Team team;
  WorkShares shares;
  RowBinning<2> binning;

  Binned(const GridGeometry<2>& grid, const std::vector<V>& x, int parts)
      : binning(grid, static_cast<int>(x.size())) {
    team.configure(parts, false);
    shares.reset(parts);
    binning.setParts(parts);
    binning.bin(team, shares, x);
  }
  std::vector<int> order(int particles) const {
    std::vector<int> o;
    for (int i = 0; i < particles; ++i) o.push_back(binning.sorted(i));
    return o;
  }
};

// 12 x 12 cells: 4 x 4 blocks, 4 rows.
const GridGeometry<2> kGrid(IVec<2>(12, 12), 1);

// Seven particles; their blocks (x, y): (3, 0), (0, 1), (0, 0), (1, 0), (0, 0), (3, 3), (1, 1).
const std::vector<V> kScattered = {V(10.5, 1.5), V(0.5, 4.5),   V(1.5, 0.5), V(4.5, 2.5),
                                   V(2.5, 2.5),  V(11.9, 11.9), V(5.5, 4.5)};

// One particle at each cell's centre: 36 a row.
std::vector<V> everyCell(const GridGeometry<2>& grid) {
  std::vector<V> x;
  for (int j = 0; j < grid.cells[1]; ++j)
    for (int i = 0; i < grid.cells[0]; ++i) x.push_back(V(i + 0.5, j + 0.5));
  return x;
}

}  // namespace

TEST(RowBinning, SortsByRowThenBlockAndKeepsTheStoredOrderWithinABlock) {
  // Row 0: block 0 holds particles 2 and 4, block 1 particle 3, block 3 particle 0; row 1: block
  // 0 particle 1, block 1 particle 6; row 2 none; row 3 particle 5.
  const std::vector<int> expected = {2, 4, 3, 0, 1, 6, 5};
  for (const int parts : {1, 3}) {
    // A stable counting sort: the same order however the particles are split among the parts.
    const Binned b(kGrid, kScattered, parts);
    EXPECT_EQ(b.order(7), expected) << parts << " parts";
    const std::vector<int> row_start = {b.binning.rowStart(0), b.binning.rowStart(1),
                                        b.binning.rowStart(2), b.binning.rowStart(3),
                                        b.binning.rowStart(4)};
    EXPECT_EQ(row_start, (std::vector<int>{0, 4, 6, 6, 7}));
  }
}

TEST(RowBinning, ARowsBlocksSpanTheBinnedBoxAlongX) {
  // Row 0's blocks 0..3 (the particles' blocks span x blocks 0 to 3): block 2 is empty.
  const Binned b(kGrid, kScattered, 1);
  std::vector<std::vector<int>> blocks;
  b.binning.forBlocksOfRow(0, [&](int block, int begin, int end) {
    blocks.push_back({block, begin, end});
  });
  EXPECT_EQ(blocks, (std::vector<std::vector<int>>{{0, 0, 2}, {1, 2, 3}, {2, 3, 3}, {3, 3, 4}}));
  // Row 2 holds no particle: no block visited.
  int visited = 0;
  b.binning.forBlocksOfRow(2, [&](int, int, int) { ++visited; });
  EXPECT_EQ(visited, 0);
}

TEST(RowBinning, RowsOfOneColourAreColourStrideRowsApart) {
  const Binned b(kGrid, kScattered, 1);
  for (int row = 0; row < 4; ++row) EXPECT_EQ(b.binning.rowColour(row), row % 3) << row;
  // 3D: two colours along y times two along z, rows counted y first.
  Team team;
  team.configure(1, false);
  WorkShares shares;
  shares.reset(1);
  RowBinning<3> binning(GridGeometry<3>(IVec<3>(8, 12, 8), 1), 1);  // 2 x 3 x 2 blocks
  binning.setParts(1);
  binning.bin(team, shares, std::vector<Vec<3>>{Vec<3>(1, 1, 1)});
  const std::vector<int> colours = {binning.rowColour(0), binning.rowColour(1),
                                    binning.rowColour(2), binning.rowColour(3),
                                    binning.rowColour(4), binning.rowColour(5)};
  EXPECT_EQ(colours, (std::vector<int>{0, 1, 0, 2, 3, 2}));
}

TEST(RowBinning, EachPartTakesConsecutiveRowsNearestItsShare) {
  // Four rows of 36 particles. Two parts: the cut at 72 falls between rows 1 and 2. Three parts:
  // the cut at 48 lies in row 1 (36..72), mostly after it, which so goes to the second part; the
  // cut at 96 in row 2 (72..108), mostly before it: the second part takes it too.
  const std::vector<V> x = everyCell(kGrid);
  const Binned two(kGrid, x, 2);
  EXPECT_EQ(two.binning.partRows(0), std::make_pair(0, 2));
  EXPECT_EQ(two.binning.partRows(1), std::make_pair(2, 4));
  const Binned three(kGrid, x, 3);
  EXPECT_EQ(three.binning.partRows(0), std::make_pair(0, 1));
  EXPECT_EQ(three.binning.partRows(1), std::make_pair(1, 3));
  EXPECT_EQ(three.binning.partRows(2), std::make_pair(3, 4));
}

TEST(RowBinning, AParticleMayDriftOneCellBeyondItsRowBeforeTheNextBinning) {
  const std::vector<V> x = everyCell(kGrid);
  Binned b(kGrid, x, 1);
  EXPECT_FALSE(b.binning.mustBin());
  EXPECT_EQ(b.binning.binnings(), 1);
  // Row 1 holds cells 3..5 along y: one cell of drift allows [2, 7). Along x the rows span the
  // whole domain, unbounded beyond it, as row 0 is below y = 0.
  const auto within = [&](int row, V at) {
    RowBinning<2>::RowCells cells;
    return b.binning.withinRowCells(b.binning.rowStart(row), at, cells);
  };
  EXPECT_TRUE(within(1, V(5, 2.1)));
  EXPECT_TRUE(within(1, V(5, 6.9)));
  EXPECT_FALSE(within(1, V(5, 1.9)));
  EXPECT_FALSE(within(1, V(5, 7.1)));
  EXPECT_TRUE(within(1, V(-3, 4)));
  EXPECT_TRUE(within(0, V(5, -3)));
  b.binning.particlesLeftTheirRows();
  EXPECT_TRUE(b.binning.mustBin());
  b.binning.bin(b.team, b.shares, x);
  EXPECT_FALSE(b.binning.mustBin());
  EXPECT_EQ(b.binning.binnings(), 2);
  // 3D allows no drift: binned anew every step.
  Team team;
  team.configure(1, false);
  WorkShares shares;
  shares.reset(1);
  RowBinning<3> binning(GridGeometry<3>(IVec<3>(8, 8, 8), 1), 1);
  binning.setParts(1);
  binning.bin(team, shares, std::vector<Vec<3>>{Vec<3>(1, 1, 1)});
  EXPECT_TRUE(binning.mustBin());
}

TEST(RowBinning, TheActiveNodesHoldWhatTheParticlesReachAfterADrift) {
  // Nine particles in cells 12..14 of a 30 x 30 grid (one block), the kernel's reach c - 1 ..
  // c + 2 of their cells c, after a drift of one cell either way: nodes 10..17 along each axis.
  const GridGeometry<2> grid(IVec<2>(30, 30), 1);
  std::vector<V> x;
  for (int j = 12; j < 15; ++j)
    for (int i = 12; i < 15; ++i) x.push_back(V(i + 0.5, j + 0.5));
  Binned b(grid, x, 1);
  const NodeBox<2> active = b.binning.active();
  for (int a = 0; a < 2; ++a) {
    EXPECT_LE(active.lo[a], 10 + GridGeometry<2>::ghost) << a;
    EXPECT_GE(active.hi[a], 18 + GridGeometry<2>::ghost) << a;
  }
  // A small snow in a large domain: its grid stages touch a few of the nodes.
  EXPECT_LT(active.count() * 4, grid.nodeCount());
  // The runs within the updated box cover every node reached.
  std::set<int> run_nodes;
  const NodeBox<2>& updated = b.binning.updated();
  for (int line = 0; line < updated.hi[1] - updated.lo[1]; ++line)
    b.binning.forUpdatedRuns(line, [&](int k, int count) {
      for (int n = 0; n < count; ++n) run_nodes.insert(k + n);
    });
  for (int j = 10; j <= 17; ++j)
    for (int i = 10; i <= 17; ++i)
      EXPECT_TRUE(run_nodes.count(grid.index(IVec<2>(i, j)))) << i << " " << j;
  // The snow moves away: the next grid stage updates the old nodes too, to zero them.
  b.binning.gridStageDone();
  for (V& p : x) p += V(9, 9);
  b.binning.bin(b.team, b.shares, x);
  const NodeBox<2>& next = b.binning.updated();
  for (int a = 0; a < 2; ++a) {
    EXPECT_LE(next.lo[a], active.lo[a]) << a;
    EXPECT_GE(next.hi[a], b.binning.active().hi[a]) << a;
    EXPECT_GT(b.binning.active().lo[a], active.lo[a]) << a;
  }
}
