// The particles of MPM snow: the common attributes and the state the snow model keeps per
// particle (Stomakhin et al. 2013, section 4), all in one container, so that whatever reorders
// the particles reorders every array.
#pragma once

#include <cstdint>
#include <type_traits>
#include <utility>
#include <vector>

#include "sim/core/particles.h"
#include "sim/mpm/snow_material.h"

namespace snowsim {

// The particles in the precision T of a solver's state.
template <class T, int D>
Particles<D, T> inPrecision(Particles<D> particles) {
  if constexpr (std::is_same_v<T, Real>) {
    return particles;
  } else {
    Particles<D, T> converted;
    convertParticles(particles, converted);
    return converted;
  }
}

// T: the scalar of the state, double or float (mpm.precision).
template <int D, class T = Real>
struct MpmParticles : Particles<D, T> {
  std::vector<Mat<D, T>> F_E;  // elastic deformation gradient
  // The Kirchhoff stress P F_E^T (symmetric) of the last return mapping's F_E, which the next
  // scatter spreads: computed where F_E and its rotation are at hand; a third of the F_E and
  // rotation the scatter would otherwise read.
  std::vector<Symmetric<D, T>> tau;
  std::vector<T> J_P;        // det F_P, plastic volume ratio
  std::vector<Mat<D, T>> C;  // affine velocity (APIC/MLS), or grad v (PIC/FLIP)
  std::vector<T>
      hardening;  // hardeningFactor: e^{xi (1 - J_P)} bounded (eq. 8), refreshed with J_P
  // Auto-sleep (mpm.auto_sleep): the steps in a row the particle and its stencil's nodes have
  // moved slower than the sleep speed; asleep once it reaches the sleep steps. Empty when off.
  std::vector<int> calm_steps;
  // Open cracks with auto-sleep: what the particle's crack scatter last read of the damage field
  // (CrackOpening::Reading: its damage gradient, the side it takes at each node, what it takes),
  // which it keeps while it sleeps. Empty otherwise.
  std::vector<Vec<D, T>> crack_gradient;
  std::vector<std::uint64_t> crack_side_bits;
  std::vector<char> crack_flags;

  MpmParticles() = default;
  // The snow starts unstrained: F_E = I, J_P = 1, no stress, no affine velocity.
  MpmParticles(Particles<D, T> particles, const SnowMaterial& material)
      : Particles<D, T>(std::move(particles)) {
    const int n = this->size();
    F_E.assign(n, Mat<D, T>::Identity());
    tau.assign(n, Symmetric<D, T>{});
    J_P.assign(n, 1);
    C.assign(n, Mat<D, T>::Zero());
    hardening.assign(n, hardeningFactor<T>(material, 1));
  }

  // Every array, empty ones included (calm_steps without auto-sleep, the crack ones without cracks
  // and sleep): a reordering skips those.
  template <class F>
  void forEachArray(F&& f) {
    Particles<D, T>::forEachArray(f);
    f(F_E), f(tau), f(J_P), f(C), f(hardening), f(calm_steps);
    f(crack_gradient), f(crack_side_bits), f(crack_flags);
  }
};

}  // namespace snowsim
