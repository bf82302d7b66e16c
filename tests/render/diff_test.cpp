// snowsim diff: summary counts and exit codes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "render/image.h"
#include "render/image_diff.h"

namespace snowsim {
namespace {

Image flat(int w, int h, std::uint8_t v) {
  return Image{w, h, std::vector<std::uint8_t>(size_t(w) * h * 4, v)};
}

int runDiff(const std::string& args) {
  const int status =
      std::system((std::string(SNOWSIM_BINARY) + " diff " + args + " > /dev/null 2>&1").c_str());
  return WEXITSTATUS(status);
}

TEST(Diff, CountsAChangedBlockAndIgnoresNothingElse) {
  Image a = flat(40, 30, 40), b = a;
  for (int y = 10; y < 20; ++y)
    for (int x = 10; x < 20; ++x)
      for (int c = 0; c < 3; ++c) b.rgba[4 * (y * 40 + x) + c] = 230;
  const ImageDiff d = diffImages(a, b);
  // The block's 100 pixels differ; its border pixels sit on an edge in b but their neighbours
  // in a are all equal, so only interior/edge split varies: all 100 are counted one way or the
  // other.
  EXPECT_EQ(d.differing + d.anti_aliased, 100);
  EXPECT_GE(d.differing, 64);  // at least the interior 8x8
  EXPECT_NEAR(d.largest, std::sqrt(0.5053 * 190.0 * 190 / 35215), 1e-3);
}

TEST(Diff, ExitCodes) {
  const auto dir = std::filesystem::temp_directory_path() / "snowsim_diff_test";
  std::filesystem::create_directories(dir);
  const std::string a = (dir / "a.png").string(), b = (dir / "b.png").string(),
                    small = (dir / "small.png").string();
  Image base = flat(20, 20, 50), changed = base;
  for (int c = 0; c < 3; ++c) changed.rgba[4 * (10 * 20 + 10) + c] = 250;
  writePng(a, base);
  writePng(b, changed);
  writePng(small, flat(10, 10, 50));
  EXPECT_EQ(runDiff(a + " " + a), 0);
  EXPECT_EQ(runDiff(a + " " + b), 1);
  EXPECT_EQ(runDiff(a + " " + b + " --max-share 0.01"), 0);
  EXPECT_EQ(runDiff(a + " " + small), 2);
  EXPECT_EQ(runDiff(a + " " + (dir / "missing.png").string()), 2);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace snowsim
