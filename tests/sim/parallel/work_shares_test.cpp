#include "sim/parallel/work_shares.h"

#include <gtest/gtest.h>

using namespace snowsim;

namespace {

// Steps of a stage of `items` items whose parts run at the given speeds (items per second), each
// cut by the shares the last step left.
void runSteps(WorkShares& shares, int items, const std::vector<double>& speed, int steps) {
  const int parts = shares.parts();
  for (int step = 0; step < steps; ++step) {
    for (int part = 0; part < parts; ++part) {
      const int mine = shares.start(part + 1, items) - shares.start(part, items);
      shares.record(part, mine, mine / speed[part]);
    }
    shares.update();
  }
}

}  // namespace

TEST(WorkShares, StartEquallyAndCoverEveryItem) {
  WorkShares shares;
  shares.reset(3);
  EXPECT_EQ(shares.start(0, 300), 0);
  EXPECT_EQ(shares.start(1, 300), 100);
  EXPECT_EQ(shares.start(2, 300), 200);
  EXPECT_EQ(shares.start(3, 300), 300);
}

TEST(WorkShares, AFasterPartTakesMoreUntilThePartsFinishTogether) {
  WorkShares shares;
  shares.reset(2);
  runSteps(shares, 3000, {2000, 1000}, 60);
  // Part 0 is twice as fast: two thirds of the items, so both take one second.
  EXPECT_NEAR(shares.start(1, 3000), 2000, 3);
  EXPECT_EQ(shares.start(2, 3000), 3000);
}

TEST(WorkShares, OneSlowStepMovesTheCutLittle) {
  WorkShares shares;
  shares.reset(2);
  runSteps(shares, 1000, {1000, 1000}, 10);
  runSteps(shares, 1000, {1000, 100}, 1);  // part 1 preempted for one step
  // Its speed is bounded at a quarter of the mean and smoothed: the cut moves by at most a sixth.
  EXPECT_GT(shares.start(1, 1000), 500);
  EXPECT_LT(shares.start(1, 1000), 500 + 1000 / 6);
}

TEST(WorkShares, APartWithNothingToDoIsTriedAgainAtTheMeanSpeed) {
  WorkShares shares;
  shares.reset(2);
  shares.record(0, 100, 0.1);
  shares.record(1, 0, 0);  // no items: its speed unknown, not zero
  shares.update();
  EXPECT_EQ(shares.start(1, 100), 50);
}
