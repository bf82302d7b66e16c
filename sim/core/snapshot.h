// What a frame shows: the particles and the grid at one instant, in a dimension-free form that
// render/ and the file writers read. 2D runs have z = 0.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "sim/geometry/triangle_mesh.h"

namespace snowsim {

struct SnowSurface;  // sim/geometry/snow_surface.h

struct GridInfo {
  int dimension = 2;
  std::array<int, 3> cells{1, 1, 1};  // cells along x, y, z (z = 1 in 2D)
  double cell_size = 0;
  double particle_spacing = 0;  // lattice spacing the particles were generated at (smallest body)
  double critical_density = 0;  // density at which a cell counts as packed (0: not defined)
  // 2D runs: density m_i / h^2 at each node of the domain ((cells[0]+1) x (cells[1]+1), x
  // fastest); node (i, j) sits at (i h, j h) and stands for the cell of side h centred there.
  // Empty for 3D runs.
  std::vector<float> node_density;
};

// A scene collider where it is at the snapshot's time, for drawing (plain data; 2D runs have z = 0
// and a 2D collider stands for its extrusion along z). The shape is given in the collider's local
// frame, placed by x_world = R(rotation) x_local + position.
struct SnapshotCollider {
  enum class Shape { Plane, Sphere, Box, Drum, Mesh };
  Shape shape = Shape::Plane;
  std::array<double, 3> position{};  // the local origin: a point of the plane, the centre (m)
  std::array<double, 4> rotation{1, 0, 0, 0};  // unit quaternion w, x, y, z: local to world
  std::array<double, 3> normal{0, 1, 0};  // plane: outward normal, local (the solid is behind it)
  double radius = 0;                      // sphere; drum: the inner radius about local z (m)
  std::array<double, 3> size{};           // box extents; drum: 2 radius, 2 radius, length (m)
  std::array<double, 3> velocity{};       // of the local origin (m/s)
  // Mesh: the file's triangles (shared by every frame), scaled about the local origin; the file is
  // named for run.json.
  std::shared_ptr<const TriangleMesh> mesh;
  std::string mesh_file;
  double scale = 1;

  // Where the collider is `elapsed` seconds later, moving on at its velocity without turning
  // (for runs that recorded only the colliders at time 0).
  SnapshotCollider movedBy(double elapsed) const {
    SnapshotCollider moved = *this;
    for (int a = 0; a < 3; ++a) moved.position[a] += elapsed * velocity[a];
    return moved;
  }
};

struct Snapshot {
  int frame = 0;
  double time = 0;
  GridInfo grid;
  std::vector<std::array<float, 3>> position;
  std::vector<std::array<float, 3>> velocity;
  std::vector<float> density;    // kg/m^D per particle (current, interpolated from the grid)
  std::vector<float> plastic_j;  // J_P, the plastic volume ratio (MPM only; empty otherwise)
  // Both empty in frames read from files older than these attributes:
  std::vector<float> mass;    // kg (2D: kg per metre of depth)
  std::vector<float> radius;  // m: half the edge of the particle's rest volume, (m / rho)^(1/D) / 2
  std::vector<SnapshotCollider> colliders;  // the scene's colliders (not the domain walls)
  // The snow's surface when a run built it for this frame (--surface, --look surface), shared by
  // the writers and the renderer; none: whoever needs it builds it.
  std::shared_ptr<const SnowSurface> surface;

  int size() const { return static_cast<int>(position.size()); }
};

}  // namespace snowsim
