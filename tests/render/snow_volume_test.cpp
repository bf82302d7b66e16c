// The volume look's medium as numbers: a slab of packed particles has the optical depth its
// grains give, straight up and towards the key light, and none above it.
#include <gtest/gtest.h>

#include <cmath>

#include "render/snow_volume.h"

namespace snowsim {
namespace {

// A 0.1 x 0.12 x 0.1 m domain of 1 cm cells and a slab of particles 2.5 mm apart filling x and z
// from 1 to 9 cm, y from 4 to 6 cm (8 layers).
Snapshot slab() {
  Snapshot s;
  s.grid.dimension = 3;
  s.grid.cells = {10, 12, 10};
  s.grid.cell_size = 0.01;
  s.grid.particle_spacing = 0.0025;
  for (int i = 0; i < 32; ++i)
    for (int j = 0; j < 8; ++j)
      for (int k = 0; k < 32; ++k) {
        s.position.push_back({0.01f + 0.0025f * (i + 0.5f), 0.04f + 0.0025f * (j + 0.5f),
                              0.01f + 0.0025f * (k + 0.5f)});
        s.velocity.push_back({0, 0, 0});
      }
  return s;
}

// Channel c (0: sigma, 1: towards the light, 2: upwards) at the texel nearest a world point of
// x and z and at texel row `row` (negative: from the top).
float at(const SnowVolume& v, float x, int row, float z, int c) {
  const glm::ivec3 t(glm::round((x - v.origin.x) / v.spacing), row < 0 ? v.size.y + row : row,
                     glm::round((z - v.origin.z) / v.spacing));
  EXPECT_TRUE(glm::all(glm::greaterThanEqual(t, glm::ivec3(0))) &&
              glm::all(glm::lessThan(t, v.size)));
  return v.texels[3 * ((static_cast<size_t>(t.z) * v.size.y + t.y) * v.size.x + t.x) + c];
}

// Through the slab, 8 layers of spheres of radius 1.25 mm at 2.5 mm: 8 pi r^2 / spacing^2 =
// 2 pi; towards the light (-0.6, 1, 0.8) the path is sqrt(2) times as long.
TEST(SnowVolume, SlabHasTheOpticalDepthOfItsGrains) {
  const glm::vec3 light = glm::normalize(glm::vec3(-0.6f, 1, 0.8f));
  SnowVolume v;
  buildSnowVolume(slab(), 0.00125f, light, v);
  const double through = 2 * 3.14159265358979;
  const int middle = static_cast<int>(std::lround((0.05f - v.origin.y) / v.spacing));
  EXPECT_NEAR(at(v, 0.05f, middle, 0.05f, 0), 3.14159265358979 / 4 / 0.0025, 0.1 * 314)
      << "inside: pi r^2 per particle volume";
  EXPECT_NEAR(at(v, 0.05f, 0, 0.05f, 2), through, 0.05 * through) << "below it, upwards";
  EXPECT_NEAR(at(v, 0.05f, 0, 0.05f, 1), std::sqrt(2.0) * through, 0.05 * through)
      << "below it, towards the light";
  for (int c = 0; c < 3; ++c) EXPECT_EQ(at(v, 0.05f, -1, 0.05f, c), 0.f) << "above it: none";
  EXPECT_FALSE(v.empty());
  buildSnowVolume(Snapshot{}, 0.00125f, light, v);
  EXPECT_TRUE(v.empty()) << "no particles, no snow";
}

}  // namespace
}  // namespace snowsim
