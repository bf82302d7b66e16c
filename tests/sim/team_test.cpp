#include "sim/team.h"

#include <gtest/gtest.h>

#include <chrono>
#include <numeric>
#include <set>
#include <thread>
#include <vector>

using namespace snowsim;

namespace {

// Rounds of three stages in one shared task of `parts` parts: each part writes, one thread sums,
// each part reads the sum. A barrier that let a thread run ahead would show a stale sum or a
// missed part.
void checkStagesMeetInOrder(int parts, bool parallel = true) {
  Team team;
  team.configure(parts, parallel);
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

TEST(Team, StagesOfASharedTaskMeetInOrder) {
  checkStagesMeetInOrder(2);
  checkStagesMeetInOrder(3);  // more threads than this machine's two cores: they take turns
  checkStagesMeetInOrder(5);  // a barrier of three rounds, whose signals form two rings in one
}

TEST(Team, ATeamNotInParallelRunsEveryPartOnTheCallingThread) {
  checkStagesMeetInOrder(3, false);
  Team team;
  team.configure(3, false);
  std::vector<std::thread::id> ran(3);
  team.together(
      true, [&] { team.forEachPart([&](int part) { ran[part] = std::this_thread::get_id(); }); });
  EXPECT_EQ(ran, std::vector<std::thread::id>(3, std::this_thread::get_id()));
}

TEST(Team, EachPartRunsOnAThreadOfItsOwnAfterEveryConfiguration) {
  Team team;
  for (const int parts : {2, 4, 1, 3}) {
    team.configure(parts, true);
    std::vector<std::thread::id> ran(parts);
    team.forEachPart([&](int part) { ran[part] = std::this_thread::get_id(); });
    EXPECT_EQ(std::set<std::thread::id>(ran.begin(), ran.end()).size(), size_t(parts))
        << parts << " parts";
    EXPECT_EQ(ran[0], std::this_thread::get_id()) << "part 0 runs on the caller";
  }
}

TEST(Team, AMovedTeamStartsWorkersOfItsOwn) {
  Team first;
  first.configure(3, true);
  first.forEachPart([](int) {});
  Team moved(std::move(first));  // the first team's workers stop; they knew it by address
  moved.configure(3, true);
  std::vector<std::thread::id> ran(3);
  moved.forEachPart([&](int part) { ran[part] = std::this_thread::get_id(); });
  EXPECT_EQ(std::set<std::thread::id>(ran.begin(), ran.end()).size(), 3u);
}

TEST(Team, SleepingThreadsAreWokenForTheNextTaskAndAtBarriers) {
  // Long enough for the spinning to end: the workers sleep between the tasks, and in a stage
  // whose part 0 is slow the others sleep at the barrier.
  const auto nap = [] { std::this_thread::sleep_for(std::chrono::milliseconds(30)); };
  Team team;
  team.configure(3, true);
  std::vector<int> runs(3, 0);
  for (int task = 0; task < 3; ++task) {
    nap();
    team.together(true, [&] {
      team.forEachPart([&](int part) {
        if (part == 0) nap();
        ++runs[part];
      });
      team.forEachPart([&](int part) { ++runs[part]; });
    });
  }
  EXPECT_EQ(runs, std::vector<int>(3, 6));
}

TEST(Team, OutsideASharedTaskEachStageRunsOnItsOwn) {
  Team team;
  team.configure(4, true);
  std::vector<int> runs(4, 0);
  team.forEachPart([&](int part) { ++runs[part]; });
  int serial_runs = 0;
  team.serially([&] { ++serial_runs; });
  EXPECT_EQ(runs, std::vector<int>(4, 1));
  EXPECT_EQ(serial_runs, 1);
}
