// The memory a run will need: said before it allocates, a run that cannot fit refused, and an
// allocation that fails all the same said plainly, with no lock or partial file left behind.
#include <gtest/gtest.h>

#include <sys/resource.h>
#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <optional>
#include <regex>
#include <string>

#include "app/memory_budget.h"
#include "sim/core/errors.h"
#include "sim/scene/resolve_scene.h"
#include "sim/scene/sampling.h"
#include "tests/support/run_snowsim.h"

namespace {

namespace fs = std::filesystem;

using snowsim_test::freshDir;
using snowsim_test::Result;
using snowsim_test::runCommand;
using snowsim_test::runSnowsim;
using snowsim_test::scene;

// snowsim ARGS under a limit of `kib` KiB of address space, as `ulimit -v` sets it.
Result runSnowsimWithin(long kib, const std::string& args) {
  return runCommand("ulimit -v " + std::to_string(kib) + "; " + SNOWSIM_BINARY + " " + args);
}

// The peak in MiB of the memory line "NAME: memory: about 412 MiB at its peak (...)".
double estimatedMib(const std::string& output) {
  std::smatch m;
  if (!std::regex_search(output, m,
                         std::regex(R"(memory: about ([0-9.]+) (MiB|GiB|TiB) at its peak)")))
    return -1;
  return std::stod(m[1]) * (m[2] == "TiB" ? 1 << 20 : m[2] == "GiB" ? 1 << 10 : 1);
}

// The files a run left in its directory whose names say they were never finished.
std::vector<std::string> unfinishedFiles(const fs::path& dir) {
  std::vector<std::string> names;
  if (!fs::exists(dir)) return names;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name == ".snowsim.lock" || name.ends_with(".part") || name.ends_with(".tmp"))
      names.push_back(name);
  }
  return names;
}

// The count the estimate takes is the count the run samples: exactly for lattice, jittered,
// mesh and points bodies, within a few percent for a Poisson-disk body (by its lattice).
TEST(ParticleCount, IsWhatTheBodiesSample) {
  const auto sampled = [](const snowsim::Scene& s) {
    return s.dimension == 2 ? long(snowsim::sampleBodies<2>(s).size())
                            : long(snowsim::sampleBodies<3>(s).size());
  };
  for (const auto& [name, sets] : std::vector<std::pair<std::string, std::vector<std::string>>>{
           {"snowball_drop", {}},
           {"column_thrown_ball", {}},
           {"mpm_snowball_drop_3d", {}},
           {"mpm_snowball_drop_3d", {"bodies[0].seeding=jittered"}},
           {"mesh_snow_drop", {}}}) {
    const snowsim::Scene s = snowsim::resolveScene(scene(name), {sets, "", 1});
    EXPECT_EQ(snowsim::countBodyParticles(s), sampled(s)) << name;
  }
  const snowsim::Scene poisson =
      snowsim::resolveScene(scene("mpm_snowball_drop_3d"), {{"bodies[0].seeding=poisson"}, "", 1});
  const double ratio = double(snowsim::countBodyParticles(poisson)) / double(sampled(poisson));
  EXPECT_NEAR(ratio, 1, 0.05);
}

// --estimate on runs far too large for the machine builds none of their arrays: under a limit of
// 1 GB of address space it still says their memory and the time of their first steps, measured
// on the scene at a coarser resolution, and writes nothing.
TEST(Memory, EstimateOfAHugeRunAllocatesLittle) {
  const fs::path out = freshDir("huge_estimate");
  const std::string run = "run " + scene("flagship/smash_wall") + " -o " + out.string();
  for (const std::string huge : {"--scale 6", "--set 'grid.cells=[256,256,256]'"}) {
    const Result r = runSnowsimWithin(1000000, run + " --estimate " + huge);
    ASSERT_EQ(r.code, 0) << huge << ": " << r.output;
    EXPECT_GT(estimatedMib(r.output), 1024) << huge << ": " << r.output;
    EXPECT_NE(r.output.find("timing its first steps at"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("estimate: the steps take about"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out)) << huge;
  }
  // 4096^3 cells need terabytes, and more nodes than a grid indexes, which --estimate says; at a
  // resolution small enough to build, the ball is a particle or two: its steps are not timed.
  const Result r =
      runSnowsimWithin(1000000, run + " --estimate --set 'grid.cells=[4096,4096,4096]'");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_GT(estimatedMib(r.output), 1 << 20) << r.output;
  EXPECT_NE(r.output.find("warning: flagship_smash_wall: grid.cells make"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("its steps are not timed"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out));
  // A run of it is refused, whatever --max-memory allows: its grid has more nodes than it indexes.
  const Result refused =
      runSnowsim(run + " --max-memory 1000T --set 'grid.cells=[4096,4096,4096]'");
  EXPECT_EQ(refused.code, 2) << refused.output;
  EXPECT_NE(refused.output.find("grid.cells make 68971442301 grid nodes (the ghost layers "
                                "included), more than the 2147483647 a grid holds"),
            std::string::npos)
      << refused.output;
  EXPECT_FALSE(fs::exists(out));
}

// The estimate of a run against its peak resident size, read from the finished child process.
TEST(Memory, EstimateIsNearThePeakOfTheRun) {
  const fs::path out = freshDir("peak");
  fs::create_directories(out);
  const std::string log = (out / "log").string();
  const pid_t child = snowsim_test::startSnowsim(
      {"run", scene("mpm_snowball_drop_3d"), "-o", (out / "run").string(), "--no-png", "--no-mp4",
       "--no-ply", "--threads", "1", "--set", "particles_per_cell=216", "--set",
       "time.duration=0.01"},
      log);
  int status = 0;
  rusage usage{};
  ASSERT_EQ(wait4(child, &status, 0, &usage), child);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << snowsim_test::bytesOf(log);
  const double peak_mib = usage.ru_maxrss / 1024.0;  // KiB
  const double estimate = estimatedMib(snowsim_test::bytesOf(log));
  EXPECT_NEAR(estimate / peak_mib, 1, 0.25)
      << estimate << " MiB estimated, " << peak_mib << " MiB at the peak";
}

// --max-memory below what the run needs refuses it before anything is written, with both figures.
TEST(Memory, RunThatCannotFitIsRefused) {
  const fs::path out = freshDir("refused");
  const Result r =
      runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() + " --max-memory 1M");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("more than --max-memory 1M (1 MiB); refused before it allocates"),
            std::string::npos)
      << r.output;
  EXPECT_GT(estimatedMib(r.output), 1) << r.output;
  EXPECT_NE(r.output.find("snowball_drop: the run needs about "), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out)) << "nothing is written for a run that cannot fit";
  // Enough memory: it runs.
  const Result fits = runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                                 " --max-memory 8G --no-png --no-mp4 --set time.duration=0.01");
  EXPECT_EQ(fits.code, 0) << fits.output;
}

// Without --max-memory, the memory the machine has free bounds a run: 1280^3 cells need more
// than 64 GiB.
TEST(Memory, RunThatCannotFitTheMachineIsRefused) {
  const std::optional<double> available = snowsim::availableMemory();
  ASSERT_TRUE(available.has_value());
  if (*available > 64.0 * (1 << 30)) GTEST_SKIP() << "this machine has the memory for it";
  const fs::path out = freshDir("refused_by_the_machine");
  const Result r = runSnowsim("run " + scene("flagship/smash_wall") + " -o " + out.string() +
                              " --set 'grid.cells=[1280,1280,1280]'");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("of memory available (MemAvailable); refused before it allocates"),
            std::string::npos)
      << r.output;
  EXPECT_GT(estimatedMib(r.output), 64 * 1024) << r.output;
  EXPECT_FALSE(fs::exists(out));
}

TEST(Memory, BadMaxMemoryIsRefusedNamingTheOption) {
  const fs::path out = freshDir("bad_max_memory");
  for (const std::string bad : {"12", "abc", "-5G", "0M", "1.5X", "8GB", "G", "nanM"}) {
    const Result r = runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                                " --max-memory '" + bad + "'");
    EXPECT_EQ(r.code, 2) << bad << ": " << r.output;
    EXPECT_NE(r.output.find("--max-memory " + bad +
                            ": allowed: a size such as 500M, 8G or 1.5T (K, M, G, T: powers of "
                            "1024)"),
              std::string::npos)
        << bad << ": " << r.output;
    EXPECT_FALSE(fs::exists(out)) << bad;
  }
  EXPECT_DOUBLE_EQ(snowsim::parseMemorySize("1.5G", "--max-memory"), 1.5 * (1 << 30));
  EXPECT_DOUBLE_EQ(snowsim::parseMemorySize("500m", "--max-memory"), 500.0 * (1 << 20));
  EXPECT_THROW(snowsim::parseMemorySize("500", "--max-memory"), snowsim::InputError);
}

// An allocation that fails all the same (here under a limit of address space that the memory
// available does not show) ends the run with exit code 5, saying what it was doing and what the
// run was estimated to need, and leaves no lock or partial file.
TEST(Memory, AllocationFailureIsSaidPlainly) {
  const fs::path out = freshDir("out_of_memory");
  const Result r =
      runSnowsimWithin(600000, "run " + scene("snowball_drop") + " -o " + out.string() +
                                   " --set solver=mpm --set 'grid.cells=[4096,2048]' --no-png "
                                   "--no-mp4");
  ASSERT_EQ(r.code, 5) << r.output;
  EXPECT_NE(r.output.find("snowsim: out of memory: snowball_drop: out of memory while building "
                          "the simulation: the run was estimated to need about "),
            std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("bad_alloc"), std::string::npos) << r.output;
  EXPECT_TRUE(unfinishedFiles(out).empty()) << unfinishedFiles(out).front();
}

}  // namespace
