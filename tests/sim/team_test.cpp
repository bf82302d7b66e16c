#include "sim/team.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <numeric>
#include <vector>

using namespace snowsim;

namespace {

// Rounds of three stages in one shared region of `parts` threads (the region asks for one per
// part): each part writes, one thread sums, each part reads the sum. A barrier that let a thread
// run ahead would show a stale sum or a missed part.
void checkStagesMeetInOrder(int parts) {
  Team team;
  team.configure(parts, true);
  std::vector<long> written(parts), read(parts);
  std::vector<int> runs(parts, 0);
  long sum = 0;
  bool in_order = true;
  constexpr int rounds = 500;
  team.together(true, [&] {
    for (int round = 0; round < rounds; ++round) {
      team.forEachPart([&](int part) {
        written[part] = long(round) * parts + part;
        ++runs[part];
      });
      team.serially([&] { sum = std::accumulate(written.begin(), written.end(), 0L); });
      team.forEachPart([&](int part) { read[part] = sum; });
      team.serially([&] {
        const long expected = long(round) * parts * parts + long(parts) * (parts - 1) / 2;
        for (const long r : read) in_order = in_order && r == expected;
      });
    }
  });
  EXPECT_TRUE(in_order) << parts << " parts";
  for (int part = 0; part < parts; ++part)
    EXPECT_EQ(runs[part], rounds) << "part " << part << " of " << parts;
}

}  // namespace

TEST(Team, StagesOfASharedRegionMeetInOrder) {
  checkStagesMeetInOrder(2);
  checkStagesMeetInOrder(3);  // more threads than this machine's two cores: they take turns
}

TEST(Team, ARegionGrantedFewerThreadsThanPartsStillRunsEveryPart) {
  // Inside an active region, with one active level allowed, the runtime grants a nested region
  // one thread: it must run all three parts of each stage.
  const int levels = omp_get_max_active_levels();
  omp_set_max_active_levels(1);
  int granted = 0;
#pragma omp parallel num_threads(2)
#pragma omp single
  {
    Team team;
    team.configure(3, true);
    team.together(true, [&] {
#pragma omp single
      granted = omp_get_num_threads();
    });
    checkStagesMeetInOrder(3);
  }
  omp_set_max_active_levels(levels);
  EXPECT_EQ(granted, 1);
}

TEST(Team, OutsideASharedRegionEachStageRunsOnItsOwn) {
  Team team;
  team.configure(4, true);
  std::vector<int> runs(4, 0);
  team.forEachPart([&](int part) { ++runs[part]; });
  int serial_runs = 0;
  team.serially([&] { ++serial_runs; });
  EXPECT_EQ(runs, std::vector<int>(4, 1));
  EXPECT_EQ(serial_runs, 1);
}
