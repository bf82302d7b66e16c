// Colliders described by a signed distance (Stomakhin et al. 2013, section 8): the domain walls,
// ground planes, spheres, boxes, drums and closed meshes, each a shape in its local frame moved
// rigidly through the world (sim/core/rigid_motion.h). A collision acts on a velocity relative to
// the collider's surface velocity there (sticky, slip, or separating with Coulomb friction).
#pragma once

#include <memory>
#include <vector>

#include "sim/core/collider_kind.h"
#include "sim/core/math.h"
#include "sim/core/rigid_motion.h"
#include "sim/geometry/level_set.h"

namespace snowsim {

// The friction rule of the paper (section 8), relative to the collider velocity v_c:
// v_rel = v - v_c, v_n = v_rel . n; if v_n >= 0 (separating) nothing changes; v_t = v_rel - n v_n;
// if |v_t| <= -mu v_n then v_rel = 0, else v_rel = v_t + mu v_n v_t / |v_t|; v = v_rel + v_c.
// Sticky sets v = v_c; slip removes the normal component of v_rel whatever its sign (no friction).
template <int D>
Vec<D> collideVelocity(const Vec<D>& v, const Vec<D>& n, const Vec<D>& collider_velocity,
                       ColliderType type, Real friction);

template <int D>
struct Collider {
  ColliderShape shape = ColliderShape::HalfSpace;
  // The local frame: x_world = rotation x_local + position. The shape is given in it.
  Vec<D> position = Vec<D>::Zero();  // local origin: plane point, sphere, box or drum centre
  Mat<D> rotation = Mat<D>::Identity();
  Vec<D> normal = Vec<D>::Zero();  // half space: outward unit normal, local frame
  Real radius = 0;                 // sphere; drum: inner radius about the local z axis
  Vec<D> half_size = Vec<D>::Zero();
  std::shared_ptr<const LevelSet> level_set;  // mesh (3D): its signed distance about position
  // The rigid velocity: v(x) = velocity + spin (x - position), spin the angular velocity's
  // cross-product matrix (in 2D its top left 2x2).
  Vec<D> velocity = Vec<D>::Zero();
  Mat<D> spin = Mat<D>::Zero();
  ColliderType type = ColliderType::Separating;
  Real friction = 0;
  int shape_dims = D;  // axes the shape depends on; a 2D shape in a 3D slab is extruded along z
  RigidMotion motion;  // where placeAt puts the collider (at rest for the domain walls)
  // How far inside its surface the grid's nodes meet it (m). A node's velocity reaches particles
  // a kernel's width away, so nodes stopped on the surface hold snow about a cell above it; the
  // particles themselves meet the surface (MpmSolver's particle collision and pushOut).
  Real grid_inset = 0;

  // Signed distance: negative inside the solid.
  Real phi(const Vec<D>& x) const;
  // Outward unit normal at x (the gradient of phi).
  Vec<D> outwardNormal(const Vec<D>& x) const;
  Vec<D> surfaceVelocity(const Vec<D>& x) const { return velocity + spin * (x - position); }

  // Applies the collision to v at x when x lies `depth` or deeper inside the collider (phi <=
  // -depth): a particle on or inside it.
  void collide(const Vec<D>& x, Vec<D>& v, Real depth = 0) const {
    if (phi(x) > -depth) return;
    v = collideVelocity<D>(v, outwardNormal(x), surfaceVelocity(x), type, friction);
  }
  // A grid node's v at x, grid_inset or deeper inside.
  void collideNode(const Vec<D>& x, Vec<D>& v) const { collide(x, v, grid_inset); }
  // Moves x onto the surface if it ended inside.
  void pushOut(Vec<D>& x) const {
    const Real d = phi(x);
    if (d < 0) x -= d * outwardNormal(x);
  }
  // Sets the pose and velocities to the motion's at `time` (s).
  void placeAt(Real time);
};

// The world-axis box that holds every point where the collider's phi <= 0, grown by margin on
// each side: a sphere's, a box's or a mesh's level set's, turned with the collider; unbounded
// along every axis for a half space or a drum, and along the axes a 2D shape is extruded over.
template <int D>
Eigen::AlignedBox<Real, D> boundingBox(const Collider<D>& collider, Real margin);

// Applies every collider to the grid velocity v at node x (as Collider::collideNode does) and
// returns the projection onto the velocity components the collisions left free, for a semi-implicit
// solve that must hold the collided components (Stomakhin et al. 2013, section 9: collisions on v*
// first): identity for a free node, I - n n^T where a slip or sliding contact fixes the normal
// component, zero where the node sticks (sticky, static friction, or two contacts).
template <int D>
Mat<D> collideAndConstrain(const std::vector<Collider<D>>& colliders, const Vec<D>& x, Vec<D>& v);

// Places every collider that moves at `time` (s); the others stay where they were made.
template <int D>
void placeColliders(std::vector<Collider<D>>& colliders, Real time);

// The fastest any point of a collider within the domain moves, for the step limit: a collider
// must not cross a cell in a step unseen by the grid.
template <int D>
Real fastestColliderSpeed(const std::vector<Collider<D>>& colliders, Real domain_diagonal);

}  // namespace snowsim
