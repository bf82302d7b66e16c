#include "app/frame_writer.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "sim/core/errors.h"
#include "tests/support/threaded_test.h"

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

THREADED_TEST(BackgroundFrameWriter, WritesEveryQueuedFrameExactly) {
  const auto dir = freshDirectory("snowsim_frame_writer_test");
  BackgroundFrameWriter writer(2);
  for (int f = 0; f < 12; ++f)  // more frames than the queue holds: write() must wait, not drop
    writer.write((dir / ("frame_" + std::to_string(f) + ".png")).string(), gradient(f));
  writer.finish();
  for (int f = 0; f < 12; ++f) {
    const Image read = readPng((dir / ("frame_" + std::to_string(f) + ".png")).string());
    EXPECT_EQ(read.rgba, gradient(f).rgba) << "frame " << f;
  }
}

THREADED_TEST(BackgroundFrameWriter, AFailedWriteIsReportedNamingThePath) {
  const auto dir = freshDirectory("snowsim_frame_writer_fail");
  const std::string bad = (dir / "missing_directory" / "frame.png").string();
  BackgroundFrameWriter writer;
  writer.write(bad, gradient(0));
  try {
    writer.finish();
    FAIL() << "no error reported";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(bad));
}

// Every frame reaches the video, the frames without a PNG path too, and only those with one are
// written as PNG.
THREADED_TEST(BackgroundFrameWriter, FeedsTheVideoEveryFrameAndWritesOnlyThePngsAsked) {
  const auto dir = freshDirectory("snowsim_frame_writer_video");
  VideoEncoder video((dir / "frames.mp4").string(), 40, 30, VideoSettings{});
  {
    BackgroundFrameWriter writer(2, &video);
    for (int f = 0; f < 10; ++f) {
      const std::string png =
          f % 2 == 0 ? (dir / ("frame_" + std::to_string(f) + ".png")).string() : std::string();
      writer.write(png, gradient(f));
    }
    writer.finish();
  }
  EXPECT_EQ(video.framesWritten(), 10);
  video.finish();
  EXPECT_TRUE(std::filesystem::exists(dir / "frames.mp4"));
  for (int f = 0; f < 10; ++f)
    EXPECT_EQ(std::filesystem::exists(dir / ("frame_" + std::to_string(f) + ".png")), f % 2 == 0)
        << "frame " << f;
}

}  // namespace
}  // namespace snowsim
