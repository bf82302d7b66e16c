// The slab decomposition (sim/distributed/slab_decomposition.h) in one process: in the world of
// one process, and as one rank of a world of two whose other rank's messages are scripted.
#include "sim/distributed/slab_decomposition.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "sim/core/errors.h"
#include "sim/core/particles.h"

using namespace snowsim;

namespace {

using V = Vec<2>;

// Rank `rank` of a world of `ranks`: every rank gathers what this one sends; what it sends to
// each rank is kept, and comes back as if that rank had sent it (loopback) or nothing comes;
// rank 0's gather to it holds `others` for the other ranks.
class ScriptedWorld final : public RankExchange {
 public:
  ScriptedWorld(int rank, int ranks) : rank_(rank), ranks_(ranks) {}
  int rank() const override { return rank_; }
  int ranks() const override { return ranks_; }
  std::vector<std::string> allGather(std::string_view mine) override {
    return std::vector<std::string>(ranks_, std::string(mine));
  }
  std::vector<std::string> gatherToFirst(std::string_view mine) override {
    sent_to_first = mine;
    if (rank_ != 0) return {};
    std::vector<std::string> all = others;
    all.insert(all.begin(), std::string(mine));
    return all;
  }
  std::vector<std::string> allToAll(const std::vector<std::string>& to) override {
    sent = to;
    return loopback ? to : std::vector<std::string>(ranks_);
  }
  [[noreturn]] void abortAll(int) override { std::abort(); }

  bool loopback = false;
  std::vector<std::string> others;  // ranks 1 .. ranks - 1's bytes, for rank 0's gather
  std::vector<std::string> sent;
  std::string sent_to_first;

 private:
  int rank_, ranks_;
};

// One particle per cell, at the cells' centres, of a grid of cells (16, 8): each column holds 8.
// Their velocity and mass follow the id, so that a mix-up shows.
Particles<2> lattice() {
  Particles<2> p;
  for (int i = 0; i < 16; ++i)
    for (int j = 0; j < 8; ++j) {
      const int id = p.size();
      p.add(V(i + 0.5, j + 0.5), V(id, -id), 1 + id, id % 3);
    }
  return p;
}
const GridGeometry<2> kGrid(IVec<2>(16, 8), 1);

}  // namespace

TEST(SlabDecomposition, InOneProcessEveryOperationLeavesItsInputAsItIs) {
  SlabDecomposition<2> slabs(oneProcess(), kGrid);
  EXPECT_FALSE(slabs.distributed());
  EXPECT_EQ(slabs.ranks(), 1);
  EXPECT_EQ(slabs.rank(), 0);
  const Particles<2> scene = lattice();
  Particles<2> particles = scene;
  slabs.keepOwn(particles);
  EXPECT_EQ(particles.x, scene.x);  // the one rank owns all
  particles.x[0] = V(15.5, 0.5);    // far from its first cell: no other rank to go to
  EXPECT_FALSE(slabs.migrate(particles, 20));
  EXPECT_EQ(particles.size(), scene.size());
  EXPECT_EQ(particles.x[0], V(15.5, 0.5));
  // The reductions over one rank: its own values.
  std::vector<double> values{1, -2};
  EXPECT_EQ(slabs.maxAndSum(values, 3.5), 3.5);
  EXPECT_EQ(values, (std::vector<double>{1, -2}));
  EXPECT_EQ(slabs.maxOverRanks({4, 5}), (std::vector<double>{4, 5}));
  EXPECT_EQ(slabs.gatherEach(7), std::vector<int>{7});
  EXPECT_EQ(slabs.gatherToFirst("mine"), std::vector<std::string>{"mine"});
  // No neighbour: the halo is this rank's sums alone.
  GridFields<2> fields;
  fields.resize(kGrid.nodeCount());
  fields.mass.assign(kGrid.nodeCount(), 1);
  NodeBox<2> all;
  all.hi = kGrid.nodes;
  slabs.sumHalo(fields, all, true);
  EXPECT_EQ(fields.mass, std::vector<Real>(kGrid.nodeCount(), 1));
  const std::vector<RankTraffic> traffic = slabs.gatherEach(slabs.traffic());
  ASSERT_EQ(traffic.size(), 1u);
  EXPECT_EQ(traffic[0].halo_nodes, 0);
  EXPECT_EQ(traffic[0].steps, 0);
}

TEST(SlabDecomposition, KeepOwnCutsTheLongestAxisAtEqualCountsAndEachRankKeepsItsSlab) {
  // The snow spreads 15 cells along x, 7 along y: the slabs are cut along x, at column 8, with
  // 64 particles on either side.
  const Particles<2> scene = lattice();
  std::vector<int> owner(scene.size(), -1);
  for (int rank = 0; rank < 2; ++rank) {
    ScriptedWorld world(rank, 2);
    SlabDecomposition<2> slabs(world, kGrid);
    Particles<2> particles = scene;
    slabs.keepOwn(particles);
    EXPECT_TRUE(slabs.distributed());
    EXPECT_EQ(slabs.axis(), 0);
    EXPECT_EQ(slabs.cuts(), std::vector<int>{8});
    EXPECT_EQ(particles.size(), 64) << rank;
    for (int p = 0; p < particles.size(); ++p) {
      const int id = particles.id[p];
      EXPECT_EQ(owner[id], -1) << id;  // no particle on two ranks
      owner[id] = rank;
      EXPECT_EQ(particles.x[p].x() < 8 ? 0 : 1, rank) << id;
      // Every array kept alongside x.
      EXPECT_EQ(particles.x[p], scene.x[id]);
      EXPECT_EQ(particles.v[p], scene.v[id]);
      EXPECT_EQ(particles.mass[p], scene.mass[id]);
      EXPECT_EQ(particles.body[p], scene.body[id]);
    }
  }
  for (int id = 0; id < scene.size(); ++id) EXPECT_NE(owner[id], -1) << id;
}

TEST(SlabDecomposition, TheCutFollowsTheParticlesAndKeepsEverySlabFourCellsWide) {
  ScriptedWorld world(0, 2);
  // Columns 0..3 hold 3 particles each, columns 4..15 one each: half of them lie below column 4.
  {
    SlabDecomposition<2> slabs(world, kGrid);
    Particles<2> particles;
    for (int i = 0; i < 16; ++i)
      for (int n = 0; n < (i < 4 ? 3 : 1); ++n) particles.add(V(i + 0.5, 0.5), V::Zero(), 1, 0);
    slabs.keepOwn(particles);
    EXPECT_EQ(slabs.cuts(), std::vector<int>{4});
  }
  // All in column 13: half of them lie below column 14, but the upper slab takes four columns.
  {
    SlabDecomposition<2> slabs(world, kGrid);
    Particles<2> particles;
    for (int n = 0; n < 10; ++n) particles.add(V(13.05 + 0.09 * n, 0.5), V::Zero(), 1, 0);
    slabs.keepOwn(particles);
    EXPECT_EQ(slabs.cuts(), std::vector<int>{12});
    EXPECT_EQ(particles.size(), 0);  // rank 0 owns columns 0..11
  }
  // Two ranks need 8 cells along some axis.
  SlabDecomposition<2> narrow(world, GridGeometry<2>(IVec<2>(7, 7), 1));
  Particles<2> particles = lattice();
  EXPECT_THROW(narrow.keepOwn(particles), InputError);
}

TEST(SlabDecomposition, TheHaloIsTheFourNodeLayersAroundTheCut) {
  // Rank 0 of two, cut at column 8: it shares nodes 7..10 with rank 1. Its partial sums there
  // come back as rank 1's, so exactly those nodes double.
  ScriptedWorld world(0, 2);
  world.loopback = true;
  SlabDecomposition<2> slabs(world, kGrid);
  Particles<2> particles = lattice();
  slabs.keepOwn(particles);
  ASSERT_EQ(slabs.cuts(), std::vector<int>{8});
  GridFields<2> fields;
  fields.resize(kGrid.nodeCount());
  fields.mass.assign(kGrid.nodeCount(), 1);
  fields.velocity.assign(kGrid.nodeCount(), V(1, 2));  // the momentum, before the node update
  fields.force.assign(kGrid.nodeCount(), V(3, 4));
  NodeBox<2> all;
  all.hi = kGrid.nodes;
  slabs.sumHalo(fields, all, true);
  ASSERT_EQ(world.sent.size(), 2u);
  EXPECT_TRUE(world.sent[0].empty());  // nothing to itself: no slab below
  for (int k = 0; k < kGrid.nodeCount(); ++k) {
    const int i = kGrid.coords(k).x();
    const Real times = i >= 7 && i <= 10 ? 2 : 1;
    EXPECT_EQ(fields.mass[k], times) << i;
    EXPECT_EQ(fields.velocity[k], V(times * V(1, 2))) << i;
    EXPECT_EQ(fields.force[k], V(times * V(3, 4))) << i;
  }
  // Four layers of the grid's 13 stored rows of nodes (8 cells, ghosts included).
  EXPECT_EQ(slabs.traffic().halo_nodes, 4 * kGrid.nodes[1]);
}

TEST(SlabDecomposition, ParticlesThatLeaveTheSlabGoToTheirRank) {
  ScriptedWorld world(0, 2);
  SlabDecomposition<2> slabs(world, kGrid);
  Particles<2> particles = lattice();
  slabs.keepOwn(particles);
  // Not a step of re-cutting (rebalance_interval): the cut stays at column 8.
  EXPECT_FALSE(slabs.migrate(particles, 1));  // nobody moved
  particles.x[0] = V(9.5, 0.5);
  particles.x[1] = V(8.25, 1.5);
  const int moved_first = particles.id[0], moved_second = particles.id[1];
  EXPECT_TRUE(slabs.migrate(particles, 2));
  EXPECT_EQ(particles.size(), 62);
  for (const int id : particles.id) {
    EXPECT_NE(id, moved_first);
    EXPECT_NE(id, moved_second);
  }
  // Their length, then each of the two with every array: x, v (2 doubles each), mass, volume,
  // body and id.
  ASSERT_EQ(world.sent.size(), 2u);
  EXPECT_TRUE(world.sent[0].empty());
  EXPECT_EQ(world.sent[1].size(), 8 + 2 * (4 * sizeof(Real) + 2 * sizeof(Real) + 2 * sizeof(int)));
  EXPECT_EQ(slabs.traffic().particles_sent, 2);
  EXPECT_EQ(slabs.traffic().steps, 2);
}

TEST(SlabDecomposition, WhatParticlesCarryArrivesOnceTheyAreStored) {
  // Rank 0 of two, whose messages come back to it as rank 1's: the two particles that leave
  // come back with the ids their carry wrote, read once both are stored again.
  ScriptedWorld world(0, 2);
  world.loopback = true;
  SlabDecomposition<2> slabs(world, kGrid);
  Particles<2> particles = lattice();
  slabs.keepOwn(particles);
  particles.x[0] = V(9.5, 0.5);
  particles.x[3] = V(8.25, 1.5);
  const std::vector<int> leaving_ids = {particles.id[0], particles.id[3]};
  std::vector<int> carried;
  int stored_on_arrival = 0;
  EXPECT_TRUE(slabs.migrate(
      particles, 2,
      [&](const std::vector<int>& leaving, std::string& bytes) {
        ASSERT_EQ(leaving, (std::vector<int>{0, 3}));
        for (const int p : leaving) SlabDecomposition<2>::append(bytes, particles.id[p]);
      },
      [&](std::string_view bytes) {
        stored_on_arrival = particles.size();
        for (size_t at = 0; at < bytes.size();)
          carried.push_back(SlabDecomposition<2>::take<int>(bytes, at));
      }));
  EXPECT_EQ(carried, leaving_ids);
  EXPECT_EQ(stored_on_arrival, 64);
  EXPECT_EQ(particles.id[62], leaving_ids[0]);
  EXPECT_EQ(particles.id[63], leaving_ids[1]);
  // The step's slab, cells 0..7, reached the nodes of columns -1 .. 9.
  for (int i = -1; i < 12; ++i)
    EXPECT_EQ(slabs.reachedInLastStep(kGrid.index(IVec<2>(i, 3))), i <= 9) << i;
}

TEST(SlabDecomposition, GatherByIdPutsEveryRanksParticlesBackInCreationOrder) {
  // Alternate ids left and right of the cut, so that rank 0's and rank 1's particles interleave
  // by id and a concatenation of the two ranks would be out of order.
  Particles<2> scene;
  for (int n = 0; n < 40; ++n)
    scene.add(V(n % 2 == 0 ? 2.5 + 0.1 * n : 12.5, 0.5 + 0.1 * n), V(n, 1), 1 + n, n % 4);
  ScriptedWorld first(0, 2), second(1, 2);
  SlabDecomposition<2> slabs0(first, kGrid), slabs1(second, kGrid);
  Particles<2> mine0 = scene, mine1 = scene, gathered;
  slabs0.keepOwn(mine0);
  slabs1.keepOwn(mine1);
  ASSERT_EQ(mine0.size(), 20);
  ASSERT_EQ(mine1.size(), 20);
  slabs1.gatherById(mine1, gathered);
  EXPECT_EQ(gathered.size(), 0);  // rank 0 alone writes the frames
  first.others = {second.sent_to_first};
  slabs0.gatherById(mine0, gathered);
  EXPECT_EQ(gathered.id, scene.id);
  EXPECT_EQ(gathered.x, scene.x);
  EXPECT_EQ(gathered.v, scene.v);
  EXPECT_EQ(gathered.mass, scene.mass);
  EXPECT_EQ(gathered.volume, scene.volume);
  EXPECT_EQ(gathered.body, scene.body);
}
