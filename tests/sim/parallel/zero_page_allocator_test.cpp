// The allocator behind the MPM partial grids: value-initialised elements read zero without being
// written, also in memory that was used and freed before.
#include "sim/parallel/zero_page_allocator.h"

#include <gtest/gtest.h>

#include <vector>

#include "sim/core/math.h"

using namespace snowsim;

TEST(ZeroPageAllocator, ValueInitialisedElementsAreZeroEvenInReusedMemory) {
  for (int round = 0; round < 3; ++round) {
    {
      std::vector<double> dirty(1000, 1.5);  // freed here: the next block of its size may reuse it
    }
    const std::vector<double, ZeroPageAllocator<double>> numbers(1000);
    for (const double x : numbers) ASSERT_EQ(x, 0.0);
    { std::vector<Vec<2>> dirty(500, Vec<2>(1.5, -2.0)); }
    std::vector<Vec<2>, ZeroPageAllocator<Vec<2>>> vectors(500);
    for (const Vec<2>& v : vectors) ASSERT_TRUE(v.isZero(0));
    vectors.resize(1000);  // grows into new memory: still zero
    for (const Vec<2>& v : vectors) ASSERT_TRUE(v.isZero(0));
  }
}
