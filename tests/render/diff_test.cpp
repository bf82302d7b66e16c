// The perceptual image comparison: what it counts and what a mask leaves out.
#include <gtest/gtest.h>

#include <cmath>

#include "render/image.h"
#include "render/image_diff.h"

namespace snowsim {
namespace {

Image flat(int w, int h, std::uint8_t v) {
  return Image{w, h, std::vector<std::uint8_t>(size_t(w) * h * 4, v)};
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

// The mask leaves its dark pixels out: a change under them is not counted, and the share is of
// the pixels compared.
TEST(Diff, MaskLeavesOutItsDarkPixels) {
  Image a = flat(40, 30, 40), b = a, mask = flat(40, 30, 255);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 10; ++x) {
      for (int c = 0; c < 3; ++c) b.rgba[4 * (y * 40 + x) + c] = 230;
      for (int c = 0; c < 3; ++c) mask.rgba[4 * (y * 40 + x) + c] = 0;
    }
  const ImageDiff unmasked = diffImages(a, b);
  EXPECT_EQ(unmasked.compared, 40 * 30);
  EXPECT_GT(unmasked.differing, 0);
  const ImageDiff masked = diffImages(a, b, 0.1, &mask);
  EXPECT_EQ(masked.compared, 30 * 30);
  EXPECT_EQ(masked.differing + masked.anti_aliased, 0);
  EXPECT_EQ(masked.largest, 0);
  // A changed pixel outside the mask: one of the 900 compared.
  for (int c = 0; c < 3; ++c) b.rgba[4 * (15 * 40 + 25) + c] = 230;
  const ImageDiff one = diffImages(a, b, 0.1, &mask);
  EXPECT_EQ(one.differing, 1);
  EXPECT_DOUBLE_EQ(one.share, 1.0 / 900);
}

TEST(Diff, MaskExcludesDarkNotLightPixels) {
  const auto excludes = [](std::uint8_t r, std::uint8_t g, std::uint8_t b) {
    const std::uint8_t pixel[4] = {r, g, b, 255};
    return maskExcludes(pixel);
  };
  EXPECT_TRUE(excludes(0, 0, 0));
  EXPECT_TRUE(excludes(100, 100, 100));
  EXPECT_TRUE(excludes(0, 0, 255)) << "pure blue is dark";
  EXPECT_FALSE(excludes(255, 255, 255));
  EXPECT_FALSE(excludes(200, 200, 200));
  EXPECT_FALSE(excludes(0, 255, 0)) << "pure green is light";
}

}  // namespace
}  // namespace snowsim
