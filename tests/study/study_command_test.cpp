// snowsim study --quick: the CSV has its columns, every unstable configuration was caught
// (status, not NaN), and a rerun by the same build measures nothing again.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tests/support/temp_dir.h"

namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  std::string field;
  while (std::getline(in, field, ',')) fields.push_back(field);
  if (!line.empty() && line.back() == ',') fields.push_back("");
  return fields;
}

TEST(StudyCommand, QuickPresetWritesCaughtRowsAndSkipsOnRerun) {
  const auto dir = snowsim_test::processTempDir() / "study";
  std::filesystem::remove_all(dir);
  const std::string csv = (dir / "results.csv").string();
  const std::string command = std::string(SNOWSIM_BINARY) + " study --quick --scenes " +
                              SNOWSIM_SOURCE_DIR + "/scenes -o " + csv;
  ASSERT_EQ(std::system((command + " > " + (dir.string() + ".log")).c_str()), 0);

  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  const auto header = split(line);
  const std::vector<std::string> expected = {"build",           "scene",
                                             "solver",          "dt",
                                             "refine",          "particles_per_cell",
                                             "duration",        "E0",
                                             "cell_size",       "status",
                                             "wall_s",          "steps",
                                             "particles",       "err_density",
                                             "err_height_m",    "err_com_m",
                                             "free_fall_err_m", "ball_past_tower_m",
                                             "pile_height_m",   "claim",
                                             "message"};
  ASSERT_EQ(header, expected);
  int rows = 0, finished = 0;
  while (std::getline(in, line)) {
    ++rows;
    EXPECT_EQ(line.find("nan"), std::string::npos) << line;
    EXPECT_EQ(line.find("inf"), std::string::npos) << line;
    const auto f = split(line);
    ASSERT_EQ(f.size(), expected.size()) << line;
    const std::string &scene = f[1], &solver = f[2], &dt = f[3], &status = f[9];
    const std::string& claim = f[19];
    EXPECT_TRUE(status == "finished" || status == "diverged" || status == "escaped" ||
                status == "tunnelled" || status == "nan")
        << status;
    // The Fig. 6 claim's runs are scored only, not compared with a reference.
    const bool against_reference = scene.rfind("critical_density", 0) != 0;
    if (status == "finished") {
      ++finished;
      ASSERT_EQ(f[13].empty(), !against_reference) << line;
      if (against_reference) {
        EXPECT_GE(std::stod(f[13]), 0.0);
      }
    }
    if (status == "diverged" || status == "nan") {
      EXPECT_TRUE(f[13].empty()) << line;
    }
    // What the stability map measured (docs/study.md): explicit MPM beyond its CFL limit (about
    // 5e-4 s here) and the semi-implicit solver at 0.01 s (advection) must be caught, not
    // written out; the report's method lets the thrown ball through the tower at 0.01 s.
    std::string want = "finished";
    if (solver == "mpm_mls" && dt != "0.0002") want = "diverged";
    if (solver == "mpm_apic_semi" && dt == "0.01") want = "diverged";
    if (solver == "density_hybrid" && dt == "0.01" && scene == "column_thrown_ball")
      want = "tunnelled";
    EXPECT_EQ(status, want) << line;
    // The report's claims: the thrown ball stays outside the tower (fails when it tunnels), and
    // its Fig. 6 pile heights x2 > x4 > x8, scored on the x8 row, hold at dt 0.001.
    if (scene == "column_thrown_ball" && status != "diverged")
      EXPECT_EQ(claim, status == "tunnelled" ? "fail" : "pass") << line;
    else if (scene == "critical_density_x8")
      EXPECT_EQ(claim, "pass") << line;
    else
      EXPECT_EQ(claim, "") << line;
  }
  EXPECT_EQ(rows, 21);
  EXPECT_EQ(finished, 14);

  // A rerun by the same build finds everything measured.
  ASSERT_EQ(std::system((command + " > " + (dir.string() + ".log")).c_str()), 0);
  std::ifstream log(dir.string() + ".log");
  std::stringstream text;
  text << log.rdbuf();
  EXPECT_NE(text.str().find("0 runs measured, 21 already measured"), std::string::npos)
      << text.str();
}

// The axes preset's crack axis (mpm_mls_cracks) runs every scene and step of the plain one with
// cracks that open: the same runs diverge, and every run that finishes ends elsewhere than the
// plain run, so the cracks took part.
TEST(StudyCommand, AxesPresetRunsTheCrackAxisBesideThePlainOne) {
  const auto dir = snowsim_test::processTempDir() / "study_axes";
  std::filesystem::remove_all(dir);
  const std::string csv = (dir / "axes.csv").string();
  const std::string command = std::string(SNOWSIM_BINARY) + " study --preset axes --scenes " +
                              SNOWSIM_SOURCE_DIR + "/scenes -o " + csv;
  ASSERT_EQ(std::system((command + " > " + (dir.string() + ".log")).c_str()), 0);
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  std::map<std::string, std::vector<std::string>> plain, cracks;  // by scene and dt
  while (std::getline(in, line)) {
    const auto f = split(line);
    if (f[2] == "mpm_mls") plain[f[1] + " " + f[3]] = f;
    if (f[2] == "mpm_mls_cracks") cracks[f[1] + " " + f[3]] = f;
  }
  ASSERT_EQ(cracks.size(), 8u);
  ASSERT_EQ(plain.size(), cracks.size());
  int finished = 0;
  for (const auto& [run, f] : cracks) {
    ASSERT_TRUE(plain.count(run)) << run;
    const auto& p = plain[run];
    EXPECT_EQ(f[9], p[9]) << run;  // the status
    if (f[9] != "finished") continue;
    ++finished;
    EXPECT_NE(f[13], p[13]) << run << ": the density error of the plain run";
    EXPECT_NE(f[15], p[15]) << run << ": the centre of mass error of the plain run";
  }
  EXPECT_EQ(finished, 5);
}

}  // namespace

namespace {

long stepsOfRun(const std::string& arguments) {
  const auto dir = snowsim_test::processTempDir() / "quality";
  std::filesystem::remove_all(dir);
  const std::string command = std::string(SNOWSIM_BINARY) + " run " + SNOWSIM_SOURCE_DIR +
                              "/scenes/snowball_drop.json --no-png --no-ply --no-mp4 -o " +
                              dir.string() + " " + arguments + " 2>/dev/null";
  if (std::system(command.c_str()) != 0) return -1;
  std::ifstream in(dir / "run.json");
  // The run's own steps, not a field of the same name in its scene (mpm.auto_sleep.steps).
  const nlohmann::json run = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  return run.contains("steps") ? run["steps"].get<long>() : -2;
}

TEST(QualityOption, PicksTheTimeStepAndLetsSetOverrideIt) {
  EXPECT_EQ(stepsOfRun("--quality draft"), 500);       // dt 0.002 over 1 s
  EXPECT_EQ(stepsOfRun("--quality reference"), 5000);  // dt 0.0002
  EXPECT_EQ(stepsOfRun("--quality draft --set time.dt=0.01"), 100);
  EXPECT_EQ(stepsOfRun("--quality bogus"), -1);
  // MPM scenes get explicit MLS at the adaptive step: the same CFL step for draft and figure
  // (the particle count differs), and more than twice the steps at the reference level's half
  // cell size and C = 0.5.
  const long mpm_draft = stepsOfRun("--set solver=mpm --quality draft");
  const long mpm_figure = stepsOfRun("--set solver=mpm --quality figure");
  const long mpm_reference = stepsOfRun("--set solver=mpm --quality reference");
  EXPECT_GT(mpm_draft, 1000);  // the CFL step of E0 = 1.4e5 Pa snow on 1 cm cells is ~0.5 ms
  EXPECT_NEAR(mpm_figure, mpm_draft, 0.2 * mpm_draft);
  EXPECT_GT(mpm_reference, 3 * mpm_figure);
}

}  // namespace

namespace {

// run.json of a short MPM run of the snowball drop on a grid of 30x36 cells of a third of a
// centimetre (the same domain), or null when the run fails.
nlohmann::json thirdCentimetreRun(const std::string& arguments) {
  const auto dir = snowsim_test::processTempDir() / "quality_cells";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  auto scene = nlohmann::json::parse(
      std::ifstream(std::string(SNOWSIM_SOURCE_DIR) + "/scenes/snowball_drop.json"));
  scene["solver"] = "mpm";
  scene["grid"] = {{"cells", {30, 36}}, {"cell_size", 0.01 / 3}};
  std::ofstream(dir / "scene.json") << scene.dump();
  const std::string command = std::string(SNOWSIM_BINARY) + " run " +
                              (dir / "scene.json").string() +
                              " --no-png --no-ply --no-mp4 --set time.duration=0.002 -o " +
                              (dir / "out").string() + " " + arguments + " 2>/dev/null";
  if (std::system(command.c_str()) != 0) return nullptr;
  return nlohmann::json::parse(std::ifstream(dir / "out" / "run.json"));
}

// The reference level's half cell size is exact: never a number written out and read back.
TEST(QualityOption, ReferenceHalvesTheCellSizeExactlyUnlessSetGivesIt) {
  const double h = 0.01 / 3;
  const auto as_written = thirdCentimetreRun("");
  ASSERT_FALSE(as_written.is_null());
  EXPECT_EQ(as_written["cell_size"].get<double>(), h);
  const auto reference = thirdCentimetreRun("--quality reference");
  ASSERT_FALSE(reference.is_null());
  EXPECT_EQ(reference["cell_size"].get<double>(), h / 2);
  EXPECT_GT(reference["particles"].get<int>(), 3 * as_written["particles"].get<int>())
      << "twice the cells each way at 9 per cell";
  // The user's grid wins over the level's.
  char set[64];
  std::snprintf(set, sizeof set, "--set grid.cell_size=%.17g", h);
  const auto user = thirdCentimetreRun(std::string("--quality reference ") + set);
  ASSERT_FALSE(user.is_null());
  EXPECT_EQ(user["cell_size"].get<double>(), h);
}

}  // namespace
