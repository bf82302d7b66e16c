#include "sim/mpm/stress_differential.h"

#include <algorithm>
#include <cmath>

namespace snowsim {

namespace {

// J F^{-T}, the cofactor matrix of F, finite for singular F.
template <int D>
Mat<D> cofactor(const Mat<D>& F) {
  Mat<D> c;
  if constexpr (D == 2) {
    c << F(1, 1), -F(1, 0), -F(0, 1), F(0, 0);
  } else {
    c.col(0) = F.col(1).cross(F.col(2));
    c.col(1) = F.col(2).cross(F.col(0));
    c.col(2) = F.col(0).cross(F.col(1));
  }
  return c;
}

// dR from the SVD of F, for any number of dF against one decomposition.
template <int D>
Mat<D> polarRotationDifferentialFromSvd(const Mat<D>& U, const Vec<D>& sigma, const Mat<D>& V,
                                        const Mat<D>& dF) {
  // R^T dF - dF^T R in the V basis: V^T (R^T dF - dF^T R) V = U^T dF V - V^T dF^T U.
  const Mat<D> M = U.transpose() * dF * V;
  const Mat<D> K = M - M.transpose();
  Mat<D> W = Mat<D>::Zero();
  for (int i = 0; i < D; ++i)
    for (int j = 0; j < D; ++j) {
      if (i == j) continue;
      // sigma_i + sigma_j = 0 only for an inverted, degenerate F: R is not differentiable there.
      const Real s = sigma[i] + sigma[j];
      W(i, j) = K(i, j) / (std::abs(s) > 1e-12 ? s : std::copysign(Real(1e-12), s));
    }
  // dR = R (V W' V^T) = U W' V^T.
  return U * W * V.transpose();
}

}  // namespace

template <int D>
Mat<D> polarRotationDifferential(const Mat<D>& F, const Mat<D>& dF) {
  Mat<D> U, V;
  Vec<D> sigma;
  signedSvd<D>(F, U, sigma, V);
  return polarRotationDifferentialFromSvd<D>(U, sigma, V, dF);
}

template <int D>
Mat<D> cofactorDifferential(const Mat<D>& F, const Mat<D>& dF) {
  if constexpr (D == 2) {
    return cofactor<2>(dF);  // the 2x2 cofactor is linear in F
  } else {
    // d cof(F) is the linear part of cof(F + dF): columns dF_b x F_c + F_b x dF_c.
    Mat<3> d;
    for (int a = 0; a < 3; ++a) {
      const int b = (a + 1) % 3, c = (a + 2) % 3;
      d.col(a) = dF.col(b).cross(F.col(c)) + F.col(b).cross(dF.col(c));
    }
    return d;
  }
}

namespace {

// F decomposed once for any number of differentials.
template <int D>
struct Decomposed {
  explicit Decomposed(const Mat<D>& F_) : F(F_), J(F_.determinant()), JFinvT(cofactor<D>(F_)) {
    signedSvd<D>(F, U, sigma, V);
  }
  // dP = 2 mu (dF - dR) + lambda (J F^{-T} : dF) J F^{-T} + lambda (J - 1) d(J F^{-T}).
  Mat<D> piolaDifferential(const Lame& lame, const Mat<D>& dF) const {
    return 2 * lame.mu * (dF - polarRotationDifferentialFromSvd<D>(U, sigma, V, dF)) +
           lame.lambda * JFinvT.cwiseProduct(dF).sum() * JFinvT +
           lame.lambda * (J - 1) * cofactorDifferential<D>(F, dF);
  }
  const Mat<D>& F;
  Real J;
  Mat<D> JFinvT, U, V;
  Vec<D> sigma;
};

}  // namespace

template <int D>
Mat<D> fixedCorotatedPiolaDifferential(const Mat<D>& F, const Lame& lame, const Mat<D>& dF) {
  return Decomposed<D>(F).piolaDifferential(lame, dF);
}

template <int D>
Tangent<D> fixedCorotatedPiolaTangent(const Mat<D>& F, const Lame& lame) {
  const Decomposed<D> decomposed(F);
  Tangent<D> C;
  for (int j = 0; j < D * D; ++j) {
    Mat<D> dF = Mat<D>::Zero();
    dF(j % D, j / D) = 1;  // column-major, as Eigen::Map reads a Mat<D>
    const Mat<D> dP = decomposed.piolaDifferential(lame, dF);
    C.col(j) = Eigen::Map<const Eigen::Matrix<Real, D * D, 1>>(dP.data());
  }
  return C;
}

template Mat<2> polarRotationDifferential<2>(const Mat<2>&, const Mat<2>&);
template Mat<3> polarRotationDifferential<3>(const Mat<3>&, const Mat<3>&);
template Mat<2> cofactorDifferential<2>(const Mat<2>&, const Mat<2>&);
template Mat<3> cofactorDifferential<3>(const Mat<3>&, const Mat<3>&);
template Mat<2> fixedCorotatedPiolaDifferential<2>(const Mat<2>&, const Lame&, const Mat<2>&);
template Mat<3> fixedCorotatedPiolaDifferential<3>(const Mat<3>&, const Lame&, const Mat<3>&);
template Tangent<2> fixedCorotatedPiolaTangent<2>(const Mat<2>&, const Lame&);
template Tangent<3> fixedCorotatedPiolaTangent<3>(const Mat<3>&, const Lame&);

}  // namespace snowsim
