// The renderer looked at as pixels: where things land, what colours mean, and that it repeats.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "render/colour.h"
#include "render/renderer.h"
#include "sim/core/errors.h"
#include "tests/support/temp_dir.h"

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

int colourDistance(const std::uint8_t* a, const std::uint8_t* b) {
  return std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2]);
}

RenderSettings testSettings(ColorBy color_by = ColorBy::White) {
  RenderSettings settings;
  settings.width = kWidth;
  settings.height = kHeight;
  settings.color_by = color_by;
  return settings;
}

// One OpenGL context per colouring for the whole test binary: creating one costs tens of ms.
Renderer& sharedRenderer(ColorBy color_by = ColorBy::White) {
  static Renderer white(testSettings(ColorBy::White));
  static Renderer density(testSettings(ColorBy::Density));
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
  const auto [ox, oy] = pixelOf(0.03, 0.055);
  EXPECT_FALSE(isBackground(image, ox, oy)) << "large cells keep every line, as in the report";
  const auto [bx, by] = pixelOf(0.055, 0.055);
  EXPECT_TRUE(isBackground(image, bx, by)) << "inside a cell";
  const auto [gx, gy] = pixelOf(0.055, 0.0);
  EXPECT_GT(image.pixel(gx, gy)[0], image.pixel(gx, gy)[2] + 20) << "the ground, brown, at y = 0";
  EXPECT_TRUE(isBackground(image, 5, 5)) << "outside the domain";
}

TEST(Renderer, TwoDimensionalGroundIsDrawnWithoutTheGrid) {
  RenderSettings settings = testSettings();
  settings.show_grid = false;
  Renderer renderer(settings);
  const Image image = renderer.render(emptyDomain(2));
  for (double x : {0.005, 0.055, 0.095}) {
    const auto [gx, gy] = pixelOf(x, 0.0);
    EXPECT_GT(image.pixel(gx, gy)[0], image.pixel(gx, gy)[2] + 20)
        << "the ground, brown, at y = 0 and x = " << x;
  }
  const auto [lx, ly] = pixelOf(0.05, 0.055);
  EXPECT_TRUE(isBackground(image, lx, ly)) << "no cell line at x = 0.05 m";
  const auto [wx, wy] = pixelOf(0.0, 0.06);
  EXPECT_TRUE(isBackground(image, wx, wy)) << "no wall at x = 0";
}

double luminance(const std::uint8_t* p) {
  return 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2];
}

// Viridis: low values dark violet, high ones bright yellow.
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
  EXPECT_GT(low[2], low[1] + 40) << "low density is violet";
  EXPECT_GT(high[0], high[2] + 80) << "high density is yellow";
  EXPECT_GT(luminance(high), luminance(low) + 80);
}

// A fixed range: a particle keeps its colour when a faster one joins it in a later frame.
TEST(Renderer, ColourRangeIsTheSameInEveryFrame) {
  RenderSettings settings = testSettings(ColorBy::Speed);
  settings.color_range = ColourRange{0, 4};
  Renderer renderer(settings);
  Snapshot s = emptyDomain(2);
  s.grid.particle_spacing = 0.01;
  addParticle(s, 0.025, 0.06, 0);
  s.velocity[0] = {1, 0, 0};
  const Image first = renderer.render(s);
  addParticle(s, 0.075, 0.06, 0);
  s.velocity[1] = {0, -8, 0};
  const Image second = renderer.render(s);
  const auto [px, py] = pixelOf(0.025, 0.06);
  EXPECT_EQ(std::vector<std::uint8_t>(first.pixel(px, py), first.pixel(px, py) + 3),
            std::vector<std::uint8_t>(second.pixel(px, py), second.pixel(px, py) + 3));
  RenderSettings empty = settings;
  empty.color_range = ColourRange{2, 2};
  EXPECT_THROW(validate(empty), InputError);
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
  RenderSettings zero = testSettings();
  zero.width = 0;
  EXPECT_THROW(validate(zero), InputError);
  RenderSettings fov = testSettings();
  fov.camera.fov_degrees = 180;
  EXPECT_THROW(validate(fov), InputError);
  EXPECT_THROW(parseColorBy("temperature"), InputError);
}

// J_P's colours are a diverging map over log J_P: 1 the neutral grey in the middle, compressed
// warm, stretched cool, a halving and a doubling alike in lightness, and the ends of the default
// range (a quarter, four times) the map's two ends; beyond them the colour stays.
TEST(Renderer, PlasticColouringIsSymmetricInLog) {
  EXPECT_FLOAT_EQ(colourScale(1, ColorBy::Plastic, kPlasticRange), 0.5f);
  EXPECT_FLOAT_EQ(colourScale(0.5, ColorBy::Plastic, kPlasticRange) +
                      colourScale(2, ColorBy::Plastic, kPlasticRange),
                  1.f);
  EXPECT_FLOAT_EQ(colourScale(0.25, ColorBy::Plastic, kPlasticRange), 0.f);
  EXPECT_FLOAT_EQ(colourScale(4, ColorBy::Plastic, kPlasticRange), 1.f);
  EXPECT_FLOAT_EQ(colourScale(1, ColorBy::Plastic, {0.5, 4}), 0.5f) << "1 stays in the middle";

  Renderer renderer(testSettings(ColorBy::Plastic));
  Snapshot s = emptyDomain(2);
  s.grid.particle_spacing = 0.012;
  const float j[] = {0.1f, 0.25f, 0.5f, 1, 2, 4, 10};
  for (int i = 0; i < 7; ++i) addParticle(s, 0.014f * i + 0.008f, 0.06f, 0);
  s.plastic_j.assign(std::begin(j), std::end(j));
  const Image image = renderer.render(s);
  auto at = [&](int i) {
    const auto [x, y] = pixelOf(0.014 * i + 0.008, 0.06);
    return image.pixel(x, y);
  };
  const std::uint8_t* neutral = at(3);
  EXPECT_LT(std::abs(neutral[0] - neutral[2]), 8) << "J_P = 1: grey";
  EXPECT_LT(std::abs(neutral[0] - neutral[1]), 8);
  EXPECT_GT(at(2)[0], at(2)[2] + 40) << "compressed: warm";
  EXPECT_GT(at(4)[2], at(4)[0] + 40) << "stretched: cool";
  EXPECT_NEAR(luminance(at(2)), luminance(at(4)), 12) << "halved and doubled alike";
  EXPECT_GT(at(1)[0], 4 * at(1)[1]) << "a quarter: the deep red end";
  EXPECT_GT(at(5)[2], 2 * at(5)[0]) << "four times: the deep blue end";
  EXPECT_LE(colourDistance(at(0), at(1)), 10) << "beyond the range: the end's colour";
  EXPECT_LE(colourDistance(at(6), at(5)), 10);

  RenderSettings without_one = testSettings(ColorBy::Plastic);
  without_one.color_range = ColourRange{1.1, 2};
  EXPECT_THROW(validate(without_one), InputError) << "the range must hold J_P = 1";
  s.plastic_j.clear();
  EXPECT_THROW(renderer.render(s), InputError) << "the report's method has no J_P";
}

TEST(Renderer, DensityCellsMarkTheCriticalDensity) {
  RenderSettings settings = testSettings();
  settings.density_cells = true;
  Renderer renderer(settings);
  Snapshot s = emptyDomain(2);
  s.grid.critical_density = 100;
  s.grid.node_density.assign(11 * 13, 0.f);
  s.grid.node_density[3 * 11 + 2] = 250;  // node (2, 3): packed
  s.grid.node_density[3 * 11 + 7] = 40;   // node (7, 3): loose
  const Image image = renderer.render(s);
  // A quarter cell off each node, so no grid line is under the pixel.
  const auto [px, py] = pixelOf(0.0225, 0.0325);
  const auto [lx, ly] = pixelOf(0.0725, 0.0325);
  const auto [ex, ey] = pixelOf(0.0525, 0.0325);
  const auto *packed = image.pixel(px, py), *loose = image.pixel(lx, ly);
  EXPECT_GT(packed[0], packed[2] + 80) << "at or above the critical density: amber";
  EXPECT_GT(loose[2], loose[0] + 30) << "below it: blue";
  EXPECT_FALSE(isBackground(image, lx, ly));
  EXPECT_TRUE(isBackground(image, ex, ey)) << "an empty cell";
}

// Level of detail: the point sprite stands where the ray-cast sphere does, about as large.
TEST(Renderer, PointSpritesMatchTheImpostors) {
  Snapshot s = emptyDomain(2);
  s.grid.particle_spacing = 0.01;
  addParticle(s, 0.025, 0.09, 0);
  RenderSettings impostor = testSettings(), sprite = testSettings();
  impostor.lod_pixels = 0;
  sprite.lod_pixels = 1000;
  impostor.show_grid = sprite.show_grid = false;  // sprite frames are single-sampled: sharper lines
  const Image a = Renderer(impostor).render(s), b = Renderer(sprite).render(s);
  auto bright = [](const Image& image) {
    int n = 0;
    for (int i = 0; i < kWidth * kHeight; ++i) n += image.rgba[4 * i + 2] > 150;
    return n;
  };
  const auto [px, py] = pixelOf(0.025, 0.09);
  EXPECT_GT(b.pixel(px, py)[2], 150);
  EXPECT_NEAR(bright(b), bright(a), 0.2 * bright(a));
}

TEST(Renderer, SceneCameraLooksWhereItIsTold) {
  Snapshot s = emptyDomain(3);
  s.grid.particle_spacing = 0.01;
  addParticle(s, 0.03, 0.04, 0.05);
  RenderSettings settings = testSettings();
  settings.camera.custom = true;
  settings.camera.eye = {0.03, 0.04, 0.4};
  settings.camera.target = {0.03, 0.04, 0.05};
  const Image at = Renderer(settings).render(s);
  settings.camera.target = {0.2, 0.04, 0.05};
  const Image away = Renderer(settings).render(s);
  const auto* centre = at.pixel(kWidth / 2, kHeight / 2);
  EXPECT_GT(centre[2], 150) << "the sphere at the image centre";
  EXPECT_LT(away.pixel(kWidth / 2, kHeight / 2)[2], 150) << "looking past it";
}

// Moire shows as energy at the highest spatial frequencies: the mean distance of each pixel's
// luminance from the mean of its 3x3 neighbourhood. Lines a pixel or two apart give it in
// quantity; lines a viewer can resolve, at most a fraction of it.
double highFrequencyEnergy(const Image& image) {
  double sum = 0;
  for (int y = 1; y + 1 < image.height; ++y)
    for (int x = 1; x + 1 < image.width; ++x) {
      double neighbourhood = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) neighbourhood += luminance(image.pixel(x + dx, y + dy));
      sum += std::abs(luminance(image.pixel(x, y)) - neighbourhood / 9);
    }
  return sum / ((image.width - 2.0) * (image.height - 2.0));
}

// A 3D domain of 120x80x80 cells of 5 mm at the default 1280x720: drawing every cell line (the
// back wall's 3-4 pixels apart, the floor's one or two) is moire; the lines a viewer can resolve
// give about half the bound.
TEST(Renderer, FineGridsRenderWithoutMoire) {
  Snapshot s;
  s.grid.dimension = 3;
  s.grid.cells = {120, 80, 80};
  s.grid.cell_size = 0.005;
  EXPECT_LT(highFrequencyEnergy(Renderer(RenderSettings{}).render(s)), 1.6);
}

// The figure look's back grid at 640x360 stays a light grid, not a dark mesh: seen from the front,
// a wall of 60x40 cells of 1 cm (the flagship smash at --scale 0.5) lies about 7 pixels a cell,
// and a small particle makes the frame one of sprites, not anti-aliased. The ink is how far
// below the white background the wall's pixels are, on average.
TEST(Renderer, FigureGridStaysLightAtSmallSizes) {
  Snapshot s;
  s.grid.dimension = 3;
  s.grid.cells = {60, 40, 40};
  s.grid.cell_size = 0.01;
  s.grid.particle_spacing = 0.005;
  addParticle(s, 0.05, 0.35, 0.2);
  RenderSettings settings;
  settings.width = 640;
  settings.height = 360;
  settings.look = Look::Figure;
  settings.camera.custom = true;
  settings.camera.eye = {0.3, 0.2, 1.4};
  settings.camera.target = {0.3, 0.2, 0};
  const Image image = Renderer(settings).render(s);
  double ink = 0;
  int pixels = 0;
  for (int y = 100; y < 260; ++y)
    for (int x = 220; x < 420; ++x, ++pixels) ink += 255 - luminance(image.pixel(x, y));
  EXPECT_GT(ink / pixels, 1) << "the grid is drawn";
  EXPECT_LT(ink / pixels, 8) << "and light";
}

// The preset camera frames the snow's box: a small ball in a corner of a large domain fills the
// image's height, from every preset, and stays within the image.
TEST(Renderer, PresetCameraFramesTheSnow) {
  Snapshot s = emptyDomain(3);
  s.grid.cells = {100, 60, 80};
  s.grid.particle_spacing = 0.002;
  for (int i = 0; i < 1000; ++i) {
    const float x = (i % 10) * 0.002f, y = (i / 10 % 10) * 0.002f, z = (i / 100) * 0.002f;
    addParticle(s, 0.1f + x, 0.05f + y, 0.1f + z);
  }
  for (CameraPreset preset :
       {CameraPreset::ThreeQuarter, CameraPreset::Front, CameraPreset::Side, CameraPreset::Top}) {
    RenderSettings settings = testSettings();
    settings.show_grid = false;
    settings.shadows = settings.occlusion = false;  // only the snow differs from the empty frame
    settings.camera.preset = preset;
    settings.camera.frame = particleBounds(s);
    Renderer renderer(settings);
    const Image image = renderer.render(s);
    Snapshot empty = s;
    empty.position.clear();
    empty.velocity.clear();
    const Image without_snow = renderer.render(empty);
    // Rows and columns with snow: at least 3 pixels that differ from the empty frame (the
    // horizon of the ground may move by a pixel; a line of one pixel a column is not snow).
    std::vector<int> per_row(kHeight), per_column(kWidth);
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x)
        if (colourDistance(image.pixel(x, y), without_snow.pixel(x, y)) > 24)
          ++per_row[y], ++per_column[x];
    const auto first = [](const std::vector<int>& v) {
      return int(std::find_if(v.begin(), v.end(), [](int n) { return n >= 3; }) - v.begin());
    };
    const auto last = [](const std::vector<int>& v) {
      return int(v.rend() - std::find_if(v.rbegin(), v.rend(), [](int n) { return n >= 3; })) - 1;
    };
    const int top = first(per_row), bottom = last(per_row);
    const int left = first(per_column), right = last(per_column);
    const std::string name = presetName(preset);
    EXPECT_GT(bottom - top, kHeight / 2) << name << ": the snow fills the frame";
    EXPECT_GT(top, 0) << name;
    EXPECT_LT(bottom, kHeight - 1) << name;
    EXPECT_GT(left, 0) << name;
    EXPECT_LT(right, kWidth - 1) << name;
  }
  EXPECT_EQ(parseCameraPreset("side", "--camera-preset"), CameraPreset::Side);
  EXPECT_THROW(parseCameraPreset("below", "--camera-preset"), InputError);
}

// A ball of 8,000 particles on a lattice, the camera close: as beads its disc is speckled by
// each sphere's shading, as a surface it is smooth. Measured over the pixels where the ball
// differs from the empty frame, away from its outline: the mean distance of each pixel's
// luminance from its 3x3 neighbourhood's mean.
TEST(Renderer, SurfaceLookDrawsABallSmoothly) {
  Snapshot s = emptyDomain(3);
  s.grid.particle_spacing = 0.0025;
  for (int k = 0; k < 20; ++k)
    for (int j = 0; j < 20; ++j)
      for (int i = 0; i < 20; ++i) {
        const float x = (i - 9.5f) * 0.0025f, y = (j - 9.5f) * 0.0025f, z = (k - 9.5f) * 0.0025f;
        if (x * x + y * y + z * z <= 0.025f * 0.025f)
          addParticle(s, 0.05f + x, 0.06f + y, 0.05f + z);
      }
  auto noiseOverTheBall = [&](Look look) {
    RenderSettings settings = testSettings();
    settings.look = look;
    settings.show_grid = false;
    settings.camera.custom = true;
    settings.camera.eye = {0.05, 0.08, 0.14};
    settings.camera.target = {0.05, 0.06, 0.05};
    Renderer renderer(settings);
    const Image image = renderer.render(s);
    Snapshot empty = s;
    empty.position.clear();
    empty.velocity.clear();
    empty.density.clear();
    const Image without = renderer.render(empty);
    double sum = 0;
    int pixels = 0;
    for (int y = 3; y + 3 < kHeight; ++y)
      for (int x = 3; x + 3 < kWidth; ++x) {
        bool inside = true;  // the ball here and in every pixel 3 away
        for (int dy = -3; dy <= 3 && inside; dy += 3)
          for (int dx = -3; dx <= 3 && inside; dx += 3)
            inside =
                colourDistance(image.pixel(x + dx, y + dy), without.pixel(x + dx, y + dy)) > 24;
        if (!inside) continue;
        double neighbourhood = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) neighbourhood += luminance(image.pixel(x + dx, y + dy));
        sum += std::abs(luminance(image.pixel(x, y)) - neighbourhood / 9);
        ++pixels;
      }
    EXPECT_GT(pixels, kWidth * kHeight / 10) << lookName(look) << ": the ball fills the view";
    return sum / std::max(pixels, 1);
  };
  const double beads = noiseOverTheBall(Look::Studio), surface = noiseOverTheBall(Look::Surface);
  EXPECT_LT(surface, 0.25 * beads) << "beads " << beads << ", surface " << surface;
}

TEST(Image, PngRoundTripsAndWritesAtomically) {
  const Image image = sharedRenderer().render(emptyDomain(2));
  const auto path = snowsim_test::processTempDir() / "image.png";
  writePng(path.string(), image);
  EXPECT_FALSE(std::filesystem::exists(path.string() + ".tmp"));
  const Image back = readPng(path.string());
  EXPECT_EQ(back.width, kWidth);
  EXPECT_EQ(back.rgba, image.rgba);
  EXPECT_THROW(writePng("/proc/snowsim/x.png", image), InputError);
}

}  // namespace
}  // namespace snowsim
