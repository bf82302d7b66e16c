#include "sim/core/collider_screen.h"

#include <cmath>
#include <limits>

namespace snowsim {

template <int D>
void ColliderScreens<D>::place(const std::vector<Collider<D>>& colliders, Real domain_diagonal) {
  screens_.resize(colliders.size());
  // Relative round-off of phi is about 1e-16 of the coordinates' size: 1e-9 leaves room.
  const Real margin = 1e-9 * (1 + domain_diagonal);
  for (size_t c = 0; c < colliders.size(); ++c) {
    const Collider<D>& collider = colliders[c];
    Screen& screen = screens_[c];
    screen.half_space = collider.shape == ColliderShape::HalfSpace;
    screen.normal = collider.rotation * collider.normal;
    screen.offset = screen.normal.dot(collider.position);
    screen.margin = margin * (1 + collider.position.norm());
    const Eigen::AlignedBox<Real, D> bounds = boundingBox(collider, screen.margin);
    screen.lo = bounds.min();
    screen.hi = bounds.max();
  }
  clear_lo_.setConstant(-std::numeric_limits<Real>::infinity());
  clear_hi_.setConstant(std::numeric_limits<Real>::infinity());
  every_.clear();
  uncovered_.clear();
  for (int c = 0; c < static_cast<int>(colliders.size()); ++c) {
    every_.push_back(c);
    const Screen& screen = screens_[c];
    int axis = -1;  // the axis of an axis-aligned half space's normal
    for (int a = 0; a < D; ++a)
      if (screen.half_space && std::abs(screen.normal[a]) == 1) axis = a;
    if (axis < 0 || screen.normal.squaredNorm() != 1) {
      uncovered_.push_back(c);
      continue;
    }
    // Clear of it: normal[axis] x[axis] > offset + margin, where mayTouch is false.
    const Real bound = screen.offset + screen.margin;
    if (screen.normal[axis] > 0)
      clear_lo_[axis] = std::max(clear_lo_[axis], bound);
    else
      clear_hi_[axis] = std::min(clear_hi_[axis], -bound);
  }
}

template class ColliderScreens<2>;
template class ColliderScreens<3>;

}  // namespace snowsim
