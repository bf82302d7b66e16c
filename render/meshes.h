// Triangle meshes of what a frame shows besides the particles: the ground plane and the colliders
// (render/renderer.cpp draws them lit and shadowed in 3D, flat in 2D). Plain geometry, no OpenGL.
#pragma once

#include <vector>

#include <glm/glm.hpp>

#include "sim/core/snapshot.h"

namespace snowsim {

// Appended to a flat array as 9 floats a vertex: position, unit normal, colour.
struct MeshVertex {
  glm::vec3 position, normal, colour;
};

void appendVertex(std::vector<float>& out, const MeshVertex& v);

// 3D: the ground plane y = 0 under the domain [0, extent], reaching `margin` beyond it each way.
void appendGround(glm::vec3 extent, float margin, glm::vec3 colour, std::vector<float>& out);

// A collider as triangles, turned by its rotation, for the domain [0, extent]. 3D: a box's six
// faces, a sphere's surface, a mesh's triangles, a plane's surface where it crosses the domain, a
// drum's wall (open at both ends, lit from inside). 2D (flat, at z = 0, facing +z): the box's
// rectangle, the sphere's disc, the region of the domain behind the plane (its solid side), a ring
// around the drum. A drum's wall is striped so that its turning shows.
void appendCollider(const SnapshotCollider& collider, int dimension, glm::vec3 extent,
                    glm::vec3 colour, std::vector<float>& out);

// The convex polygon `polygon` clipped to the half space (x - point) . normal <= 0
// (Sutherland-Hodgman); empty when nothing of it is left.
std::vector<glm::vec3> clipPolygon(const std::vector<glm::vec3>& polygon, glm::vec3 point,
                                   glm::vec3 normal);

}  // namespace snowsim
