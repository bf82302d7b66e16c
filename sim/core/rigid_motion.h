// A collider's rigid motion over time (docs/scene-format.md, "Moving colliders"): its pose (the
// position of its local origin and the rotation taking its local frame to the world) and the
// velocity of that pose, evaluated at any time from its description: a constant linear
// and angular velocity, or keyframes interpolated linearly in position and by slerp in rotation,
// held before the first key and after the last. Evaluated from the time, never accumulated, so a
// step's pose is exact and the same in every run. Always in 3D: a 2D scene rotates about z.
#pragma once

#include <vector>

#include <Eigen/Geometry>

#include "sim/core/math.h"

namespace snowsim {

// A pose of a keyframed motion: where the local origin is and how the local frame is turned.
struct PoseKey {
  double time = 0;  // s
  Vec3 position{};  // m
  Vec3 rotation{};  // degrees, as RigidMotionDescription::rotation
};

// A rigid motion as a scene describes it: a constant velocity and angular velocity from
// `position` and `rotation` at time 0, or keyframes.
struct RigidMotionDescription {
  Vec3 position{};  // the local origin at time 0 (m)
  Vec3 velocity{};  // m/s
  // Degrees: Euler angles about x, then y, then z (R = Rz Ry Rx); a 2D scene's angle is z's.
  Vec3 rotation{};
  Vec3 angular_velocity{};         // degrees/s about the world axes; 2D: z's
  std::vector<PoseKey> keyframes;  // when given, they alone set the motion
};

struct RigidPose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();            // of the local origin (m)
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // local frame to world
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();            // of the local origin (m/s)
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();    // world axes (rad/s)

  // The velocity of the rigid motion at world point x: v + w x (x - p).
  Eigen::Vector3d surfaceVelocity(const Eigen::Vector3d& x) const {
    return velocity + angular_velocity.cross(x - position);
  }
};

// The rotation of Euler angles in degrees about x, then y, then z (fixed axes): R = Rz Ry Rx,
// Blender's "XYZ" rotation mode.
Eigen::Quaterniond eulerXyzDegrees(const Vec3& degrees);

class RigidMotion {
 public:
  RigidMotion() = default;  // at rest at the origin
  explicit RigidMotion(const RigidMotionDescription& description);

  RigidPose at(double time) const;
  bool moves() const;
  // The fastest a point within `reach` metres of the local origin ever moves: |v| + |w| reach.
  double fastestSpeedWithin(double reach) const;

 private:
  struct Key {
    double time;
    RigidPose pose;  // the pose at the key and the velocity of the segment that starts there
  };
  RigidPose start_;        // no keys: the pose at time 0 and its constant velocities
  std::vector<Key> keys_;  // keyframed: every key, in time order
};

}  // namespace snowsim
