// One simulation across MPI ranks (sim/distributed/), run as a user would: mpirun -np N snowsim
// run, oversubscribed on this machine, against the same scene in one process.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "sim/io/ply.h"
#include "tests/support/run_snowsim.h"

namespace fs = std::filesystem;
using snowsim_test::frames;
using snowsim_test::freshDir;
using snowsim_test::runCommand;
using snowsim_test::runSnowsim;

namespace {

const std::string kScene = std::string(SNOWSIM_SOURCE_DIR) + "/tests/sim/distributed/smash.json";
// Two frames of the smash (0.04 s, some 400 steps): the ball reaches the wall and flattens.
const std::string kShort = " --set time.duration=0.04 --no-png --no-mp4 --threads 1";

std::string mpirun(int ranks) {
  return "mpirun --allow-run-as-root --oversubscribe -np " + std::to_string(ranks) + " " +
         SNOWSIM_BINARY;
}

nlohmann::json summaryOf(const fs::path& dir) {
  return nlohmann::json::parse(std::ifstream(dir / "run.json"));
}

// How far apart two runs' particles are in a frame, each particle by its largest difference of a
// coordinate: the largest and the mean over the particles (metres).
struct PositionDifference {
  double largest = 0, mean = 0;
};
PositionDifference positionDifference(const fs::path& a, const fs::path& b,
                                      const std::string& frame) {
  const snowsim::Snapshot one = snowsim::readPly((a / frame).string());
  const snowsim::Snapshot other = snowsim::readPly((b / frame).string());
  EXPECT_EQ(one.position.size(), other.position.size());
  PositionDifference d;
  const size_t count = std::min(one.position.size(), other.position.size());
  for (size_t p = 0; p < count; ++p) {
    double particle = 0;
    for (int axis = 0; axis < 3; ++axis)
      particle =
          std::max(particle, double(std::abs(one.position[p][axis] - other.position[p][axis])));
    d.largest = std::max(d.largest, particle);
    d.mean += particle / double(std::max<size_t>(count, 1));
  }
  return d;
}

// Runs mpirun -np 2 snowsim`args` -o out and sends mpirun SIGTERM once `frame` is written.
void stopAtFrame(const std::string& args, const fs::path& out, const std::string& frame) {
  const pid_t child = fork();
  if (child == 0) {
    freopen("/dev/null", "w", stdout);
    freopen("/dev/null", "w", stderr);
    const std::string command = mpirun(2) + args + " -o " + out.string();
    execl("/bin/sh", "sh", "-c", ("exec " + command).c_str(), nullptr);
    _exit(127);
  }
  for (int i = 0; i < 60000 && !fs::exists(out / frame); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  kill(child, SIGTERM);
  int status = 0;
  waitpid(child, &status, 0);
}

class OneRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    single_ = freshDir("mpi_single");
    const auto run = runSnowsim("run " + kScene + " -o " + single_.string() + kShort);
    ASSERT_EQ(run.code, 0) << run.output;
  }
  static fs::path single_;
};
fs::path OneRun::single_;

// Across 2 and 4 ranks the frames hold every particle in the order of one process's, at positions
// that agree with it to round-off, and the snow crossed the slabs' cuts.
TEST_F(OneRun, RanksAgreeWithOneProcessToRoundOff) {
  for (const int ranks : {2, 4}) {
    const fs::path out = freshDir("mpi_" + std::to_string(ranks));
    const auto run = runCommand(mpirun(ranks) + " run " + kScene + " -o " + out.string() + kShort);
    ASSERT_EQ(run.code, 0) << run.output;
    const auto single = summaryOf(single_), split = summaryOf(out);
    EXPECT_EQ(split["steps"], single["steps"]) << "the ranks agree on the time step";
    ASSERT_EQ(split["ranks"].size(), ranks);
    long sent = 0, moved_cuts = 0;
    for (const auto& rank : split["ranks"]) {
      sent += rank["particles_sent"].get<long>();
      moved_cuts += rank["rebalances_that_moved_a_cut"].get<long>();
      EXPECT_GT(rank["rebalances"].get<long>(), 1);
    }
    EXPECT_GT(sent, 0) << "no particle migrated";
    EXPECT_GT(moved_cuts, 0) << "the slabs never followed the snow";
    const snowsim::Snapshot last = snowsim::readPly((out / "frame_00002.ply").string());
    ASSERT_EQ(last.position.size(), single["particles"].get<size_t>());
    const double difference = positionDifference(single_, out, "frame_00002.ply").largest;
    std::printf("%d ranks: largest position difference from one process after 0.04 s: %g m\n",
                ranks, difference);
    EXPECT_LT(difference, 1e-5) << "more than round-off (the cell is 0.01 m)";
    // The step's collapse at the wall is blamed on the snow that hardened there, whichever rank
    // holds it: every rank's stiffest particle is weighed, not rank 0's alone.
    ASSERT_TRUE(single.contains("step_collapse"));
    ASSERT_TRUE(split.contains("step_collapse"));
    const auto& collapse = single["step_collapse"];
    EXPECT_NEAR(split["step_collapse"]["hardening"].get<double>(),
                collapse["hardening"].get<double>(), 1e-3 * collapse["hardening"].get<double>());
  }
}

// With cracks that open (tests/sim/distributed/smash.json cracks near the wall from 0.032 s on),
// the ranks share the crack's fields at the nodes near their cuts. Its sides follow signs and
// thresholds, so the round-off of sums taken in another order moves the snow farther than in the
// plain solver: about as far as a velocity 1e-7 off does in one process (docs/scale-out.md).
// Without the shared fields, the particles near the cuts part by half a cell (mean 1e-3 m).
TEST(Mpi, CracksAcrossRanksAgreeWithOneProcess) {
  const std::string cracks =
      " --set mpm.transfer=mls --set mpm.open_cracks=true --set material.fracture_strain=0.3"
      " --set time.duration=0.06 --no-png --no-mp4 --threads 1";
  const fs::path single = freshDir("mpi_cracks_single");
  const auto one = runSnowsim("run " + kScene + " -o " + single.string() + cracks);
  ASSERT_EQ(one.code, 0) << one.output;
  const auto stages = summaryOf(single)["stages"];
  ASSERT_TRUE(std::any_of(stages.begin(), stages.end(), [](const auto& s) {
    return s["stage"] == "crack: scatter";
  })) << "no crack step: the test's scene does not crack";
  for (const int ranks : {2, 4}) {
    const fs::path out = freshDir("mpi_cracks_" + std::to_string(ranks));
    const auto run = runCommand(mpirun(ranks) + " run " + kScene + " -o " + out.string() + cracks);
    ASSERT_EQ(run.code, 0) << run.output;
    EXPECT_EQ(summaryOf(out)["steps"], summaryOf(single)["steps"]);
    const PositionDifference d = positionDifference(single, out, "frame_00003.ply");
    std::printf(
        "%d ranks with cracks: position difference from one process after 0.06 s: "
        "largest %g m, mean %g m\n",
        ranks, d.largest, d.mean);
    EXPECT_LT(d.largest, 2e-3) << "a fifth of a cell";
    EXPECT_LT(d.mean, 3e-4);
  }
}

// Two runs across as many ranks write byte-identical frames.
TEST(Mpi, SameRanksGiveByteIdenticalFrames) {
  const fs::path first = freshDir("mpi_first"), second = freshDir("mpi_second");
  for (const fs::path& out : {first, second}) {
    const auto run = runCommand(mpirun(2) + " run " + kScene + " -o " + out.string() + kShort);
    ASSERT_EQ(run.code, 0) << run.output;
  }
  EXPECT_EQ(frames(first), frames(second));
}

// A run across 2 ranks stopped by SIGTERM to mpirun, resumed across 2 ranks, writes the frames of
// the run never stopped. The signal comes at the second of 10 frames: an idle machine runs the
// remaining frames in seconds, not before mpirun passes the signal on.
TEST(Mpi, ResumeAcrossRanksWritesTheFramesOfTheWholeRun) {
  const std::string args =
      " run " + kScene +
      " --set time.duration=0.2 --no-png --no-mp4 --threads 1 --checkpoint-minutes 0";
  const fs::path whole = freshDir("mpi_whole"), out = freshDir("mpi_stopped");
  ASSERT_EQ(runCommand(mpirun(2) + args + " -o " + whole.string()).code, 0);
  stopAtFrame(args, out, "frame_00001.ply");
  ASSERT_TRUE(fs::exists(out / "checkpoint.snowsim")) << "stopped without a checkpoint";
  EXPECT_EQ(summaryOf(out)["interrupted_by_signal"], SIGTERM);
  // A checkpoint of 2 ranks is refused by another count, or by one process, naming the count it
  // needs, from rank 0 alone and before any rank reads it.
  for (const std::string& launch : {mpirun(4), std::string(SNOWSIM_BINARY)}) {
    const auto other = runCommand(launch + " resume " + out.string());
    EXPECT_EQ(other.code, 2) << other.output;
    EXPECT_NE(other.output.find("written by a run across 2 MPI ranks; resume it across as many: "
                                "mpirun -np 2 snowsim resume"),
              std::string::npos)
        << other.output;
    EXPECT_EQ(other.output.find("MPI_ABORT"), std::string::npos) << other.output;
  }
  const auto resumed = runCommand(mpirun(2) + " resume " + out.string());
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  EXPECT_EQ(frames(out), frames(whole));
  EXPECT_EQ(summaryOf(out)["steps"], summaryOf(whole)["steps"]);
}

// The same with cracks that open and sleep, stopped once the snow has cracked: the crack's fields
// at each rank's nodes resume with it.
TEST(Mpi, ResumeAcrossRanksWithCracksWritesTheFramesOfTheWholeRun) {
  const std::string args = " run " + kScene +
                           " --set mpm.transfer=mls --set mpm.open_cracks=true"
                           " --set material.fracture_strain=0.3 --set mpm.auto_sleep.enabled=true"
                           " --set time.duration=0.4 --no-png --no-mp4 --threads 1"
                           " --checkpoint-minutes 0";
  const fs::path whole = freshDir("mpi_cracks_whole"), out = freshDir("mpi_cracks_stopped");
  ASSERT_EQ(runCommand(mpirun(2) + args + " -o " + whole.string()).code, 0);
  stopAtFrame(args, out, "frame_00002.ply");  // 0.04 s: cracks from 0.032 s on
  ASSERT_TRUE(fs::exists(out / "checkpoint.snowsim")) << "stopped without a checkpoint";
  ASSERT_FALSE(fs::exists(out / "frame_00020.ply")) << "the run ended before the signal";
  const auto stopped = summaryOf(out);
  EXPECT_EQ(stopped["interrupted_by_signal"], SIGTERM);
  const auto stages = stopped["stages"];
  EXPECT_TRUE(std::any_of(stages.begin(), stages.end(), [](const auto& s) {
    return s["stage"] == "crack: scatter";
  })) << "stopped before the snow cracked";
  const auto resumed = runCommand(mpirun(2) + " resume " + out.string());
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  EXPECT_EQ(frames(out), frames(whole));
  EXPECT_EQ(summaryOf(out)["steps"], summaryOf(whole)["steps"]);
}

// OpenMPI 4's mpirun kills the ranks 1 s after passing a stop on unless given more: a run across
// ranks warns of it once, and says nothing once mpirun is given the setting.
TEST(Mpi, WarnsWhenMpirunWouldKillTheRanksBeforeTheirCheckpoint) {
  std::ifstream system_file("/etc/openmpi/openmpi-mca-params.conf");
  for (std::string line; std::getline(system_file, line);)
    if (line.rfind("odls_base_sigkill_timeout", 0) == 0)
      GTEST_SKIP() << "this machine's OpenMPI sets odls_base_sigkill_timeout for every mpirun";
  const fs::path out = freshDir("mpi_kill_timeout");
  // No setting in the environment or in a parameter file of the user's.
  const std::string bare_env =
      "env -u OMPI_MCA_odls_base_sigkill_timeout HOME=" + out.parent_path().string() + " ";
  const std::string args = " run " + kScene + " -o " + out.string() + kShort + " --overwrite";
  const std::string advice = "launch it with --mca odls_base_sigkill_timeout 15";
  const auto bare = runCommand(bare_env + mpirun(2) + args);
  EXPECT_EQ(bare.code, 0) << bare.output;
  const size_t warned = bare.output.find(advice);
  ASSERT_NE(warned, std::string::npos) << bare.output;
  EXPECT_EQ(bare.output.find(advice, warned + 1), std::string::npos) << "rank 0 alone warns";
  const auto given =
      runCommand(bare_env + "OMPI_MCA_odls_base_sigkill_timeout=15 " + mpirun(2) + args);
  EXPECT_EQ(given.code, 0) << given.output;
  EXPECT_EQ(given.output.find(advice), std::string::npos) << given.output;
}

// What is not distributed is refused with a message, before anything is written.
TEST(Mpi, RefusesWhatIsNotDistributed) {
  const fs::path out = freshDir("mpi_refused");
  const auto implicit = runCommand(mpirun(2) + " run " + kScene + " -o " + out.string() +
                                   " --set mpm.integrator=semi_implicit");
  EXPECT_EQ(implicit.code, 2);
  EXPECT_NE(implicit.output.find("only \"explicit\" is distributed"), std::string::npos)
      << implicit.output;
  EXPECT_FALSE(fs::exists(out)) << "refused after making the output directory";
  // Bad input every rank meets alike is told once, by rank 0.
  const auto missing = runCommand(mpirun(2) + " run " + kScene + ".missing -o " + out.string());
  EXPECT_EQ(missing.code, 2);
  const size_t told = missing.output.find("File does not exist");
  ASSERT_NE(told, std::string::npos) << missing.output;
  EXPECT_EQ(missing.output.find("File does not exist", told + 1), std::string::npos)
      << missing.output;
}

// A failure rank 0 meets alone (frame 2's PLY goes to /dev/full) ends every rank at once with the
// exit code of one process, instead of leaving the others waiting in their next exchange; the
// earlier frames stay complete.
TEST(Mpi, AnErrorOfOneRankEndsEveryRank) {
  const fs::path out = freshDir("mpi_full_disk");
  fs::create_directories(out);
  fs::create_symlink("/dev/full", out / "frame_00002.ply.tmp");
  const auto run =
      runCommand("timeout 120 " + mpirun(2) + " run " + kScene + " -o " + out.string() + kShort);
  EXPECT_EQ(run.code, 2) << run.output;
  EXPECT_NE(run.output.find("frame_00002.ply: writing failed"), std::string::npos) << run.output;
  EXPECT_TRUE(fs::exists(out / "frame_00001.ply"));
  EXPECT_FALSE(fs::exists(out / "frame_00002.ply"));
}

}  // namespace
