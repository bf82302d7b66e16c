// Which colliders a point may touch, cheaply: Collider::phi is a call and a rotation, and most
// particles and grid nodes are far from every collider. Set with the colliders' poses each step;
// a point screened out is one phi would put outside its collider.
#pragma once

#include <vector>

#include "sim/core/collider.h"
#include "sim/core/math.h"

namespace snowsim {

template <int D>
class ColliderScreens {
 public:
  // Per collider, a test that passes over it for a point well clear of it: a half space's plane
  // in world coordinates, a sphere's, a box's or a mesh's world-axis bounding box, each with a
  // margin far beyond the round-off between the two ways of computing the distance. Drums are
  // always tested (their box spans every axis). domain_diagonal sets the margin's scale.
  void place(const std::vector<Collider<D>>& colliders, Real domain_diagonal);

  // Whether collider c may hold x (phi <= 0).
  bool mayTouch(int c, const Vec<D>& x) const {
    const Screen& s = screens_[c];
    if (s.half_space) return s.normal.dot(x) - s.offset <= s.margin;
    // Written so that a NaN position passes, and meets phi as it would without the screen.
    return !((x.array() < s.lo.array()).any() || (x.array() > s.hi.array()).any());
  }
  // The colliders to screen one by one at x: a box test clears most points of every
  // axis-aligned half space (the domain walls) at once, leaving only the colliders it does not
  // cover.
  const std::vector<int>& near(const Vec<D>& x) const {
    const bool clear =
        (x.array() > clear_lo_.array()).all() && (x.array() < clear_hi_.array()).all();
    return clear ? uncovered_ : every_;
  }

 private:
  struct Screen {
    Vec<D> normal = Vec<D>::Zero();
    Real offset = 0, margin = 0;
    bool half_space = false;
    Vec<D> lo, hi;  // bounding box, margin included
  };
  std::vector<Screen> screens_;
  Vec<D> clear_lo_, clear_hi_;
  std::vector<int> every_, uncovered_;
};

}  // namespace snowsim
