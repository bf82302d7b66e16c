// The renderer looked at as pixels: where things land, what colours mean, and that it repeats.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "render/renderer.h"
#include "sim/errors.h"

namespace snowsim {
namespace {

constexpr int kWidth = 320, kHeight = 240;

Snapshot emptyDomain(int dimension) {
  Snapshot s;
  s.grid.dimension = dimension;
  s.grid.cells = {10, 12, dimension == 3 ? 10 : 1};
  s.grid.cell_size = 0.01;
  s.grid.particle_spacing = 0.01 / 3;
  return s;
}

void addParticle(Snapshot& s, float x, float y, float z, float density = 0) {
  s.position.push_back({x, y, z});
  s.velocity.push_back({0, 0, 0});
  s.density.push_back(density);
}

// The pixel of world point (x, y) in the 2D orthographic view: the domain (0.1 x 0.12 m) centred,
// its height filling 1/1.1 of the image.
std::pair<int, int> pixelOf(double x, double y) {
  const double half_height = 0.55 * 0.12, aspect = double(kWidth) / kHeight;
  const double u = (x - 0.05) / (half_height * aspect), v = (y - 0.06) / half_height;
  return {int(std::lround((u + 1) / 2 * kWidth - 0.5)),
          int(std::lround((1 - v) / 2 * kHeight - 0.5))};
}

bool isBackground(const Image& image, int x, int y) {
  const auto* p = image.pixel(x, y);
  return std::abs(p[0] - 51) <= 2 && std::abs(p[1] - 56) <= 2 && std::abs(p[2] - 69) <= 2;
}

// One OpenGL context per colouring for the whole test binary: creating one costs tens of ms.
Renderer& sharedRenderer(ColorBy color_by = ColorBy::White) {
  static Renderer white({kWidth, kHeight, ColorBy::White, true, 0});
  static Renderer density({kWidth, kHeight, ColorBy::Density, true, 0});
  return color_by == ColorBy::White ? white : density;
}

TEST(Renderer, SphereLandsWhereTheCameraSays) {
  Snapshot s = emptyDomain(2);
  addParticle(s, 0.025, 0.09, 0);
  s.grid.particle_spacing = 0.01;  // a 1 cm sphere, about 18 pixels across
  const Image image = sharedRenderer().render(s);
  const auto [px, py] = pixelOf(0.025, 0.09);
  EXPECT_GT(image.pixel(px, py)[0], 150) << "the lit sphere is bright at its centre";
  EXPECT_GT(image.pixel(px, py)[2], 150);
  const auto [qx, qy] = pixelOf(0.025 + 0.012, 0.09 + 0.003);
  EXPECT_TRUE(isBackground(image, qx, qy)) << "a sphere-width away: background again";
}

TEST(Renderer, EmptySceneShowsOnlyTheGrid) {
  const Image image = sharedRenderer().render(emptyDomain(2));
  int bright = 0;
  for (int i = 0; i < kWidth * kHeight; ++i) bright += image.rgba[4 * i] > 110;
  EXPECT_GT(bright, 100) << "the walls are bright lines";
  EXPECT_LT(bright, 4000) << "and nothing else is";
  const auto [lx, ly] = pixelOf(0.05, 0.055);
  EXPECT_FALSE(isBackground(image, lx, ly)) << "a cell line at x = 0.05 m";
  const auto [bx, by] = pixelOf(0.055, 0.055);
  EXPECT_TRUE(isBackground(image, bx, by)) << "inside a cell";
  const auto [gx, gy] = pixelOf(0.055, 0.0);
  EXPECT_GT(image.pixel(gx, gy)[0], image.pixel(gx, gy)[2] + 20) << "the ground, brown, at y = 0";
  EXPECT_TRUE(isBackground(image, 5, 5)) << "outside the domain";
}

TEST(Renderer, ColourByDensityDiffersWhereDensityDiffers) {
  Snapshot s = emptyDomain(2);
  s.grid.critical_density = 100;
  s.grid.particle_spacing = 0.01;
  addParticle(s, 0.025, 0.06, 0, /*density=*/10);
  addParticle(s, 0.075, 0.06, 0, /*density=*/190);
  const Image image = sharedRenderer(ColorBy::Density).render(s);
  const auto [lx, ly] = pixelOf(0.025, 0.06);
  const auto [hx, hy] = pixelOf(0.075, 0.06);
  const auto *low = image.pixel(lx, ly), *high = image.pixel(hx, hy);
  EXPECT_GT(low[2], low[0] + 40) << "low density is blue";
  EXPECT_GT(high[0], high[2] + 40) << "high density is red";
}

TEST(Renderer, ThreeDimensionalScenesRender) {
  Snapshot s = emptyDomain(3);
  for (int i = 0; i < 27; ++i)
    addParticle(s, 0.04f + 0.005f * (i % 3), 0.02f + 0.005f * (i / 9),
                0.04f + 0.005f * (i / 3 % 3));
  const Image with = sharedRenderer().render(s);
  const Image without = sharedRenderer().render(emptyDomain(3));
  int changed = 0;
  for (size_t i = 0; i < with.rgba.size(); i += 4) changed += with.rgba[i] != without.rgba[i];
  EXPECT_GT(changed, 200) << "the spheres are visible";
}

TEST(Renderer, RenderingTwiceGivesIdenticalBytes) {
  Snapshot s = emptyDomain(2);
  for (int i = 0; i < 50; ++i) addParticle(s, 0.02f + 0.0012f * i, 0.03f + 0.0007f * i, 0);
  EXPECT_EQ(sharedRenderer().render(s).rgba, sharedRenderer().render(s).rgba);
}

TEST(Renderer, BadSettingsAreInputErrors) {
  EXPECT_THROW(validate({0, 720, ColorBy::White, true, 0}), InputError);
  EXPECT_THROW(parseColorBy("temperature"), InputError);
}

TEST(Image, PngRoundTripsAndWritesAtomically) {
  const Image image = sharedRenderer().render(emptyDomain(2));
  const auto path =
      std::filesystem::temp_directory_path() / ("snowsim_png_" + std::to_string(getpid()) + ".png");
  writePng(path.string(), image);
  EXPECT_FALSE(std::filesystem::exists(path.string() + ".tmp"));
  const Image back = readPng(path.string());
  EXPECT_EQ(back.width, kWidth);
  EXPECT_EQ(back.rgba, image.rgba);
  EXPECT_THROW(writePng("/proc/snowsim/x.png", image), InputError);
}

}  // namespace
}  // namespace snowsim
