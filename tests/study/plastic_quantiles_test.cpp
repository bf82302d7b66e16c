// scripts/plastic_quantiles.py: J_P at quantiles of the mass of a frame, as docs/snow-at-scale.md
// compares runs by; a file that is not a frame prints no row and fails.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "sim/core/snapshot.h"
#include "sim/io/ply.h"
#include "tests/support/run_snowsim.h"

namespace {

using snowsim_test::freshDir;
using snowsim_test::runCommand;

const std::string kScript =
    std::string("python3 ") + SNOWSIM_SOURCE_DIR + "/scripts/plastic_quantiles.py ";

TEST(PlasticQuantiles, WeighsEachParticleByItsMass) {
  if (runCommand("command -v python3").code != 0) GTEST_SKIP() << "python3 is not installed";
  const auto dir = freshDir("plastic_quantiles");
  std::filesystem::create_directories(dir);
  snowsim::Snapshot frame;
  frame.grid.dimension = 3;
  // Counted by particles the median would lie at 0.8 or 1.0; by mass it is the heavy one's 1.2.
  const float plastic_j[] = {1.2f, 0.6f, 1.0f, 0.8f};
  const float mass[] = {97, 1, 1, 1};
  for (int p = 0; p < 4; ++p) {
    frame.position.push_back({0.01f * p, 0, 0});
    frame.velocity.push_back({0, 0, 0});
    frame.density.push_back(400);
    frame.plastic_j.push_back(plastic_j[p]);
    frame.mass.push_back(mass[p]);
    frame.radius.push_back(0.002f);
  }
  const std::string ply = (dir / "frame_00000.ply").string();
  snowsim::writePly(ply, frame);

  const auto result = runCommand(kScript + ply);
  ASSERT_EQ(result.code, 0) << result.output;
  EXPECT_EQ(result.output, "frame,J_P_1pct,J_P_10pct,J_P_50pct,J_P_90pct,J_P_99pct\n" + ply +
                               ",0.6000,1.2000,1.2000,1.2000,1.2000\n");

  const auto bad = runCommand(kScript + ply + " " + SNOWSIM_SOURCE_DIR + "/README.md");
  EXPECT_NE(bad.code, 0);
  EXPECT_EQ(bad.output.find("frame,"), std::string::npos) << bad.output;
  EXPECT_NE(bad.output.find("README.md: not a PLY file"), std::string::npos) << bad.output;
}

}  // namespace
