#include "app/png_writer.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "sim/errors.h"

namespace snowsim {
namespace {

Image gradient(int shade) {
  Image image;
  image.width = 40;
  image.height = 30;
  image.rgba.resize(40 * 30 * 4);
  for (size_t i = 0; i < image.rgba.size(); ++i)
    image.rgba[i] = static_cast<std::uint8_t>(i % 4 == 3 ? 255 : (i / 4 + shade) % 256);
  return image;
}

std::filesystem::path freshDirectory(const char* name) {
  const auto dir = std::filesystem::temp_directory_path() / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

TEST(BackgroundPngWriter, WritesEveryQueuedFrameExactly) {
  const auto dir = freshDirectory("snowsim_png_writer_test");
  BackgroundPngWriter writer(2);
  for (int f = 0; f < 12; ++f)  // more frames than the queue holds: write() must wait, not drop
    writer.write((dir / ("frame_" + std::to_string(f) + ".png")).string(), gradient(f));
  writer.finish();
  for (int f = 0; f < 12; ++f) {
    const Image read = readPng((dir / ("frame_" + std::to_string(f) + ".png")).string());
    EXPECT_EQ(read.rgba, gradient(f).rgba) << "frame " << f;
  }
}

TEST(BackgroundPngWriter, AFailedWriteIsReportedNamingThePath) {
  const auto dir = freshDirectory("snowsim_png_writer_fail");
  const std::string bad = (dir / "missing_directory" / "frame.png").string();
  BackgroundPngWriter writer;
  writer.write(bad, gradient(0));
  try {
    writer.finish();
    FAIL() << "no error reported";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(bad));
}

}  // namespace
}  // namespace snowsim
