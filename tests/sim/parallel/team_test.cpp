#include "sim/parallel/team.h"

#include <gtest/gtest.h>

#include <chrono>
#include <numeric>
#include <set>
#include <thread>
#include <vector>

#include "tests/support/threaded_test.h"

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
      team.forEachPart("write", [&](int part) {
        written[part] = long(round) * parts + part;
        ++runs[part];
      });
      team.serially("sum", [&] { sum = std::accumulate(written.begin(), written.end(), 0L); });
      team.forEachPart("read", [&](int part) { read[part] = sum; });
      team.serially("check", [&] {
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

THREADED_TEST(Team, StagesOfASharedTaskMeetInOrder) {
  checkStagesMeetInOrder(2);
  checkStagesMeetInOrder(3);  // more threads than cores on a 2-core machine: they take turns
  checkStagesMeetInOrder(5);  // a barrier of three rounds, whose signals form two rings in one
}

THREADED_TEST(Team, ATeamNotInParallelRunsEveryPartOnTheCallingThread) {
  checkStagesMeetInOrder(3, false);
  Team team;
  team.configure(3, false);
  std::vector<std::thread::id> ran(3);
  team.together(true, [&] {
    team.forEachPart("stage", [&](int part) { ran[part] = std::this_thread::get_id(); });
  });
  EXPECT_EQ(ran, std::vector<std::thread::id>(3, std::this_thread::get_id()));
}

THREADED_TEST(Team, EachPartRunsOnAThreadOfItsOwnAfterEveryConfiguration) {
  Team team;
  for (const int parts : {2, 4, 1, 3}) {
    team.configure(parts, true);
    std::vector<std::thread::id> ran(parts);
    team.forEachPart("stage", [&](int part) { ran[part] = std::this_thread::get_id(); });
    EXPECT_EQ(std::set<std::thread::id>(ran.begin(), ran.end()).size(), size_t(parts))
        << parts << " parts";
    EXPECT_EQ(ran[0], std::this_thread::get_id()) << "part 0 runs on the caller";
  }
}

THREADED_TEST(Team, AMovedTeamStartsWorkersOfItsOwn) {
  Team first;
  first.configure(3, true);
  first.forEachPart("stage", [](int) {});
  Team moved(std::move(first));  // the first team's workers stop; they knew it by address
  moved.configure(3, true);
  std::vector<std::thread::id> ran(3);
  moved.forEachPart("stage", [&](int part) { ran[part] = std::this_thread::get_id(); });
  EXPECT_EQ(std::set<std::thread::id>(ran.begin(), ran.end()).size(), 3u);
}

THREADED_TEST(Team, SleepingThreadsAreWokenForTheNextTaskAndAtBarriers) {
  // Long enough for the spinning to end: the workers sleep between the tasks, and in a stage
  // whose part 0 is slow the others sleep at the barrier.
  const auto nap = [] { std::this_thread::sleep_for(std::chrono::milliseconds(30)); };
  Team team;
  team.configure(3, true);
  std::vector<int> runs(3, 0);
  for (int task = 0; task < 3; ++task) {
    nap();
    team.together(true, [&] {
      team.forEachPart("stage", [&](int part) {
        if (part == 0) nap();
        ++runs[part];
      });
      team.forEachPart("stage", [&](int part) { ++runs[part]; });
    });
  }
  EXPECT_EQ(runs, std::vector<int>(3, 6));
}

THREADED_TEST(Team, OutsideASharedTaskEachStageRunsOnItsOwn) {
  Team team;
  team.configure(4, true);
  std::vector<int> runs(4, 0);
  team.forEachPart("stage", [&](int part) { ++runs[part]; });
  int serial_runs = 0;
  team.serially("serial", [&] { ++serial_runs; });
  EXPECT_EQ(runs, std::vector<int>(4, 1));
  EXPECT_EQ(serial_runs, 1);
}

// The profile counts each stage's meetings on each thread, and puts a slow part's time in its own
// thread's work and in the other thread's wait.
THREADED_TEST(Team, AProfileSplitsEachStageIntoWorkAndWaitPerThread) {
  const auto nap = [] { std::this_thread::sleep_for(std::chrono::milliseconds(20)); };
  const auto run = [&](Team& team) {
    team.together(true, [&] {
      for (int round = 0; round < 3; ++round) {
        team.forEachPart("part 1 naps", [&](int part) {
          if (part == 1) nap();
        });
        team.serially("nothing", [] {});
      }
    });
  };
  Team team;
  team.configure(2, true);
  team.profileStages(true);
  run(team);
  ASSERT_EQ(team.threads(), 2);
  for (int thread = 0; thread < 2; ++thread) {
    const std::vector<StageTime>& times = team.stageTimes(thread);
    ASSERT_EQ(times.size(), 2u) << "thread " << thread;
    EXPECT_EQ(times[0].stage, "part 1 naps");
    EXPECT_EQ(times[1].stage, "nothing");
    EXPECT_EQ(times[0].meetings, 3);
    EXPECT_EQ(times[1].meetings, 3);
  }
  // Part 1 runs on thread 1 (part t on thread t): three naps of 20 ms each.
  EXPECT_GE(team.stageTimes(1)[0].work_seconds, 0.060);
  EXPECT_LT(team.stageTimes(0)[0].work_seconds, 0.010);
  EXPECT_GT(team.stageTimes(0)[0].wait_seconds, 0.030);

  team.profileStages(false);
  run(team);
  EXPECT_EQ(team.stageTimes(0)[0].meetings, 3) << "nothing is added once profiling is off";
  team.profileStages(true);
  EXPECT_TRUE(team.stageTimes(0).empty()) << "a new profile starts empty";

  Team profiled_first;  // profiling from before the threads start covers them all
  profiled_first.profileStages(true);
  profiled_first.configure(2, true);
  run(profiled_first);
  ASSERT_EQ(profiled_first.threads(), 2);
  EXPECT_EQ(profiled_first.stageTimes(1).at(0).meetings, 3);

  Team alone;  // one thread runs both parts and waits for no one
  alone.configure(2, false);
  alone.profileStages(true);
  run(alone);
  ASSERT_EQ(alone.threads(), 1);
  EXPECT_GE(alone.stageTimes(0)[0].work_seconds, 0.060);
  EXPECT_LT(alone.stageTimes(0)[0].wait_seconds, 0.010);
}
