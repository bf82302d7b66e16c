// The progress line's ETA counts the steps left at the step the run takes now and, past the
// impact the cost estimate forecasts, at the hardened step (app/progress.h).
#include "app/progress.h"

#include <gtest/gtest.h>

namespace {

using snowsim::stepsLeft;

TEST(Progress, StepsLeftCountTheHardenedStepPastTheImpact) {
  // 1 s left at 1 ms: 1000 steps without a forecast.
  EXPECT_DOUBLE_EQ(stepsLeft(1, 2, 1e-3, 0, 0), 1000);
  // The impact at 1.5 s, the step a tenth after it: 500 + 5000.
  EXPECT_DOUBLE_EQ(stepsLeft(1, 2, 1e-3, 1.5, 1e-4), 500 + 5000);
  // Past the impact the step taken now holds, however it compares with the forecast.
  EXPECT_DOUBLE_EQ(stepsLeft(1.6, 2, 2e-4, 1.5, 1e-4), 2000);
  // A forecast step longer than the one taken now does not lengthen it.
  EXPECT_DOUBLE_EQ(stepsLeft(1, 2, 1e-3, 1.5, 1e-2), 1000);
  // An impact past the end changes nothing.
  EXPECT_DOUBLE_EQ(stepsLeft(1, 2, 1e-3, 3, 1e-4), 1000);
}

}  // namespace
