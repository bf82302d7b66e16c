// PLY frames round-trip every field and fail clearly on files they did not write.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "sim/core/errors.h"
#include "sim/io/ply.h"
#include "tests/support/temp_dir.h"

namespace snowsim {
namespace {

std::filesystem::path tempDir() {
  auto dir = snowsim_test::processTempDir() / "ply";
  std::filesystem::create_directories(dir);
  return dir;
}

Snapshot sample(bool with_plastic) {
  Snapshot s;
  s.frame = 7;
  s.time = 0.14;
  s.grid.dimension = 2;
  s.grid.cells = {3, 2, 1};
  s.grid.cell_size = 0.01;
  s.grid.particle_spacing = 0.01 / 3;
  s.grid.critical_density = 123.5;
  s.grid.node_density = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
  for (int i = 0; i < 5; ++i) {
    s.position.push_back({0.01f * i, 0.02f, 0});
    s.velocity.push_back({-1.0f * i, 0.5f, 0});
    s.density.push_back(100.0f + i);
    if (with_plastic) s.plastic_j.push_back(0.9f + 0.01f * i);
    s.mass.push_back(1e-3f * (i + 1));
    s.radius.push_back(0.002f);
  }
  return s;
}

TEST(Ply, RoundTripsEveryField) {
  for (bool with_plastic : {false, true}) {
    const Snapshot s = sample(with_plastic);
    const std::string path = (tempDir() / "frame.ply").string();
    writePly(path, s);
    EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
    const Snapshot r = readPly(path);
    EXPECT_EQ(r.frame, s.frame);
    EXPECT_DOUBLE_EQ(r.time, s.time);
    EXPECT_EQ(r.grid.dimension, 2);
    EXPECT_EQ(r.grid.cells, s.grid.cells);
    EXPECT_DOUBLE_EQ(r.grid.cell_size, s.grid.cell_size);
    EXPECT_DOUBLE_EQ(r.grid.particle_spacing, s.grid.particle_spacing);
    EXPECT_DOUBLE_EQ(r.grid.critical_density, s.grid.critical_density);
    EXPECT_EQ(r.grid.node_density, s.grid.node_density);
    EXPECT_EQ(r.position, s.position);
    EXPECT_EQ(r.velocity, s.velocity);
    EXPECT_EQ(r.density, s.density);
    EXPECT_EQ(r.plastic_j, s.plastic_j);
    EXPECT_EQ(r.mass, s.mass);
    EXPECT_EQ(r.radius, s.radius);
  }
}

TEST(Ply, ZUpFramesReadBackInTheScenesAxes) {
  Snapshot s = sample(true);
  s.position[1] = {0.1f, 0.2f, 0.3f};
  s.velocity[1] = {-1.f, 2.f, -3.f};
  const std::string path = (tempDir() / "z_up.ply").string();
  writePly(path, s, UpAxis::Z);
  const Snapshot r = readPly(path);
  EXPECT_EQ(r.position, s.position);
  EXPECT_EQ(r.velocity, s.velocity);
}

// Another tool's PLY: any scalar types, columns in any order, no snowsim comments.
TEST(Ply, ParticlesFromAnotherToolsFile) {
  const std::string path = (tempDir() / "foreign.ply").string();
  {
    std::ofstream out(path, std::ios::binary);
    out << "ply\nformat binary_little_endian 1.0\ncomment from elsewhere\nelement vertex 2\n"
        << "property double vx\nproperty double vy\nproperty double vz\nproperty uchar red\n"
        << "property float x\nproperty float y\nproperty float z\nend_header\n";
    for (int i = 0; i < 2; ++i) {
      const double v[3] = {1.0 + i, 2.0, 3.0};
      const unsigned char red = 200;
      const float x[3] = {0.25f * i, 0.5f, 0.75f};
      out.write(reinterpret_cast<const char*>(v), sizeof v);
      out.write(reinterpret_cast<const char*>(&red), 1);
      out.write(reinterpret_cast<const char*>(x), sizeof x);
    }
  }
  EXPECT_THROW(readPly(path), InputError) << "not a frame snowsim can draw";
  const Snapshot r = readPly(path, PlyContent::Particles);
  ASSERT_EQ(r.size(), 2);
  EXPECT_EQ(r.position[1], (std::array<float, 3>{0.25f, 0.5f, 0.75f}));
  EXPECT_EQ(r.velocity[1], (std::array<float, 3>{2.f, 2.f, 3.f}));
  EXPECT_TRUE(r.mass.empty() && r.plastic_j.empty());
}

TEST(Ply, HeaderIsStandardBinaryPly) {
  const std::string path = (tempDir() / "header.ply").string();
  writePly(path, sample(false));
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "ply");
  std::getline(in, line);
  EXPECT_EQ(line, "format binary_little_endian 1.0");
  const auto size = std::filesystem::file_size(path);
  EXPECT_GT(size, 5u * 7u * 4u + 12u * 4u);
}

TEST(Ply, ForeignOrTruncatedFilesAreRejected) {
  const std::string path = (tempDir() / "bad.ply").string();
  std::ofstream(path) << "solid cube\n";
  EXPECT_THROW(readPly(path), InputError);
  writePly(path, sample(false));
  std::filesystem::resize_file(path, std::filesystem::file_size(path) - 10);
  try {
    readPly(path);
    FAIL() << "a truncated file was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("shorter than its header says"), std::string::npos);
  }
  EXPECT_THROW(readPly((tempDir() / "missing.ply").string()), InputError);
}

TEST(Ply, UnwritablePathIsAnInputError) {
  EXPECT_THROW(writePly("/proc/snowsim/frame.ply", sample(false)), InputError);
}

}  // namespace
}  // namespace snowsim
