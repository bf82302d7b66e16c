// Closed triangle meshes read from OBJ, STL or PLY files (through assimp), for bodies filled with
// snow and for colliders. Loading checks what the level set of a mesh needs: triangles that span
// an area, and a closed surface (every edge shared by exactly two triangles).
#pragma once

#include <array>
#include <string>
#include <vector>

namespace snowsim {

struct TriangleMesh {
  std::vector<std::array<double, 3>> vertices;  // m, in the file's frame
  std::vector<std::array<int, 3>> triangles;    // indices into vertices

  // The smallest and largest coordinate along each axis.
  std::array<std::array<double, 3>, 2> bounds() const;
  // Enclosed volume (divergence theorem); negative when the triangles face inwards.
  double signedVolume() const;
};

// Reads and checks a mesh file. Throws InputError naming `path` and what is wrong: missing,
// unreadable, no triangles, a triangle of (near) zero area, or not watertight (an edge of one
// triangle or of three or more). Vertices at the same position are merged first, so an STL's
// separate triangles close up.
TriangleMesh loadTriangleMesh(const std::string& path);

// Where a mesh is placed: x' = position + R (scale x), R the rotation by rotation_degrees[0]
// about x, then [1] about y, then [2] about z (fixed axes: R = Rz Ry Rx).
struct MeshPlacement {
  std::array<double, 3> position{};
  std::array<double, 3> rotation_degrees{};
  double scale = 1;
};

TriangleMesh placed(const TriangleMesh& mesh, const MeshPlacement& placement);

}  // namespace snowsim
