// Which particles the 3D renderer leaves out: those deep in dense snow as seen from the camera or
// the light, never those on the surface facing it, nor any of a sparse cloud.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>

#include "render/buried_particles.h"

namespace snowsim {
namespace {

constexpr float kSpacing = 0.01f;

// A packed cube of n^3 particles on a lattice of kSpacing, its corner at (0, 0, 0).
std::vector<std::array<float, 3>> packedCube(int n) {
  std::vector<std::array<float, 3>> positions;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        positions.push_back({(i + 0.5f) * kSpacing, (j + 0.5f) * kSpacing, (k + 0.5f) * kSpacing});
  return positions;
}

int indexOf(int n, int i, int j, int k) {
  return (k * n + j) * n + i;
}

bool contains(const std::vector<std::uint32_t>& indices, int i) {
  return std::binary_search(indices.begin(), indices.end(), static_cast<std::uint32_t>(i));
}

TEST(BuriedParticles, DenseSnowHidesItsInsideButNotItsSurface) {
  const int n = 40;
  const BuriedParticles buried(packedCube(n), kSpacing, 0.5f * kSpacing);
  const glm::vec3 above(0.2f, 1.0f, 0.3f);  // a camera above the cube's top face
  std::vector<std::uint32_t> seen;
  buried.visibleFromPoint(above, seen);
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
  EXPECT_TRUE(contains(seen, indexOf(n, 20, n - 1, 20))) << "the top layer";
  EXPECT_TRUE(contains(seen, indexOf(n, 20, n - 3, 20))) << "three layers down";
  EXPECT_FALSE(contains(seen, indexOf(n, 20, 20, 20))) << "the centre";
  EXPECT_FALSE(contains(seen, indexOf(n, 20, 0, 20))) << "the bottom, under the whole cube";
  EXPECT_LT(seen.size(), packedCube(n).size() / 2) << "most of a packed cube is inside";

  std::vector<std::uint32_t> lit;
  buried.visibleFromDirection(glm::vec3(1, 0, 0), lit);  // a light from +x
  EXPECT_TRUE(contains(lit, indexOf(n, n - 1, 20, 20))) << "the face towards the light";
  EXPECT_FALSE(contains(lit, indexOf(n, 0, 20, 20))) << "the face away from it";
  EXPECT_FALSE(contains(lit, indexOf(n, 20, 20, 20))) << "the centre";
}

TEST(BuriedParticles, GroundHidesWhatIsUnderTheSnowFromBelow) {
  const int n = 10;
  const BuriedParticles buried(packedCube(n), kSpacing, 0.5f * kSpacing);
  std::vector<std::uint32_t> seen;
  buried.visibleFromPoint(glm::vec3(0.05f, -1.0f, 0.05f), seen);
  EXPECT_TRUE(seen.empty()) << "a camera under the ground sees none of the snow on it";
}

TEST(BuriedParticles, SparseSnowAndLoneParticlesAreAllSeen) {
  const int n = 40;
  // Spheres a tenth of the spacing wide: rays pass between them.
  const BuriedParticles sparse(packedCube(n), kSpacing, 0.05f * kSpacing);
  std::vector<std::uint32_t> seen;
  sparse.visibleFromPoint(glm::vec3(0.2f, 1.0f, 0.3f), seen);
  EXPECT_EQ(seen.size(), packedCube(n).size());

  const BuriedParticles lone({{0.3f, 0.2f, 0.1f}}, kSpacing, 0.5f * kSpacing);
  seen.clear();
  lone.visibleFromDirection(glm::vec3(0, 1, 0), seen);
  EXPECT_EQ(seen, std::vector<std::uint32_t>{0});
}

}  // namespace
}  // namespace snowsim
