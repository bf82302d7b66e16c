// A study split into shards: each shard runs a disjoint share, the merge joins them into the CSV
// one process writes (the same rows in the same order; only the wall times differ), and refuses
// runs found twice or missing. The OpenMPI launcher and the Slurm script run the same shards.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/run_snowsim.h"

namespace {

using snowsim_test::freshDir;
using snowsim_test::runCommand;
using snowsim_test::runSnowsim;

const std::string kScenes = std::string(" --scenes ") + SNOWSIM_SOURCE_DIR + "/scenes";

std::string fileText(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

// The CSV's rows with the wall time (the 11th field), the one column a rerun changes, blanked.
std::vector<std::string> withoutWallTimes(const std::string& csv) {
  std::vector<std::string> rows = lines(csv);
  for (std::string& row : rows) {
    size_t start = 0;
    for (int field = 0; field < 10; ++field) start = row.find(',', start) + 1;
    row.erase(start, row.find(',', start) - start);
  }
  return rows;
}

std::string quickStudy(const std::filesystem::path& csv, const std::string& arguments) {
  const auto result = runSnowsim("study --quick" + kScenes + " -o " + csv.string() + arguments);
  EXPECT_EQ(result.code, 0) << result.output;
  return fileText(csv);
}

TEST(StudyShards, RejectAShardOutOfRange) {
  for (const std::string shard : {"0/2", "3/2", "2", "a/b", "1/2x", "1/0"}) {
    const auto result = runSnowsim("study --quick --shard " + shard + kScenes + " -o /dev/null");
    EXPECT_NE(result.code, 0) << shard;
    EXPECT_NE(result.output.find("--shard"), std::string::npos) << result.output;
    EXPECT_NE(result.output.find("1 <= i <= n"), std::string::npos) << result.output;
  }
}

// The rows of a study CSV whose time step (the 4th field) is dt.
int rowsAtStep(const std::string& csv, const std::string& dt) {
  int count = 0;
  for (const std::string& row : lines(csv)) {
    size_t start = 0;
    for (int field = 0; field < 3; ++field) start = row.find(',', start) + 1;
    count += row.substr(start, row.find(',', start) - start) == dt;
  }
  return count;
}

TEST(StudyShards, MergedShardsAreTheOneProcessStudy) {
  const auto dir = freshDir("study_shards");
  std::filesystem::create_directories(dir);
  const std::string whole = quickStudy(dir / "whole.csv", "");
  std::string shards;
  size_t shard_rows = 0;
  for (int shard = 1; shard <= 3; ++shard) {
    const auto csv = dir / ("shard" + std::to_string(shard) + ".csv");
    const std::string text = quickStudy(csv, " --shard " + std::to_string(shard) + "/3");
    shard_rows += lines(text).size() - 1;
    // The costly runs are shared out: dealt round-robin, the quick preset's three time steps would
    // give one shard every run at the smallest.
    EXPECT_GE(rowsAtStep(text, "0.0002"), 1) << text;
    EXPECT_LT(rowsAtStep(text, "0.0002"), rowsAtStep(whole, "0.0002")) << text;
    shards += " " + csv.string();
  }
  EXPECT_EQ(shard_rows, lines(whole).size() - 1);

  auto result =
      runSnowsim("study --quick --merge" + shards + " -o " + (dir / "merged.csv").string());
  ASSERT_EQ(result.code, 0) << result.output;
  EXPECT_EQ(withoutWallTimes(fileText(dir / "merged.csv")), withoutWallTimes(whole));

  // One shard of one is the whole study, and merging it changes no byte.
  result = runSnowsim("study --quick --merge " + (dir / "whole.csv").string() + " -o " +
                      (dir / "whole_merged.csv").string());
  ASSERT_EQ(result.code, 0) << result.output;
  EXPECT_EQ(fileText(dir / "whole_merged.csv"), whole);

  // A rerun of a shard resumes it: nothing is measured again, nothing is added.
  const std::string second = fileText(dir / "shard2.csv");
  const size_t second_rows = lines(second).size() - 1;
  result =
      runSnowsim("study --quick --shard 2/3" + kScenes + " -o " + (dir / "shard2.csv").string());
  EXPECT_NE(result.output.find("0 runs measured, " + std::to_string(second_rows) + " already"),
            std::string::npos)
      << result.output;
  EXPECT_EQ(fileText(dir / "shard2.csv"), second);

  // A run in two shards, a missing shard, an existing output: refused, nothing written.
  result = runSnowsim("study --quick --merge" + shards + " " + (dir / "shard1.csv").string() +
                      " -o " + (dir / "twice.csv").string());
  EXPECT_NE(result.code, 0);
  EXPECT_NE(result.output.find("is in both"), std::string::npos) << result.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "twice.csv"));
  result = runSnowsim("study --quick --merge " + (dir / "shard1.csv").string() + " " +
                      (dir / "shard3.csv").string() + " -o " + (dir / "half.csv").string());
  EXPECT_NE(result.code, 0);
  EXPECT_NE(
      result.output.find(std::to_string(second_rows) + " runs of preset quick are in no shard"),
      std::string::npos)
      << result.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "half.csv"));
  result = runSnowsim("study --quick --merge" + shards + " -o " + (dir / "merged.csv").string());
  EXPECT_NE(result.code, 0);
  EXPECT_NE(result.output.find("exists"), std::string::npos) << result.output;
  // Rows of another preset are not this preset's.
  result = runSnowsim("study --preset stability --merge" + shards + " -o " +
                      (dir / "other.csv").string());
  EXPECT_NE(result.code, 0);
  EXPECT_NE(result.output.find("does not have"), std::string::npos) << result.output;

  // The OpenMPI launcher: two ranks, each its shard, then the merge.
  if (runCommand("command -v mpirun").code != 0) GTEST_SKIP() << "mpirun is not installed";
  result = runCommand(std::string("OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 ") +
                      "MPIRUN_ARGS=--oversubscribe SNOWSIM=" + SNOWSIM_BINARY + " " +
                      SNOWSIM_SOURCE_DIR + "/scripts/mpirun_study.sh 2 " +
                      (dir / "launched.csv").string() + " --quick" + kScenes);
  ASSERT_EQ(result.code, 0) << result.output;
  EXPECT_EQ(withoutWallTimes(fileText(dir / "launched.csv")), withoutWallTimes(whole));
  EXPECT_TRUE(std::filesystem::exists(dir / "launched.shards" / "shard-2-of-2.csv"));
}

// Slurm is not installed here: a stand-in sbatch records what the script submits, and a stand-in
// snowsim what an array task runs.
TEST(StudyShards, SlurmScriptSubmitsAnArrayAndADependentMerge) {
  const auto dir = freshDir("study_slurm");
  std::filesystem::create_directories(dir / "bin");
  const auto sbatch = dir / "bin" / "sbatch";
  std::ofstream(sbatch) << "#!/bin/sh\necho \"$@\" >> " << (dir / "sbatch.log").string()
                        << "\necho 4242\n";
  std::filesystem::permissions(sbatch, std::filesystem::perms::owner_all);
  const std::string script = std::string(SNOWSIM_SOURCE_DIR) + "/scripts/slurm_study.sh";
  // Without sbatch: a message, and nothing made.
  auto result = runCommand("SBATCH=" + (dir / "bin" / "no-sbatch").string() + " " + script + " 3 " +
                           (dir / "none.csv").string());
  EXPECT_EQ(result.code, 2) << result.output;
  EXPECT_NE(result.output.find("sbatch not found"), std::string::npos) << result.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "none.shards"));
  result = runCommand("PATH=" + (dir / "bin").string() +
                      ":$PATH SNOWSIM=/opt/snowsim SBATCH_ARGS='--partition=short --time=1:00' " +
                      script + " 3 " + (dir / "out.csv").string() + " --preset full");
  ASSERT_EQ(result.code, 0) << result.output;
  const auto submitted = lines(fileText(dir / "sbatch.log"));
  ASSERT_EQ(submitted.size(), 2u);
  EXPECT_NE(submitted[0].find("--array=1-3 " + script), std::string::npos) << submitted[0];
  for (const std::string& line : submitted)
    EXPECT_EQ(line.find("--partition=short --time=1:00 --parsable"), 0u) << line;
  EXPECT_NE(submitted[1].find("--dependency=afterok:4242"), std::string::npos) << submitted[1];
  const std::string shards = (dir / "out.shards").string();
  EXPECT_NE(submitted[1].find("/opt/snowsim study --preset full --merge " + shards +
                              "/shard-1-of-3.csv " + shards + "/shard-2-of-3.csv " + shards +
                              "/shard-3-of-3.csv -o " + (dir / "out.csv").string()),
            std::string::npos)
      << submitted[1];

  // A stand-in snowsim prints the threads it was given and its command line.
  const auto snowsim = dir / "bin" / "snowsim";
  std::ofstream(snowsim) << "#!/bin/sh\necho \"threads $OMP_NUM_THREADS: $*\"\n";
  std::filesystem::permissions(snowsim, std::filesystem::perms::owner_all);
  result =
      runCommand("SLURM_ARRAY_TASK_ID=2 SLURM_ARRAY_TASK_COUNT=3 SLURM_CPUS_PER_TASK=4 SNOWSIM=" +
                 snowsim.string() + " " + script + " " + shards + " --preset full");
  ASSERT_EQ(result.code, 0) << result.output;
  EXPECT_EQ(result.output,
            "threads 4: study --shard 2/3 -o " + shards + "/shard-2-of-3.csv --preset full\n");
}

}  // namespace
