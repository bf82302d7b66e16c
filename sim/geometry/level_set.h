// The signed distance to a closed triangle mesh, built once with OpenVDB (the mesh to level set
// conversion Houdini's MPM colliders use) and kept as a dense grid of voxels sampled trilinearly:
// a read is a few array loads, safe from any thread, and OpenVDB stays inside level_set.cpp.
#pragma once

#include <array>
#include <vector>

#include "sim/geometry/triangle_mesh.h"

namespace snowsim {

class LevelSet {
 public:
  // Distances at the corners of voxels of side `voxel_size` (m) covering the mesh's bounds and
  // `margin` (m) beyond them. The voxels grow when the box would need more than kMaxVoxels.
  LevelSet(const TriangleMesh& mesh, double voxel_size, double margin);

  static constexpr long kMaxVoxels = 1L << 24;
  // The voxel side the constructor takes for these arguments: voxel_size, or larger when the box
  // would need more than kMaxVoxels.
  static double voxelFor(const TriangleMesh& mesh, double voxel_size, double margin);

  // Signed distance at x (m): negative inside. Beyond the box, the distance to the box is added
  // to the value at its nearest point.
  double phi(const std::array<double, 3>& x) const;
  // The gradient of phi at x: the outward normal on the surface (not normalised).
  std::array<double, 3> gradient(const std::array<double, 3>& x) const;

  double voxelSize() const { return voxel_; }
  // The distance from the surface of the point deepest inside the solid (m).
  double depth() const;
  // Corners of the box outside which phi > 0 (m): the voxels' box, grown by how far below zero a
  // value on its faces goes (by nothing for a closed mesh, whose faces lie outside it).
  std::array<double, 3> solidLower() const;
  std::array<double, 3> solidUpper() const;

 private:
  float at(int i, int j, int k) const {
    return values_[(static_cast<size_t>(k) * dims_[1] + j) * dims_[0] + i];
  }
  struct Position {
    std::array<double, 3> voxels;  // the nearest point of the box, in voxels from the origin
    std::array<double, 3> beyond;  // x minus that point (m): zero inside the box
  };
  Position locate(const std::array<double, 3>& x) const;

  std::array<double, 3> origin_{};  // the first voxel's position (m)
  double voxel_ = 0;
  std::array<int, 3> dims_{};
  std::vector<float> values_;  // x fastest
  double face_reach_ = 0;      // -(the lowest value on the box's faces), at least 0
};

}  // namespace snowsim
