// The scene's colliders as the core's: the solver's colliders (the domain walls and the scene's)
// and those a snapshot carries for drawing.
#pragma once

#include <vector>

#include "sim/core/collider.h"
#include "sim/core/snapshot.h"
#include "sim/scene/scene.h"

namespace snowsim {

// The 2D walls of the domain box [0, extent] as half spaces, plus the scene's colliders. The walls
// along a 2D scene's extruded z axis are frictionless slip walls, so a slab behaves like 2D.
template <int D>
std::vector<Collider<D>> makeColliders(const Scene& scene);

// The voxel side (m) of a mesh collider's distance field: half a cell, or coarser when the mesh's
// box would need more than LevelSet::kMaxVoxels voxels at that size.
double meshColliderVoxel(const Scene& scene, const ColliderParams& collider);

// The scene's colliders (not the domain walls) at `time` seconds, as a snapshot carries them for
// drawing: in 3D coordinates, a 2D scene's collider extruded through the slab of a 3D run (and
// at z = 0 in a 2D one).
std::vector<SnapshotCollider> collidersAt(const Scene& scene, int dimension, double time);

}  // namespace snowsim
