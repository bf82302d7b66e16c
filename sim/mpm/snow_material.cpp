#include "sim/mpm/snow_material.h"

#include <algorithm>
#include <cmath>

namespace snowsim {

Lame hardenedLame(const SnowMaterial& m, Real J_P) {
  const Real e = std::exp(m.xi * (1 - J_P));  // eq. 8
  return {m.mu0() * e, m.lambda0() * e};
}

namespace {

// The cofactor matrix det(F) F^-T, which stays finite for singular F: its columns are the cross
// products of F's other two columns.
Mat<3> cofactor3(const Mat<3>& F) {
  Mat<3> cofactor;
  cofactor.col(0) = F.col(1).cross(F.col(2));
  cofactor.col(1) = F.col(2).cross(F.col(0));
  cofactor.col(2) = F.col(0).cross(F.col(1));
  return cofactor;
}

// 2x2 polar rotation in closed form: R is the rotation by atan2(c - b, a + d) for F = [a b; c d]
// (the rotation closest to F in the Frobenius norm).
Mat<2> polar2(const Mat<2>& F) {
  const Real x = F(0, 0) + F(1, 1);
  const Real y = F(1, 0) - F(0, 1);
  const Real r = std::sqrt(x * x + y * y);
  Mat<2> R;
  if (r == 0) {
    R.setIdentity();
    return R;
  }
  const Real c = x / r, s = y / r;
  R << c, -s, s, c;
  return R;
}

// The rotation by phi from (cos 2phi, sin 2phi), phi in (-pi/2, pi/2]: the half-angle formulas
// without trigonometric calls, taking the square root on the side where it is well conditioned.
Mat<2> halfAngleRotation(Real cos2, Real sin2) {
  Real c, s;
  if (cos2 >= 0) {
    c = std::sqrt(Real(0.5) * (1 + cos2));
    s = sin2 / (2 * c);
  } else {
    s = std::copysign(std::sqrt(Real(0.5) * (1 - cos2)), sin2);
    c = sin2 / (2 * s);
  }
  Mat<2> V;
  V << c, -s, s, c;
  return V;
}

// 2x2 SVD in closed form: F = R S (polar), then S = W diag(sigma) W^T (symmetric eigenproblem),
// so U = R W, V = W.
void svd2(const Mat<2>& F, Mat<2>& U, Vec<2>& sigma, Mat<2>& V) {
  const Mat<2> R = polar2(F);
  const Mat<2> S = R.transpose() * F;  // symmetric
  const Real a = S(0, 0), b = Real(0.5) * (S(0, 1) + S(1, 0)), d = S(1, 1);
  const Real mean = Real(0.5) * (a + d), half = Real(0.5) * (a - d);
  const Real rad = std::sqrt(half * half + b * b);
  sigma << mean + rad, mean - rad;
  V = rad > 0 ? halfAngleRotation(half / rad, b / rad) : Mat<2>::Identity();
  U = R * V;
}

// Diagonalises the symmetric 3x3 A by cyclic Jacobi rotations (Golub and Van Loan, section
// 8.5), accumulating them into V: V^T A_in V = A_out. From a good guess (A nearly diagonal) one
// or two sweeps finish it; from any start at most a handful. A rotation is skipped once its
// off-diagonal entry no longer changes the diagonal (|a_pq| <= 1e-16 sqrt(a_pp a_qq) for the
// positive semi-definite A here), which also ends the sweeps.
void jacobiEigen3(Mat<3>& A, Mat<3>& V) {
  constexpr int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  constexpr int max_sweeps = 12;  // round-off is reached in under ten from any start
  for (int sweep = 0; sweep < max_sweeps; ++sweep) {
    bool rotated = false;
    for (const auto& [p, q] : pairs) {
      const Real apq = A(p, q);
      if (apq * apq <= Real(1e-32) * std::abs(A(p, p) * A(q, q))) continue;
      rotated = true;
      // The rotation that zeroes a_pq: tan of its angle t, the smaller root of
      // t^2 + 2 theta t - 1 = 0 with theta = (a_qq - a_pp) / (2 a_pq).
      const Real theta = (A(q, q) - A(p, p)) / (2 * apq);
      const Real t =
          std::abs(theta) > Real(1e150)
              ? 1 / (2 * theta)
              : std::copysign(Real(1), theta) / (std::abs(theta) + std::sqrt(theta * theta + 1));
      const Real c = 1 / std::sqrt(t * t + 1), s = t * c;
      const int r = 3 - p - q;  // the third axis
      const Real arp = A(r, p), arq = A(r, q);
      A(p, p) -= t * apq;
      A(q, q) += t * apq;
      A(p, q) = A(q, p) = 0;
      A(r, p) = A(p, r) = c * arp - s * arq;
      A(r, q) = A(q, r) = s * arp + c * arq;
      const Vec<3> vp = V.col(p), vq = V.col(q);
      V.col(p) = c * vp - s * vq;
      V.col(q) = s * vp + c * vq;
    }
    if (!rotated) return;
  }
}

// 3x3 SVD from the eigenvectors of F^T F, found by Jacobi rotations starting from the guess V
// (in/out): V the eigenvectors ordered by decreasing eigenvalue, re-orthonormalised so it stays a
// rotation over many warm-started steps; then U by Gram-Schmidt on the columns of F V, which
// stays orthonormal when singular values nearly coincide; the last singular value takes the
// sign of det F.
void svd3(const Mat<3>& F, Mat<3>& U, Vec<3>& sigma, Mat<3>& V) {
  Mat<3> FV = F * V;
  Mat<3> A = FV.transpose() * FV;  // V^T F^T F V, nearly diagonal for a good guess
  jacobiEigen3(A, V);
  // Decreasing eigenvalues; a swap of two columns negates one so that V stays a rotation.
  auto order = [&](int i, int j) {
    if (A(i, i) >= A(j, j)) return;
    std::swap(A(i, i), A(j, j));
    const Vec<3> vi = V.col(i);
    V.col(i) = V.col(j);
    V.col(j) = -vi;
  };
  order(0, 1);
  order(0, 2);
  order(1, 2);
  V.col(0).normalize();
  V.col(1) = (V.col(1) - V.col(0).dot(V.col(1)) * V.col(0)).normalized();
  V.col(2) = V.col(0).cross(V.col(1));
  FV.noalias() = F * V;
  sigma[0] = FV.col(0).norm();
  if (sigma[0] == 0) {  // F = 0
    U.setIdentity();
    sigma.setZero();
    return;
  }
  const Vec<3> u0 = FV.col(0) / sigma[0];
  Vec<3> u1 = FV.col(1) - u0.dot(FV.col(1)) * u0;
  sigma[1] = u1.norm();
  if (sigma[1] > 1e-300) {
    u1 /= sigma[1];
  } else {  // rank one: any unit vector orthogonal to u0
    u1 = u0.unitOrthogonal();
  }
  const Vec<3> u2 = u0.cross(u1);
  sigma[2] = u2.dot(FV.col(2));
  U.col(0) = u0;
  U.col(1) = u1;
  U.col(2) = u2;
}

}  // namespace

template <>
void signedSvd<2>(const Mat<2>& F, Mat<2>& U, Vec<2>& sigma, Mat<2>& V) {
  svd2(F, U, sigma, V);
}
template <>
void signedSvd<3>(const Mat<3>& F, Mat<3>& U, Vec<3>& sigma, Mat<3>& V) {
  V.setIdentity();
  svd3(F, U, sigma, V);
}

template <>
void signedSvdFrom<2>(const Mat<2>& F, Mat<2>& U, Vec<2>& sigma, Mat<2>& V) {
  svd2(F, U, sigma, V);  // closed form: nothing to gain from a guess
}
template <>
void signedSvdFrom<3>(const Mat<3>& F, Mat<3>& U, Vec<3>& sigma, Mat<3>& V) {
  svd3(F, U, sigma, V);
}

template <>
Mat<2> polarRotation<2>(const Mat<2>& F) {
  return polar2(F);
}
template <>
Mat<3> polarRotation<3>(const Mat<3>& F) {
  Mat<3> U, V;
  Vec<3> s;
  signedSvd<3>(F, U, s, V);
  return U * V.transpose();
}

template <int D>
Mat<D> fixedCorotatedPiola(const Mat<D>& F_E, const Lame& lame) {
  const Mat<D> R = polarRotation<D>(F_E);
  const Real J = F_E.determinant();
  // J F^{-T} is the cofactor matrix of F, which stays finite for singular F.
  Mat<D> JFinvT;
  if constexpr (D == 2) {
    JFinvT << F_E(1, 1), -F_E(1, 0), -F_E(0, 1), F_E(0, 0);
  } else {
    JFinvT = cofactor3(F_E);
  }
  return 2 * lame.mu * (F_E - R) + lame.lambda * (J - 1) * JFinvT;
}

template <int D>
Mat<D> fixedCorotatedKirchhoff(const Mat<D>& F_E, const Mat<D>& R_E, const Lame& lame) {
  const Real J = F_E.determinant();
  return 2 * lame.mu * (F_E - R_E) * F_E.transpose() +
         lame.lambda * (J - 1) * J * Mat<D>::Identity();
}

template <int D>
Real plasticReturnMapping(const SnowMaterial& m, Mat<D>& F_E, Mat<D>& F_P) {
  const Mat<D> F = F_E * F_P;
  Mat<D> U, V;
  Vec<D> sigma;
  signedSvd<D>(F_E, U, sigma, V);
  for (int a = 0; a < D; ++a)
    sigma[a] = std::clamp(sigma[a], 1 - m.theta_c, 1 + m.theta_s);  // eq. 11
  F_E = U * sigma.asDiagonal() * V.transpose();
  F_P = V * sigma.cwiseInverse().asDiagonal() * U.transpose() * F;  // eq. 12
  return F_P.determinant();
}

Real plasticReturnMappingJ(const SnowMaterial& m, Mat<2>& F_E, Real J_P, Mat<2>& R_E) {
  // F = [a b; c d] splits into a scaled rotation and a symmetric traceless part,
  // F = (r/2) R + A with r = |(a + d, c - b)|, R its rotation and A = [e g; g -e],
  // e = (a - d)/2, g = (b + c)/2. Then F = R S with S = (r/2) I + R^T A, whose eigenvalues, the
  // signed singular values, are r/2 +- |(e, g)|; and replacing them by clamped ones gives
  // F' = mean' R + (half-difference' / |(e, g)|) A. Two independent square roots, no SVD.
  const Real x = F_E(0, 0) + F_E(1, 1), y = F_E(1, 0) - F_E(0, 1);
  const Real e = Real(0.5) * (F_E(0, 0) - F_E(1, 1)), g = Real(0.5) * (F_E(0, 1) + F_E(1, 0));
  const Real r = std::sqrt(x * x + y * y), rad = std::sqrt(e * e + g * g);
  const Real s0 = Real(0.5) * r + rad, s1 = Real(0.5) * r - rad;
  const Real lo = 1 - m.theta_c, hi = 1 + m.theta_s;
  const Real c0 = std::clamp(s0, lo, hi), c1 = std::clamp(s1, lo, hi);  // eq. 11
  if (r > 0) {
    R_E << x, -y, y, x;
    R_E /= r;
  } else {
    R_E.setIdentity();  // as polarRotation: any rotation will do
  }
  if (c0 == s0 && c1 == s1) return J_P;  // inside the elastic range: F_E stays as it is
  F_E = Real(0.5) * (c0 + c1) * R_E;
  if (rad > 0) {
    const Real k = Real(0.5) * (c0 - c1) / rad;
    F_E(0, 0) += k * e;
    F_E(1, 1) -= k * e;
    F_E(0, 1) += k * g;
    F_E(1, 0) += k * g;
  }
  // det F = J_E J_P is unchanged by the return mapping: J_P' = J_P J_trial / J_clamped.
  return J_P * (s0 * s1) / (c0 * c1);
}

namespace {

// The polar rotation of F by Newton's iteration X <- (X + X^-T) / 2 (Higham 1986), started from F
// itself: it squares the distance of each singular value from 1 per iteration, so the few percent
// that snow's F_E strays from a rotation take four iterations to round-off. False if det F <= 0
// (the polar factor would be a reflection) or it does not converge in a few iterations.
bool newtonPolar3(const Mat<3>& F, Mat<3>& R) {
  Mat<3> X = F;
  for (int iteration = 0; iteration < 8; ++iteration) {
    const Mat<3> cofactor = cofactor3(X);  // det X X^-T
    const Real det = X.col(0).dot(cofactor.col(0));
    if (!(det > 0)) return false;
    const Mat<3> next = Real(0.5) * (X + cofactor / det);
    const Real change = (next - X).squaredNorm();
    X = next;
    if (change <= Real(1e-28)) {  // the next change would be ~1e-28: X is exact to round-off
      R = X;
      return true;
    }
  }
  return false;
}

// Whether every eigenvalue of the symmetric part of S lies in [lo, hi] (S = R^T F has the
// singular values of F as eigenvalues): S - lo I and hi I - S positive definite, by their leading
// principal minors (Sylvester's criterion).
bool eigenvaluesWithin(const Mat<3>& S, Real lo, Real hi) {
  const Mat<3> sym = Real(0.5) * (S + S.transpose());
  auto positiveDefinite = [](const Mat<3>& A) {
    return A(0, 0) > 0 && A(0, 0) * A(1, 1) - A(0, 1) * A(1, 0) > 0 && A.determinant() > 0;
  };
  return positiveDefinite(sym - lo * Mat<3>::Identity()) &&
         positiveDefinite(hi * Mat<3>::Identity() - sym);
}

}  // namespace

Real plasticReturnMappingJ(const SnowMaterial& m, Mat<3>& F_E, Real J_P, Mat<3>& R_E, Mat<3>& V_E) {
  // Most snow is within its elastic range most of the time: its polar rotation comes cheaper than
  // an SVD, and when the singular values are inside the bounds F_E and J_P stay as they are.
  Mat<3> R;
  if (newtonPolar3(F_E, R) &&
      eigenvaluesWithin(R.transpose() * F_E, 1 - m.theta_c, 1 + m.theta_s)) {
    R_E = R;
    return J_P;
  }
  Mat<3> U;
  Mat<3>& V = V_E;
  Vec<3> sigma;
  signedSvdFrom<3>(F_E, U, sigma, V);
  Real J_trial = 1, J_clamped = 1;
  for (int a = 0; a < 3; ++a) {
    J_trial *= sigma[a];
    sigma[a] = std::clamp(sigma[a], 1 - m.theta_c, 1 + m.theta_s);  // eq. 11
    J_clamped *= sigma[a];
  }
  F_E = U * sigma.asDiagonal() * V.transpose();
  R_E = U * V.transpose();
  return J_P * J_trial / J_clamped;  // as in 2D
}

template Mat<2> fixedCorotatedPiola<2>(const Mat<2>&, const Lame&);
template Mat<3> fixedCorotatedPiola<3>(const Mat<3>&, const Lame&);
template Mat<2> fixedCorotatedKirchhoff<2>(const Mat<2>&, const Mat<2>&, const Lame&);
template Mat<3> fixedCorotatedKirchhoff<3>(const Mat<3>&, const Mat<3>&, const Lame&);
template Real plasticReturnMapping<2>(const SnowMaterial&, Mat<2>&, Mat<2>&);
template Real plasticReturnMapping<3>(const SnowMaterial&, Mat<3>&, Mat<3>&);

}  // namespace snowsim
