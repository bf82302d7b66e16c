#include "sim/core/rigid_motion.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace snowsim {

namespace {

constexpr double kRadiansPerDegree = std::numbers::pi / 180;

Eigen::Vector3d vector3(const Vec3& v) {
  return {v[0], v[1], v[2]};
}

// The rotation by the rotation vector `w` (axis times angle, radians).
Eigen::Quaterniond rotationBy(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle == 0) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle));
}

// The rotation vector (axis times angle, radians, the short way round) taking `from` to `to`.
Eigen::Vector3d rotationBetween(const Eigen::Quaterniond& from, const Eigen::Quaterniond& to) {
  Eigen::Quaterniond q = to * from.conjugate();
  if (q.w() < 0) q.coeffs() = -q.coeffs();  // the short way, as slerp goes
  const Eigen::AngleAxisd turn(q);
  return turn.angle() * turn.axis();
}

}  // namespace

Eigen::Quaterniond eulerXyzDegrees(const Vec3& degrees) {
  using Eigen::AngleAxisd, Eigen::Vector3d;
  return Eigen::Quaterniond(AngleAxisd(degrees[2] * kRadiansPerDegree, Vector3d::UnitZ()) *
                            AngleAxisd(degrees[1] * kRadiansPerDegree, Vector3d::UnitY()) *
                            AngleAxisd(degrees[0] * kRadiansPerDegree, Vector3d::UnitX()));
}

RigidMotion::RigidMotion(const RigidMotionDescription& description) {
  if (description.keyframes.empty()) {
    start_.position = vector3(description.position);
    start_.rotation = eulerXyzDegrees(description.rotation);
    start_.velocity = vector3(description.velocity);
    start_.angular_velocity = kRadiansPerDegree * vector3(description.angular_velocity);
    return;
  }
  for (const PoseKey& k : description.keyframes) {
    Key key{k.time, {}};
    key.pose.position = vector3(k.position);
    key.pose.rotation = eulerXyzDegrees(k.rotation);
    keys_.push_back(key);
  }
  for (size_t i = 0; i + 1 < keys_.size(); ++i) {
    RigidPose& a = keys_[i].pose;
    const RigidPose& b = keys_[i + 1].pose;
    const double span = keys_[i + 1].time - keys_[i].time;
    a.velocity = (b.position - a.position) / span;
    a.angular_velocity = rotationBetween(a.rotation, b.rotation) / span;
  }
  start_ = keys_.front().pose;
}

RigidPose RigidMotion::at(double time) const {
  if (keys_.empty()) {
    RigidPose pose = start_;
    pose.position += time * start_.velocity;
    pose.rotation = rotationBy(time * start_.angular_velocity) * start_.rotation;
    return pose;
  }
  if (time < keys_.front().time) {  // held: at rest before the first key
    RigidPose pose = keys_.front().pose;
    pose.velocity.setZero();
    pose.angular_velocity.setZero();
    return pose;
  }
  // The segment [key i, key i + 1) holding the time; the last key holds on (its velocity is 0).
  const auto after = std::upper_bound(keys_.begin(), keys_.end(), time,
                                      [](double t, const Key& k) { return t < k.time; });
  const Key& key = *(after - 1);
  RigidPose pose = key.pose;
  if (after == keys_.end()) return pose;
  const double elapsed = time - key.time;
  pose.position += elapsed * key.pose.velocity;
  pose.rotation = key.pose.rotation.slerp(elapsed / (after->time - key.time), after->pose.rotation);
  return pose;
}

bool RigidMotion::moves() const {
  return fastestSpeedWithin(1) > 0;
}

double RigidMotion::fastestSpeedWithin(double reach) const {
  const auto speed = [&](const RigidPose& p) {
    return p.velocity.norm() + p.angular_velocity.norm() * reach;
  };
  double fastest = speed(start_);
  for (const Key& k : keys_) fastest = std::max(fastest, speed(k.pose));
  return fastest;
}

}  // namespace snowsim
