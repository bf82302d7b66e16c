// The differential of the fixed-corotated first Piola stress (Stomakhin et al. 2013, section 6 and
// its technical report "Energetically consistent invertible elasticity"), with the hardened Lamé
// parameters held fixed within the step (J_P frozen). Pure functions, used by the semi-implicit
// solve's matrix-free operator (paper eq. 9 linearised).
#pragma once

#include "sim/mpm/snow_material.h"

namespace snowsim {

// dR of the polar decomposition F = R S: with F = U Sigma V^T, R = U V^T, R^T dR = W is skew and
// solves W S + S W = R^T dF - dF^T R; in the basis of V this is W'_ij (sigma_i + sigma_j) = K'_ij.
template <int D>
Mat<D> polarRotationDifferential(const Mat<D>& F, const Mat<D>& dF);

// d(J F^{-T}) = J [(F^{-T} : dF) F^{-T} - F^{-T} dF^T F^{-T}] (derivative of the cofactor matrix).
template <int D>
Mat<D> cofactorDifferential(const Mat<D>& F, const Mat<D>& dF);

// dP = 2 mu (dF - dR) + lambda (J F^{-T} : dF) J F^{-T} + lambda (J - 1) d(J F^{-T})
// (differential of P = 2 mu (F - R) + lambda (J - 1) J F^{-T}, mu and lambda fixed).
template <int D>
Mat<D> fixedCorotatedPiolaDifferential(const Mat<D>& F, const Lame& lame, const Mat<D>& dF);

// The same differential as a matrix on column-major vec(dF): vec(dP) = C vec(dF), one SVD for all
// D^2 columns. The semi-implicit solve forms it once a step instead of once an iteration.
template <int D>
using Tangent = Eigen::Matrix<Real, D * D, D * D>;
template <int D>
Tangent<D> fixedCorotatedPiolaTangent(const Mat<D>& F, const Lame& lame);

}  // namespace snowsim
