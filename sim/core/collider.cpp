#include "sim/core/collider.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace snowsim {

namespace {

// A point for the level set of a mesh (meshes are 3D only; a 2D point has z = 0).
template <int D>
std::array<double, 3> toArray3(const Vec<D>& r) {
  std::array<double, 3> p{0, 0, 0};
  for (int a = 0; a < D; ++a) p[a] = r[a];
  return p;
}

}  // namespace

template <int D>
Vec<D> collideVelocity(const Vec<D>& v, const Vec<D>& n, const Vec<D>& collider_velocity,
                       ColliderType type, Real friction) {
  if (type == ColliderType::Sticky) return collider_velocity;
  const Vec<D> v_rel = v - collider_velocity;
  const Real v_n = v_rel.dot(n);
  if (type == ColliderType::Slip) return v_rel - v_n * n + collider_velocity;
  if (v_n >= 0) return v;  // separating: no collision
  const Vec<D> v_t = v_rel - v_n * n;
  const Real t = v_t.norm();
  if (t <= -friction * v_n) return collider_velocity;         // static friction: stick
  return v_t + friction * v_n * v_t / t + collider_velocity;  // kinetic friction
}

template <int D>
Mat<D> collideAndConstrain(const std::vector<Collider<D>>& colliders, const Vec<D>& x, Vec<D>& v) {
  Mat<D> free = Mat<D>::Identity();
  int contacts = 0;
  for (const Collider<D>& c : colliders) {
    if (c.phi(x) > -c.grid_inset) continue;
    const Vec<D> n = c.outwardNormal(x);
    const Vec<D> v_c = c.surfaceVelocity(x);
    const Vec<D> v_rel = v - v_c;
    const Real v_n = v_rel.dot(n);
    if (c.type == ColliderType::Separating && v_n >= 0) continue;
    // The static friction branch of collideVelocity: the node sticks.
    const bool sticks =
        c.type == ColliderType::Sticky ||
        (c.type == ColliderType::Separating && (v_rel - v_n * n).norm() <= -c.friction * v_n);
    v = collideVelocity<D>(v, n, v_c, c.type, c.friction);
    if (++contacts > 1 || sticks) {
      free.setZero();
    } else {
      free -= n * n.transpose();
    }
  }
  return free;
}

template <int D>
Eigen::AlignedBox<Real, D> boundingBox(const Collider<D>& collider, Real margin) {
  constexpr Real unbounded = std::numeric_limits<Real>::infinity();
  Eigen::AlignedBox<Real, D> box(Vec<D>::Constant(-unbounded), Vec<D>::Constant(unbounded));
  if (collider.shape == ColliderShape::Sphere && collider.shape_dims == D) {  // turns into itself
    box.min() = collider.position.array() - collider.radius - margin;
    box.max() = collider.position.array() + collider.radius + margin;
    return box;
  }
  // The box in the collider's frame: its centre and half extents.
  Vec<D> centre = Vec<D>::Zero(), extent = Vec<D>::Constant(unbounded);
  if (collider.shape == ColliderShape::Sphere || collider.shape == ColliderShape::Box) {
    for (int a = 0; a < collider.shape_dims; ++a)
      extent[a] = collider.shape == ColliderShape::Sphere ? collider.radius : collider.half_size[a];
  } else if (collider.shape == ColliderShape::Mesh && D == 3) {
    const std::array<double, 3> lower = collider.level_set->solidLower();
    const std::array<double, 3> upper = collider.level_set->solidUpper();
    for (int a = 0; a < D; ++a) {
      centre[a] = 0.5 * (lower[a] + upper[a]);
      extent[a] = 0.5 * (upper[a] - lower[a]);
    }
  } else {
    return box;  // a half space, a drum
  }
  const Vec<D> world_centre = collider.position + collider.rotation * centre;
  for (int i = 0; i < D; ++i) {
    Real half = 0;  // of the turned local box along world axis i (0 times unbounded is 0)
    for (int j = 0; j < D; ++j)
      if (collider.rotation(i, j) != 0) half += std::abs(collider.rotation(i, j)) * extent[j];
    box.min()[i] = world_centre[i] - half - margin;
    box.max()[i] = world_centre[i] + half + margin;
  }
  return box;
}

template <int D>
Real Collider<D>::phi(const Vec<D>& x) const {
  const Vec<D> r = rotation.transpose() * (x - position);  // local frame
  switch (shape) {
    case ColliderShape::HalfSpace:
      return r.dot(normal);
    case ColliderShape::Sphere: {
      // A loop, not r.head(shape_dims).norm(): GCC 12 warns (falsely) on the dynamic head.
      Real r2 = 0;
      for (int a = 0; a < shape_dims; ++a) r2 += r[a] * r[a];
      return std::sqrt(r2) - radius;
    }
    case ColliderShape::Box: {
      Real outside = 0, inside = -std::numeric_limits<Real>::infinity();
      for (int a = 0; a < shape_dims; ++a) {
        const Real q = std::abs(r[a]) - half_size[a];
        outside += q > 0 ? q * q : 0;
        inside = std::max(inside, q);
      }
      return inside > 0 ? std::sqrt(outside) : inside;
    }
    case ColliderShape::Mesh:
      return level_set->phi(toArray3(r));
    case ColliderShape::Drum:  // the solid is outside the cylinder about local z
      return radius - std::hypot(r[0], r[1]);
  }
  return 0;
}

template <int D>
Vec<D> Collider<D>::outwardNormal(const Vec<D>& x) const {
  const Vec<D> r = rotation.transpose() * (x - position);
  Vec<D> n = Vec<D>::Zero();
  switch (shape) {
    case ColliderShape::HalfSpace:
      return rotation * normal;
    case ColliderShape::Sphere:
      n.head(shape_dims) = r.head(shape_dims);
      break;
    case ColliderShape::Box: {
      int deepest = 0;
      Real inside = -std::numeric_limits<Real>::infinity();
      for (int a = 0; a < shape_dims; ++a) {
        const Real q = std::abs(r[a]) - half_size[a];
        if (q > 0) n[a] = std::copysign(q, r[a]);
        if (q > inside) inside = q, deepest = a;
      }
      if (inside <= 0) n[deepest] = r[deepest] < 0 ? -1 : 1;  // inside: nearest face
      break;
    }
    case ColliderShape::Mesh: {
      const std::array<double, 3> g = level_set->gradient(toArray3(r));
      for (int a = 0; a < D; ++a) n[a] = g[a];
      break;
    }
    case ColliderShape::Drum:
      n.template head<2>() = -r.template head<2>();
      break;
  }
  const Real len = n.norm();
  if (len == 0) {  // the centre of a sphere or drum: any direction will do, choose +y
    n.setZero();
    n[1] = 1;
    return rotation * n;
  }
  return rotation * (n / len);
}

template <int D>
void Collider<D>::placeAt(Real time) {
  const RigidPose pose = motion.at(time);
  const Mat<3> turn = pose.rotation.toRotationMatrix();
  Mat<3> spin3;
  spin3 << 0, -pose.angular_velocity.z(), pose.angular_velocity.y(),  //
      pose.angular_velocity.z(), 0, -pose.angular_velocity.x(),       //
      -pose.angular_velocity.y(), pose.angular_velocity.x(), 0;
  position = pose.position.head<D>();
  rotation = turn.topLeftCorner<D, D>();
  velocity = pose.velocity.head<D>();
  spin = spin3.topLeftCorner<D, D>();
}

template <int D>
void placeColliders(std::vector<Collider<D>>& colliders, Real time) {
  for (Collider<D>& c : colliders)
    if (c.motion.moves()) c.placeAt(time);
}

template <int D>
Real fastestColliderSpeed(const std::vector<Collider<D>>& colliders, Real domain_diagonal) {
  Real fastest = 0;
  for (const Collider<D>& c : colliders)
    fastest = std::max(fastest, c.motion.fastestSpeedWithin(domain_diagonal));
  return fastest;
}

template Eigen::AlignedBox<Real, 2> boundingBox<2>(const Collider<2>&, Real);
template Eigen::AlignedBox<Real, 3> boundingBox<3>(const Collider<3>&, Real);
template Mat<2> collideAndConstrain<2>(const std::vector<Collider<2>>&, const Vec<2>&, Vec<2>&);
template Mat<3> collideAndConstrain<3>(const std::vector<Collider<3>>&, const Vec<3>&, Vec<3>&);
template Vec<2> collideVelocity<2>(const Vec<2>&, const Vec<2>&, const Vec<2>&, ColliderType, Real);
template Vec<3> collideVelocity<3>(const Vec<3>&, const Vec<3>&, const Vec<3>&, ColliderType, Real);
template struct Collider<2>;
template struct Collider<3>;
template void placeColliders<2>(std::vector<Collider<2>>&, Real);
template void placeColliders<3>(std::vector<Collider<3>>&, Real);
template Real fastestColliderSpeed<2>(const std::vector<Collider<2>>&, Real);
template Real fastestColliderSpeed<3>(const std::vector<Collider<3>>&, Real);

}  // namespace snowsim
