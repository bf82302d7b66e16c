// The snow's surface from its particles: a ball of particles gives a closed mesh of the ball's
// size and volume, the same bits on one thread and two, and a lone grain is handed back as loose.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>

#include "sim/core/errors.h"
#include "sim/geometry/snow_surface.h"
#include "tests/support/threaded_test.h"

using namespace snowsim;

namespace {

constexpr double kCell = 0.005, kSpacing = kCell / 2, kRadius = 0.05;
constexpr std::array<double, 3> kCentre{0.1, 0.08, 0.1};

// A 3D frame of 40^3 cells holding a ball of particles on a lattice of half the cell.
Snapshot ballSnapshot() {
  Snapshot s;
  s.grid.dimension = 3;
  s.grid.cells = {40, 40, 40};
  s.grid.cell_size = kCell;
  s.grid.particle_spacing = kSpacing;
  const int n = static_cast<int>(2 * kRadius / kSpacing);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        std::array<double, 3> x{};
        double r2 = 0;
        for (int a = 0; a < 3; ++a) {
          const int c = a == 0 ? i : a == 1 ? j : k;
          x[a] = kCentre[a] - kRadius + (c + 0.5) * kSpacing;
          r2 += (x[a] - kCentre[a]) * (x[a] - kCentre[a]);
        }
        if (r2 > kRadius * kRadius) continue;
        s.position.push_back({float(x[0]), float(x[1]), float(x[2])});
      }
  s.velocity.assign(s.position.size(), {0, 0, 0});
  s.density.assign(s.position.size(), 400);
  return s;
}

// Signed volume enclosed by the triangles (divergence theorem): positive when they face out.
double enclosedVolume(const SnowSurface& m) {
  double volume = 0;
  for (const auto& t : m.triangles) {
    const auto &a = m.vertices[t[0]], &b = m.vertices[t[1]], &c = m.vertices[t[2]];
    volume += (double(a[0]) * (double(b[1]) * c[2] - double(b[2]) * c[1]) -
               double(a[1]) * (double(b[0]) * c[2] - double(b[2]) * c[0]) +
               double(a[2]) * (double(b[0]) * c[1] - double(b[1]) * c[0])) /
              6;
  }
  return volume;
}

}  // namespace

TEST(SnowSurface, BallGivesAClosedMeshOfItsSizeAndVolume) {
  const Snapshot ball = ballSnapshot();
  const SnowSurface surface = buildSnowSurface(ball, SurfaceSettings{});
  ASSERT_GT(surface.triangles.size(), 1000u);

  // Closed: every edge is shared by exactly two triangles, once each way.
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
  for (const auto& t : surface.triangles)
    for (int e = 0; e < 3; ++e) ++edges[{t[e], t[(e + 1) % 3]}];
  for (const auto& [edge, count] : edges) {
    ASSERT_EQ(count, 1) << "edge " << edge.first << "-" << edge.second;
    ASSERT_EQ(edges.count({edge.second, edge.first}), 1u)
        << "edge " << edge.first << "-" << edge.second << " has one side only";
  }

  // The ball's extents within half a particle spacing, its volume within 3 %.
  for (int a = 0; a < 3; ++a) {
    float low = 1e9f, high = -1e9f;
    for (const auto& v : surface.vertices) low = std::min(low, v[a]), high = std::max(high, v[a]);
    EXPECT_NEAR(low, kCentre[a] - kRadius, 0.5 * kSpacing) << "axis " << a;
    EXPECT_NEAR(high, kCentre[a] + kRadius, 0.5 * kSpacing) << "axis " << a;
  }
  const double ball_volume = 4.0 / 3.0 * M_PI * kRadius * kRadius * kRadius;
  EXPECT_NEAR(enclosedVolume(surface), ball_volume, 0.03 * ball_volume);

  // Normals face out, and no grain of a solid ball is loose.
  int outward = 0;
  for (size_t v = 0; v < surface.vertices.size(); ++v) {
    double dot = 0;
    for (int a = 0; a < 3; ++a)
      dot += surface.normals[v][a] * (surface.vertices[v][a] - kCentre[a]);
    outward += dot > 0;
  }
  EXPECT_EQ(outward, static_cast<int>(surface.vertices.size()));
  EXPECT_TRUE(surface.loose.empty());
  EXPECT_EQ(surface.isolated + surface.smoothed_away, 0);
  EXPECT_EQ(surface.field.voxels.size(), surface.field.values.size());
  EXPECT_DOUBLE_EQ(surface.field.voxel_size, 0.5 * kCell);
}

THREADED_TEST(SnowSurface, SameBitsOnOneThreadAndTwo) {
  const Snapshot ball = ballSnapshot();
  for (double adaptivity : {0.0, 0.5}) {
    SurfaceSettings one, two;
    one.threads = 1, two.threads = 2;
    one.adaptivity = two.adaptivity = adaptivity;
    const SnowSurface a = buildSnowSurface(ball, one), b = buildSnowSurface(ball, two);
    EXPECT_EQ(a.vertices, b.vertices) << "adaptivity " << adaptivity;
    EXPECT_EQ(a.normals, b.normals) << "adaptivity " << adaptivity;
    EXPECT_EQ(a.triangles, b.triangles) << "adaptivity " << adaptivity;
    EXPECT_EQ(a.field.voxels, b.field.voxels) << "adaptivity " << adaptivity;
    EXPECT_EQ(a.field.values, b.field.values) << "adaptivity " << adaptivity;
  }
}

TEST(SnowSurface, LoneGrainIsLooseNotLost) {
  Snapshot s = ballSnapshot();
  const auto lone = static_cast<std::uint32_t>(s.size());
  s.position.push_back({0.18f, 0.18f, 0.18f});  // far from the ball
  s.velocity.push_back({0, 0, 0});
  s.density.push_back(400);
  const SnowSurface surface = buildSnowSurface(s, SurfaceSettings{});
  ASSERT_EQ(surface.loose.size(), 1u);
  EXPECT_EQ(surface.loose[0], lone);
  EXPECT_EQ(surface.isolated, 1);
  for (const auto& v : surface.vertices) ASSERT_LT(v[0], 0.16f) << "the grain became a blob";
}

TEST(SnowSurface, GrainsTheSmoothingRemovesAreCounted) {
  // A pair of grains: not isolated with min_neighbours 1, but too thin to survive the erosion.
  Snapshot s = ballSnapshot();
  const auto first = static_cast<std::uint32_t>(s.size());
  s.position.push_back({0.18f, 0.18f, 0.18f});
  s.position.push_back({0.18f + float(kSpacing), 0.18f, 0.18f});
  s.velocity.resize(s.position.size());
  s.density.resize(s.position.size(), 400);
  SurfaceSettings settings;
  settings.min_neighbours = 1;
  const SnowSurface surface = buildSnowSurface(s, settings);
  EXPECT_EQ(surface.isolated, 0);
  EXPECT_EQ(surface.smoothed_away, 2);
  EXPECT_EQ(surface.loose, (std::vector<std::uint32_t>{first, first + 1}));
}

TEST(SnowSurface, AverageAtVerticesIsTheNearbyParticlesMean) {
  const Snapshot ball = ballSnapshot();
  const SnowSurface surface = buildSnowSurface(ball, SurfaceSettings{});
  // A value linear in x: a symmetric kernel average near a flat-ish surface stays close to it.
  std::vector<float> values;
  for (const auto& x : ball.position) values.push_back(x[0]);
  const std::vector<float> at = averageAtVertices(surface, ball.position, values, 1, 2 * kSpacing);
  ASSERT_EQ(at.size(), surface.vertices.size());
  for (size_t v = 0; v < at.size(); ++v)
    ASSERT_NEAR(at[v], surface.vertices[v][0], 2 * kSpacing) << "vertex " << v;
}

TEST(SnowSurface, BadSettingsAndTwoDimensionsAreRefused) {
  SurfaceSettings bad;
  bad.voxel = 0;
  try {
    validate(bad, "--surface-");
    FAIL() << "voxel 0 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--surface-voxel 0 is out of range"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(parseSurfaceFilter("box", "--surface-filter"), InputError);
  Snapshot flat = ballSnapshot();
  flat.grid.dimension = 2;
  EXPECT_THROW(buildSnowSurface(flat, SurfaceSettings{}), InputError);
}
