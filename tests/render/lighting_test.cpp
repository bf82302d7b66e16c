// The 3D lighting looked at as pixels: the key light's shadow falls where the light says, on the
// ground and its grid lines; the floor has lines both ways; ambient occlusion darkens a crevice,
// spheres a pixel wide are still shaded, colliders are drawn, and the looks set the background.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "render/renderer.h"
#include "sim/core/errors.h"

namespace snowsim {
namespace {

constexpr int kWidth = 320, kHeight = 240;
constexpr double kFov = 35, kEyeHeight = 0.3;
constexpr double kPi = 3.14159265358979;

// A 0.1 x 0.12 x 0.1 m domain; no grid, so the ground is bare.
Snapshot domain() {
  Snapshot s;
  s.grid.dimension = 3;
  s.grid.cells = {10, 12, 10};
  s.grid.cell_size = 0.01;
  s.grid.particle_spacing = 0.02;  // spheres of radius 1 cm
  return s;
}

void addParticle(Snapshot& s, double x, double y, double z) {
  s.position.push_back({float(x), float(y), float(z)});
  s.velocity.push_back({0, 0, 0});
  s.density.push_back(0);
}

// Looking straight down at the ground from kEyeHeight above (0.05, 0, 0.05): image right is +x,
// image down is +z.
RenderSettings topView() {
  RenderSettings settings;
  settings.width = kWidth;
  settings.height = kHeight;
  settings.show_grid = false;
  settings.camera.custom = true;
  settings.camera.eye = {0.05, kEyeHeight, 0.05};
  settings.camera.target = {0.05, 0, 0.05};
  settings.camera.up = {0, 0, -1};
  settings.camera.fov_degrees = kFov;
  return settings;
}

// The pixel of world point (x, y, z) in topView().
std::pair<int, int> pixelOf(double x, double y, double z) {
  const double scale = 0.5 * kHeight / ((kEyeHeight - y) * std::tan(kFov / 2 * kPi / 180));
  return {int(std::lround(kWidth / 2.0 + (x - 0.05) * scale - 0.5)),
          int(std::lround(kHeight / 2.0 + (z - 0.05) * scale - 0.5))};
}

double brightness(const Image& image, std::pair<int, int> p) {
  const auto* rgb = image.pixel(p.first, p.second);
  return (rgb[0] + rgb[1] + rgb[2]) / 3.0;
}

TEST(Lighting, ShadowFallsWhereTheLightSays) {
  // The key light comes from (-0.6, 1, 0.8) (docs/rendering.md): a sphere 4 cm above the ground
  // casts its shadow 2.4 cm towards +x and 3.2 cm towards -z of its foot.
  Snapshot s = domain();
  addParticle(s, 0.05, 0.04, 0.05);
  RenderSettings settings = topView();
  settings.occlusion = false;
  const Image lit = Renderer(settings).render(s);
  const auto shadow = pixelOf(0.074, 0, 0.018), beside = pixelOf(0.026, 0, 0.082);
  EXPECT_LT(brightness(lit, shadow), 0.7 * brightness(lit, beside))
      << "the ground in the shadow is at least 30% darker than beside the sphere";
  settings.shadows = false;
  const Image unshadowed = Renderer(settings).render(s);
  EXPECT_NEAR(brightness(unshadowed, shadow), brightness(unshadowed, beside), 10)
      << "without shadows both points of the ground look alike";
}

// The floor's grid lines are lit as the ground they lie on: a line in a sphere's shadow is darker
// than the same lines in the light, by as much as the ground is.
TEST(Lighting, ShadowsDarkenTheFloorLines) {
  Snapshot s = domain();
  addParticle(s, 0.03, 0.04, 0.07);
  RenderSettings settings = topView();
  settings.occlusion = false;
  settings.sphere_radius = 0.02;
  const Image bare = Renderer(settings).render(s);
  settings.show_grid = true;
  const Image lined = Renderer(settings).render(s);
  const double lit_ground = brightness(bare, pixelOf(0.09, 0, 0.09));
  // Line pixels: where the grid changes the floor inside the domain. In shadow: where the bare
  // ground is dark.
  const auto [x0, y0] = pixelOf(0.003, 0, 0.003);
  const auto [x1, y1] = pixelOf(0.097, 0, 0.097);
  double shadowed_sum = 0, lit_sum = 0;
  int shadowed = 0, lit = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      if (std::abs(brightness(bare, {x, y}) - brightness(lined, {x, y})) < 8) continue;
      const double ground = brightness(bare, {x, y});
      if (ground < 0.7 * lit_ground) {
        shadowed_sum += brightness(lined, {x, y});
        ++shadowed;
      } else if (ground > 0.95 * lit_ground) {
        lit_sum += brightness(lined, {x, y});
        ++lit;
      }
    }
  ASSERT_GT(shadowed, 30) << "lines cross the shadow";
  ASSERT_GT(lit, 300) << "and the light";
  EXPECT_LT(shadowed_sum / shadowed, 0.75 * (lit_sum / lit))
      << "a line in the shadow is at least 25% darker than one in the light";
}

// Both families of the floor's lines are drawn: a row of the top view crosses the lines of
// constant x, a column those of constant z, one change in brightness for each of the 9 inner lines.
TEST(Lighting, FloorShowsBothFamiliesOfLines) {
  RenderSettings settings = topView();
  settings.show_grid = true;
  const Image image = Renderer(settings).render(domain());
  auto lines = [&](std::pair<int, int> from, std::pair<int, int> to) {
    const double ground = brightness(image, pixelOf(0.055, 0, 0.055));
    int count = 0;
    bool in_line = false;
    const int steps = std::max(std::abs(to.first - from.first), std::abs(to.second - from.second));
    for (int i = 0; i <= steps; ++i) {
      const std::pair<int, int> p{from.first + (to.first - from.first) * i / steps,
                                  from.second + (to.second - from.second) * i / steps};
      const bool line = std::abs(brightness(image, p) - ground) > 8;
      count += line && !in_line;
      in_line = line;
    }
    return count;
  };
  EXPECT_EQ(lines(pixelOf(0.005, 0, 0.055), pixelOf(0.095, 0, 0.055)), 9) << "lines of constant x";
  EXPECT_EQ(lines(pixelOf(0.055, 0, 0.005), pixelOf(0.055, 0, 0.095)), 9) << "lines of constant z";
}

TEST(Lighting, OcclusionDarkensTheCreviceBetweenTouchingSpheres) {
  // Two spheres of 1 cm touching at x = 0.05, seen from above; points on the left sphere's top a
  // fifth of a radius from the contact (the crevice) and from its far side (open).
  Snapshot s = domain();
  addParticle(s, 0.04, 0.05, 0.05);
  addParticle(s, 0.06, 0.05, 0.05);
  RenderSettings settings = topView();
  settings.shadows = false;
  const double top = 0.05 + 0.01 * std::sqrt(1 - 0.8 * 0.8);
  const auto crevice = pixelOf(0.048, top, 0.05), open = pixelOf(0.032, top, 0.05);
  const Image with = Renderer(settings).render(s);
  settings.occlusion = false;
  const Image without = Renderer(settings).render(s);
  const double crevice_darkening = brightness(without, crevice) - brightness(with, crevice);
  const double open_darkening = brightness(without, open) - brightness(with, open);
  EXPECT_GT(crevice_darkening, 15) << "occlusion darkens the crevice";
  EXPECT_GT(crevice_darkening, open_darkening + 10) << "more than the open side";
}

TEST(Lighting, SpheresAPixelWideAreShadedAcrossACluster) {
  // A ball of 2 cm radius made of spheres about a pixel wide, lit from the left: its left side
  // is brighter than its right, so the tiny spheres are not drawn in one flat colour.
  Snapshot s = domain();
  const double spacing = 0.0008;
  for (double x = -0.02; x <= 0.02; x += spacing)
    for (double y = -0.02; y <= 0.02; y += spacing)
      for (double z = -0.02; z <= 0.02; z += spacing)
        if (x * x + y * y + z * z <= 0.02 * 0.02) addParticle(s, 0.05 + x, 0.04 + y, 0.05 + z);
  s.grid.particle_spacing = spacing;
  RenderSettings settings = topView();
  const Image image = Renderer(settings).render(s);
  const double left = brightness(image, pixelOf(0.036, 0.054, 0.05));
  const double right = brightness(image, pixelOf(0.064, 0.054, 0.05));
  const double middle = brightness(image, pixelOf(0.05, 0.06, 0.05));
  EXPECT_GT(left, right + 25) << "the side facing the light is brighter";
  EXPECT_GT(middle, right + 15) << "the top too";
}

TEST(Lighting, CollidersAreDrawn) {
  Snapshot s = domain();
  RenderSettings settings = topView();
  const Image bare = Renderer(settings).render(s);
  SnapshotCollider box;
  box.shape = SnapshotCollider::Shape::Box;
  box.position = {0.03, 0.02, 0.05};
  box.size = {0.02, 0.04, 0.08};
  SnapshotCollider ball;
  ball.shape = SnapshotCollider::Shape::Sphere;
  ball.position = {0.07, 0.02, 0.05};
  ball.radius = 0.015;
  s.colliders = {box, ball};
  const Image drawn = Renderer(settings).render(s);
  for (const auto& at : {pixelOf(0.03, 0.04, 0.05), pixelOf(0.07, 0.035, 0.05)})
    EXPECT_GT(std::abs(brightness(drawn, at) - brightness(bare, at)), 10)
        << "the collider's top differs from the bare ground";
  EXPECT_NEAR(brightness(drawn, {5, 5}), brightness(bare, {5, 5}), 1) << "far from both";
}

// --look volume: more snow along a ray lets less of what is behind it through. Two slabs side by
// side, seen face on against the background: a single sheet of particles (optical depth pi r^2 /
// spacing^2 = pi / 4, a transmittance of 0.46) and eight sheets (6.3, 0.002). A pixel is L + T
// background, so the two backgrounds, black and white, give the transmittance T.
TEST(Lighting, VolumeThickerSnowIsMoreOpaque) {
  Snapshot s = domain();
  s.grid.particle_spacing = 0.0025;
  for (double x = 0.01; x < 0.04; x += 0.0025)
    for (double y = 0.05; y < 0.09; y += 0.0025) {
      addParticle(s, x, y, 0.05);
      for (int layer = 0; layer < 8; ++layer) addParticle(s, x + 0.05, y, 0.04 + 0.0025 * layer);
    }
  RenderSettings settings;
  settings.width = kWidth;
  settings.height = kHeight;
  settings.look = Look::Volume;
  settings.camera.custom = true;
  settings.camera.eye = {0.05, 0.07, 0.4};
  settings.camera.target = {0.05, 0.07, 0};
  settings.camera.fov_degrees = kFov;
  settings.background = std::array<double, 3>{0, 0, 0};
  const Image black = Renderer(settings).render(s);
  settings.background = std::array<double, 3>{1, 1, 1};
  const Image white = Renderer(settings).render(s);
  // The pixel of a point of the plane z = 0.05 (0.35 m from the eye).
  auto pixel = [](double x, double y) {
    const double scale = 0.5 * kHeight / (0.35 * std::tan(kFov / 2 * kPi / 180));
    return std::pair<int, int>{int(std::lround(kWidth / 2.0 + (x - 0.05) * scale)),
                               int(std::lround(kHeight / 2.0 - (y - 0.07) * scale))};
  };
  auto transmittance = [&](double x, double y) {
    return (brightness(white, pixel(x, y)) - brightness(black, pixel(x, y))) / 255;
  };
  EXPECT_GT(transmittance(0.05, 0.16), 0.99) << "no snow: the background";
  const double thin = transmittance(0.025, 0.07), thick = transmittance(0.075, 0.07);
  EXPECT_GT(thin, 0.25) << "a sheet lets the background through";
  EXPECT_LT(thin, 0.7) << "but dims it";
  EXPECT_LT(thick, 0.05) << "eight sheets hide it";
  EXPECT_GT(brightness(black, pixel(0.075, 0.07)), 60) << "and the snow scatters light";
}

TEST(Lighting, LooksAndBackgroundSetTheBackground) {
  Snapshot s = domain();
  RenderSettings settings = topView();
  settings.camera.target = {0.05, kEyeHeight, 5};  // level, away from the domain: background only
  settings.camera.up = {0, 1, 0};
  settings.look = Look::Figure;
  const Image figure = Renderer(settings).render(s);
  EXPECT_EQ(figure.pixel(kWidth / 2, kHeight / 2)[0], 255) << "figure: white";
  settings.background = std::array<double, 3>{0, 0, 1};
  const Image blue = Renderer(settings).render(s);
  EXPECT_EQ(blue.pixel(kWidth / 2, kHeight / 2)[2], 255);
  EXPECT_EQ(blue.pixel(kWidth / 2, kHeight / 2)[0], 0);
  settings.background = std::array<double, 3>{0, 0, 1.5};
  EXPECT_THROW(validate(settings), InputError);
  EXPECT_EQ(parseLook("figure"), Look::Figure);
  EXPECT_EQ(parseLook("volume"), Look::Volume);
  EXPECT_THROW(parseLook("noir"), InputError);
}

}  // namespace
}  // namespace snowsim
