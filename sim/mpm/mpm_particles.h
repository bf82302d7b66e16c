// The particles of MPM snow: the common attributes and the state the snow model keeps per
// particle (Stomakhin et al. 2013, section 4), all in one container, so that whatever reorders
// the particles reorders every array.
#pragma once

#include <tuple>
#include <utility>
#include <vector>

#include "sim/core/particles.h"
#include "sim/mpm/snow_material.h"

namespace snowsim {

template <int D>
struct MpmParticles : Particles<D> {
  std::vector<Mat<D>> F_E;  // elastic deformation gradient
  std::vector<Mat<D>> R_E;  // its polar rotation, from the last return mapping
  std::vector<Mat<D>> V_E;  // 3D: its right singular vectors, the next SVD's starting guess
  std::vector<Real> J_P;    // det F_P, plastic volume ratio
  std::vector<Mat<D>> C;    // affine velocity (APIC/MLS), or grad v (PIC/FLIP)
  std::vector<Lame> lame;   // hardened Lamé parameters (eq. 8), refreshed with J_P

  // One array of each element type, for a reordering that gathers into a spare array and swaps.
  using SpareArrays = std::tuple<std::vector<Vec<D>>, std::vector<Mat<D>>, std::vector<Real>,
                                 std::vector<int>, std::vector<Lame>>;

  MpmParticles() = default;
  // The snow starts unstrained: F_E = I, J_P = 1, no affine velocity.
  MpmParticles(Particles<D> particles, const SnowMaterial& material)
      : Particles<D>(std::move(particles)) {
    const int n = this->size();
    F_E.assign(n, Mat<D>::Identity());
    R_E.assign(n, Mat<D>::Identity());
    if constexpr (D == 3) V_E.assign(n, Mat<D>::Identity());
    J_P.assign(n, 1);
    C.assign(n, Mat<D>::Zero());
    lame.assign(n, hardenedLame(material, 1));
  }

  // Every array, empty ones included (V_E in 2D): a reordering skips those.
  template <class F>
  void forEachArray(F&& f) {
    Particles<D>::forEachArray(f);
    f(F_E), f(R_E), f(V_E), f(J_P), f(C), f(lame);
  }
};

}  // namespace snowsim
