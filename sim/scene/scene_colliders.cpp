#include "sim/scene/scene_colliders.h"

#include <algorithm>
#include <memory>

namespace snowsim {

namespace {

// A 2D scene's collider moved into the slab of a 3D run: its local origin halfway through the
// depth.
RigidMotionDescription centredInSlab(RigidMotionDescription motion, double depth) {
  motion.position[2] = depth / 2;
  for (PoseKey& k : motion.keyframes) k.position[2] = depth / 2;
  return motion;
}

// A mesh collider's distance field: voxels of half a cell, a few cells beyond the surface.
double meshVoxelAsked(const Scene& scene) {
  return scene.cell_size / 2;
}
double meshMargin(const Scene& scene) {
  return 3 * scene.cell_size;
}

// How far inside the collider the grid's nodes meet it: the scene's inset, at most half of how
// deep the collider's deepest point lies (a sphere's radius, a box's thinnest half size), so that
// the grid still sees a small one. A mesh's thin part beside a thick one gets the whole inset.
template <int D>
Real gridInset(const Scene& scene, const Collider<D>& c) {
  const Real inset = scene.mpm.collider_inset * scene.cell_size;
  switch (c.shape) {
    case ColliderShape::Sphere:
      return std::min(inset, c.radius / 2);
    case ColliderShape::Box:
      return std::min(inset, c.half_size.head(c.shape_dims).minCoeff() / 2);
    case ColliderShape::Mesh:
      return std::min(inset, c.level_set->depth() / 2);
    default:  // a half space or a drum's wall: solid without end
      return inset;
  }
}

}  // namespace

double meshColliderVoxel(const Scene& scene, const ColliderParams& collider) {
  return LevelSet::voxelFor(collider.mesh.placedAt({0, 0, 0}), meshVoxelAsked(scene),
                            meshMargin(scene));
}

template <int D>
std::vector<Collider<D>> makeColliders(const Scene& scene) {
  std::vector<Collider<D>> colliders;
  const Vec3 extent = scene.extent();
  for (int a = 0; a < D; ++a)
    for (int side = 0; side < 2; ++side) {
      Collider<D> wall;
      wall.normal[a] = side == 0 ? 1 : -1;
      wall.position[a] = side == 0 ? 0 : extent[a];
      const bool extruded_axis = a >= scene.authored_dimension;
      wall.type = extruded_axis ? ColliderType::Slip : scene.mpm.wall_type;
      wall.friction = extruded_axis ? 0 : scene.mpm.wall_friction;
      // A 2D scene's slab stays uniform along its depth only if its end walls hold their nodes.
      wall.grid_inset = extruded_axis ? 0 : gridInset(scene, wall);
      colliders.push_back(wall);
    }
  const int dims = std::min(D, scene.authored_dimension);
  for (const ColliderParams& p : scene.colliders) {
    Collider<D> c;
    c.shape = p.shape;
    c.shape_dims = dims;
    for (int a = 0; a < dims; ++a) {
      c.normal[a] = p.normal[a];
      c.half_size[a] = p.size[a] / 2;
    }
    c.radius = p.radius;
    if (p.shape == ColliderShape::Mesh)
      c.level_set = std::make_shared<const LevelSet>(p.mesh.placedAt({0, 0, 0}),
                                                     meshVoxelAsked(scene), meshMargin(scene));
    c.type = p.type;
    c.friction = p.friction;
    c.grid_inset = gridInset(scene, c);
    const RigidMotionDescription& motion = p;
    c.motion = RigidMotion(D > dims ? centredInSlab(motion, extent[D - 1]) : motion);
    c.placeAt(0);
    colliders.push_back(c);
  }
  return colliders;
}

std::vector<SnapshotCollider> collidersAt(const Scene& scene, int dimension, double time) {
  using Shape = SnapshotCollider::Shape;
  const Vec3 extent = scene.extent();
  const bool extruded = scene.authored_dimension == 2;  // through the slab, or flat in 2D
  std::vector<SnapshotCollider> colliders;
  for (const ColliderParams& p : scene.colliders) {
    SnapshotCollider c;
    c.shape = p.shape == ColliderShape::HalfSpace ? Shape::Plane
              : p.shape == ColliderShape::Sphere  ? Shape::Sphere
              : p.shape == ColliderShape::Drum    ? Shape::Drum
              : p.shape == ColliderShape::Mesh    ? Shape::Mesh
                                                  : Shape::Box;
    const RigidMotionDescription& motion = p;
    const RigidPose pose =
        RigidMotion(extruded ? centredInSlab(motion, dimension == 3 ? extent[2] : 0) : motion)
            .at(time);
    c.normal = p.normal;
    c.radius = p.radius;
    c.size = p.shape == ColliderShape::Drum ? Vec3{2 * p.radius, 2 * p.radius, extent[2]} : p.size;
    if (extruded) c.size[2] = dimension == 3 ? extent[2] : 0;
    c.mesh = p.mesh.triangles;
    c.mesh_file = p.mesh.file;
    c.scale = p.mesh.scale;
    for (int a = 0; a < 3; ++a) {
      c.position[a] = pose.position[a];
      c.velocity[a] = pose.velocity[a];
    }
    c.rotation = {pose.rotation.w(), pose.rotation.x(), pose.rotation.y(), pose.rotation.z()};
    colliders.push_back(c);
  }
  return colliders;
}

template std::vector<Collider<2>> makeColliders<2>(const Scene&);
template std::vector<Collider<3>> makeColliders<3>(const Scene&);

}  // namespace snowsim
