// scripts/plastic_noise_ply.py: a frame turned into a points body of uneven strength, as
// docs/snow-at-scale.md ("Irregular seeding and uneven strength") starts runs from.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "sim/core/snapshot.h"
#include "sim/io/ply.h"
#include "tests/support/run_snowsim.h"

namespace {

using snowsim_test::freshDir;
using snowsim_test::runCommand;

const std::string kScript =
    std::string("python3 ") + SNOWSIM_SOURCE_DIR + "/scripts/plastic_noise_ply.py ";

std::string contents(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A row of particles 1 mm apart along x, each with its own velocity and mass.
snowsim::Snapshot rowOfParticles(int count) {
  snowsim::Snapshot frame;
  frame.grid.dimension = 3;
  frame.grid.cells = {100, 100, 100};
  frame.grid.cell_size = 0.01;
  frame.grid.particle_spacing = 0.005;
  for (int p = 0; p < count; ++p) {
    frame.position.push_back({0.1f + 0.001f * p, 0.2f, 0.3f});
    frame.velocity.push_back({1.0f * p, -2.0f, 0.5f});
    frame.density.push_back(400);
    frame.plastic_j.push_back(1);
    frame.mass.push_back(1e-5f * (p + 1));
    frame.radius.push_back(0.002f);
  }
  return frame;
}

TEST(PlasticNoisePly, KeepsTheParticlesAndSpreadsTheirPlasticJ) {
  if (runCommand("command -v python3").code != 0) GTEST_SKIP() << "python3 is not installed";
  const auto dir = freshDir("plastic_noise_ply");
  std::filesystem::create_directories(dir);
  const std::string in = (dir / "frame_00000.ply").string();
  const int count = 200;
  snowsim::writePly(in, rowOfParticles(count));
  const snowsim::Snapshot source = snowsim::readPly(in);

  const std::string uniform = (dir / "uniform.ply").string(), again = (dir / "again.ply").string(),
                    other = (dir / "other.ply").string(), lattice = (dir / "lattice.ply").string();
  ASSERT_EQ(runCommand(kScript + in + " " + uniform + " 0.05").code, 0);
  ASSERT_EQ(runCommand(kScript + in + " " + again + " 0.05").code, 0);
  ASSERT_EQ(runCommand(kScript + in + " " + other + " 0.05 0 2").code, 0);
  ASSERT_EQ(runCommand(kScript + in + " " + lattice + " 0.05 0.03").code, 0);
  EXPECT_EQ(contents(uniform), contents(again)) << "the same arguments give the same file";
  EXPECT_NE(contents(uniform), contents(other)) << "another seed, other noise";

  for (const std::string& path : {uniform, lattice}) {
    const snowsim::Snapshot body = snowsim::readPly(path, snowsim::PlyContent::Particles);
    ASSERT_EQ(body.position.size(), size_t(count)) << path;
    float low = 2, high = 0, largest_step = 0;
    for (int p = 0; p < count; ++p) {
      EXPECT_EQ(body.position[p], source.position[p]) << path << ", particle " << p;
      EXPECT_EQ(body.velocity[p], source.velocity[p]) << path << ", particle " << p;
      EXPECT_EQ(body.mass[p], source.mass[p]) << path << ", particle " << p;
      low = std::min(low, body.plastic_j[p]);
      high = std::max(high, body.plastic_j[p]);
      if (p > 0)
        largest_step = std::max(largest_step, std::abs(body.plastic_j[p] - body.plastic_j[p - 1]));
    }
    EXPECT_GE(low, 0.95f) << path;
    EXPECT_LE(high, 1.05f) << path;
    EXPECT_GT(high - low, 0.02f) << path << ": the noise spans its range";
    if (path == uniform)
      EXPECT_GT(largest_step, 0.02f) << "per particle: neighbours differ as much as any two";
    else  // trilinear over 3 cm: 1 mm apart, neighbours differ by at most 2 * 0.05 / 30
      EXPECT_LE(largest_step, 2 * 0.05f / 30 + 1e-6f) << "value noise: neighbours share it";
  }

  const auto bad = runCommand(kScript + in + " " + (dir / "bad.ply").string() + " 1.5");
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.output.find("AMPLITUDE must be in [0, 1)"), std::string::npos) << bad.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.ply"));
}

}  // namespace
