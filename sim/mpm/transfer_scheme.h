// The particle-grid transfers of MPM as types, chosen once per step like the B-spline kernel
// (withKernel), so the per-particle functions branch at compile time.
#pragma once

#include "sim/core/math.h"
#include "sim/core/stencil.h"
#include "sim/scene/scene.h"

namespace snowsim {

// PIC/FLIP blend (Stomakhin et al. 2013, section 4 steps 1 and 8): no affine velocity; the
// stress enters as a grid force.
struct PicFlipTransfer {
  static constexpr bool affine = false, mls = false;
};
// APIC (Jiang et al. 2015): the affine velocity C_p rides along; the stress is a grid force.
struct ApicTransfer {
  static constexpr bool affine = true, mls = false;
};
// MLS-MPM (Hu et al. 2018): APIC whose scatter also carries dt times the force.
struct MlsTransfer {
  static constexpr bool affine = true, mls = true;
};

// Runs f.template operator()<Transfer, Kernel>() for the transfer and kernel chosen at run time.
template <class F>
decltype(auto) withTransferAndKernel(MpmTransfer transfer, KernelType kernel, F&& f) {
  return withKernel(kernel, [&]<class Kernel>() -> decltype(auto) {
    if (transfer == MpmTransfer::PicFlip) return f.template operator()<PicFlipTransfer, Kernel>();
    if (transfer == MpmTransfer::Apic) return f.template operator()<ApicTransfer, Kernel>();
    return f.template operator()<MlsTransfer, Kernel>();
  });
}

// D_p^{-1} of APIC (Jiang et al. 2015, after eq. 11): 4 / h^2 for quadratic, 3 / h^2 for cubic.
template <class Kernel>
Real inertiaInverse(Real h) {
  return (Kernel::support == 3 ? Real(4) : Real(3)) / (h * h);
}

}  // namespace snowsim
