// The ground and collider meshes: where their triangles lie and which way they face.
#include <gtest/gtest.h>

#include <cmath>

#include "render/meshes.h"

namespace snowsim {
namespace {

const glm::vec3 kExtent(0.4f, 0.2f, 0.3f);

std::vector<MeshVertex> vertices(const std::vector<float>& flat) {
  std::vector<MeshVertex> out;
  for (size_t i = 0; i + 9 <= flat.size(); i += 9)
    out.push_back({{flat[i], flat[i + 1], flat[i + 2]},
                   {flat[i + 3], flat[i + 4], flat[i + 5]},
                   {flat[i + 6], flat[i + 7], flat[i + 8]}});
  return out;
}

std::vector<MeshVertex> meshOf(const SnapshotCollider& collider, int dimension) {
  std::vector<float> flat;
  appendCollider(collider, dimension, kExtent, glm::vec3(1), flat);
  return vertices(flat);
}

TEST(Meshes, BoxHasSixOutwardFaces) {
  SnapshotCollider box;
  box.shape = SnapshotCollider::Shape::Box;
  box.position = {0.2, 0.1, 0.15};
  box.size = {0.02, 0.2, 0.1};
  const auto v = meshOf(box, 3);
  ASSERT_EQ(v.size(), 36u);
  for (const MeshVertex& p : v) {
    const glm::vec3 from_centre = p.position - glm::vec3(0.2f, 0.1f, 0.15f);
    EXPECT_GT(glm::dot(from_centre, p.normal), 0) << "normals point out of the box";
    EXPECT_NEAR(std::abs(from_centre.x), 0.01f, 1e-6f);
  }
}

TEST(Meshes, ATurnedBoxIsDrawnTurned) {
  // A box 0.1 m long along its local x, turned 90 degrees about z: drawn long along y.
  SnapshotCollider box;
  box.shape = SnapshotCollider::Shape::Box;
  box.position = {0.2, 0.1, 0.15};
  box.size = {0.1, 0.02, 0.02};
  box.rotation = {std::sqrt(0.5), 0, 0, std::sqrt(0.5)};
  for (const MeshVertex& p : meshOf(box, 3)) {
    const glm::vec3 from_centre = p.position - glm::vec3(0.2f, 0.1f, 0.15f);
    EXPECT_NEAR(std::abs(from_centre.x), 0.01f, 1e-6f);
    EXPECT_NEAR(std::abs(from_centre.y), 0.05f, 1e-6f);
    EXPECT_GT(glm::dot(from_centre, p.normal), 0) << "normals point out of the box";
  }
}

TEST(Meshes, ADrumIsAWallAroundItsAxisSeenFromInside) {
  SnapshotCollider drum;
  drum.shape = SnapshotCollider::Shape::Drum;
  drum.position = {0.2, 0.1, 0.15};
  drum.radius = 0.08;
  drum.size = {0.16, 0.16, 0.3};
  const glm::vec3 axis(0.2f, 0.1f, 0.15f);
  const auto wall = meshOf(drum, 3);
  ASSERT_FALSE(wall.empty());
  for (const MeshVertex& p : wall) {
    const glm::vec3 radial(p.position.x - axis.x, p.position.y - axis.y, 0);
    EXPECT_NEAR(glm::length(radial), 0.08f, 1e-6f);
    EXPECT_NEAR(std::abs(p.position.z - axis.z), 0.15f, 1e-6f);
    EXPECT_LT(glm::dot(radial, p.normal), 0) << "the wall faces its axis";
  }
  drum.position[2] = 0;  // 2D: a ring just outside the radius
  for (const MeshVertex& p : meshOf(drum, 2)) {
    const float r = glm::length(p.position - glm::vec3(0.2f, 0.1f, 0));
    EXPECT_GE(r, 0.08f - 1e-6f);
    EXPECT_LE(r, 0.08f * 1.15f + 1e-6f);
  }
}

TEST(Meshes, SphereVerticesLieOnItsSurface) {
  SnapshotCollider ball;
  ball.shape = SnapshotCollider::Shape::Sphere;
  ball.position = {0.1, 0.05, 0.1};
  ball.radius = 0.03;
  for (const MeshVertex& p : meshOf(ball, 3)) {
    EXPECT_NEAR(glm::length(p.position - glm::vec3(0.1f, 0.05f, 0.1f)), 0.03f, 1e-6f);
    EXPECT_NEAR(glm::length(p.normal), 1, 1e-5f);
  }
}

TEST(Meshes, PlaneIsClippedToTheDomain) {
  // A slope through the domain: its surface stays inside the box and reaches two opposite walls.
  SnapshotCollider plane;
  plane.position = {0.2, 0.05, 0.15};
  plane.normal = {-0.6, 0.8, 0};
  const auto v = meshOf(plane, 3);
  ASSERT_FALSE(v.empty());
  float low_z = 1, high_z = -1;
  for (const MeshVertex& p : v) {
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(p.position[a], -1e-5f);
      EXPECT_LE(p.position[a], kExtent[a] + 1e-5f);
    }
    EXPECT_NEAR(glm::dot(p.position - glm::vec3(0.2f, 0.05f, 0.15f), glm::vec3(-0.6f, 0.8f, 0)), 0,
                1e-5f);
    low_z = std::min(low_z, p.position.z), high_z = std::max(high_z, p.position.z);
  }
  EXPECT_NEAR(low_z, 0, 1e-5f);
  EXPECT_NEAR(high_z, kExtent.z, 1e-5f);
}

TEST(Meshes, FlatPlaneCoversItsSolidSide) {
  // 2D: a floor at y = 0.05 covers the strip of the domain below it.
  SnapshotCollider plane;
  plane.position = {0, 0.05, 0};
  plane.normal = {0, 1, 0};
  const auto v = meshOf(plane, 2);
  ASSERT_EQ(v.size(), 6u);
  double area = 0;
  for (size_t i = 0; i < v.size(); i += 3)
    area += 0.5 * glm::length(glm::cross(v[i + 1].position - v[i].position,
                                         v[i + 2].position - v[i].position));
  EXPECT_NEAR(area, 0.4 * 0.05, 1e-6);
}

TEST(Meshes, ClippingAwayEverythingLeavesNothing) {
  const std::vector<glm::vec3> square{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  EXPECT_TRUE(clipPolygon(square, {0, -1, 0}, {0, 1, 0}).empty());
  EXPECT_EQ(clipPolygon(square, {0.5f, 0, 0}, {1, 0, 0}).size(), 4u);
}

TEST(Meshes, GroundFacesUpAroundTheDomain) {
  std::vector<float> flat;
  appendGround(kExtent, 0.1f, glm::vec3(1), flat);
  const auto v = vertices(flat);
  ASSERT_EQ(v.size(), 6u);
  for (const MeshVertex& p : v) {
    EXPECT_EQ(p.position.y, 0);
    EXPECT_EQ(p.normal, glm::vec3(0, 1, 0));
    EXPECT_NEAR(std::abs(p.position.x - 0.2f), 0.3f, 1e-6f);
  }
}

}  // namespace
}  // namespace snowsim
