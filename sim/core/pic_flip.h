// The PIC/FLIP blend of a particle's new velocity (Zhu and Bridson 2005; Stomakhin et al. 2013,
// section 4 step 8), shared by every solver that transfers without an affine velocity.
#pragma once

#include "sim/core/math.h"

namespace snowsim {

// v_p = (1 - alpha) v_PIC + alpha (v_p + sum_i w_ip (v_i - v_i^old)): pic is sum_i w_ip v_i,
// increment the FLIP change sum_i w_ip (v_i - v_i^old).
template <int D, class T = Real>
Vec<D, T> picFlipBlend(const Vec<D, T>& v_p, const Vec<D, T>& pic, const Vec<D, T>& increment,
                       T alpha) {
  return (1 - alpha) * pic + alpha * (v_p + increment);
}

}  // namespace snowsim
