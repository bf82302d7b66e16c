#include "sim/mpm/snow_material.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace snowsim {

template <class T>
T hardeningFactor(const SnowMaterial& m, std::type_identity_t<T> J_P) {
  const T bounded = std::clamp(  // eq. 8, bounded
      std::exp(T(m.xi) * (1 - J_P)), T(m.hardening_min),
      T(std::min<Real>(m.hardening_max, std::numeric_limits<T>::max())));
  return m.fracture_strain > 0 ? bounded * strengthLeft<T>(m, J_P) : bounded;
}

namespace {

// Round-off thresholds of the iterations below, per precision.
template <class T>
struct Tolerance;
template <>
struct Tolerance<double> {
  static constexpr double jacobi = 1e-32;  // a_pq^2 relative to a_pp a_qq: negligible
  static constexpr double newton = 1e-28;  // squared change after which Newton is exact
  static constexpr double rank = 1e-300;   // a singular value taken as zero
  static constexpr double huge = 1e150;    // |theta| whose square would overflow
};
template <>
struct Tolerance<float> {
  static constexpr float jacobi = 1e-14f;
  static constexpr float newton = 1e-8f;
  static constexpr float rank = 1e-30f;
  static constexpr float huge = 1e18f;
};

// The cofactor matrix det(F) F^-T, which stays finite for singular F: its columns are the cross
// products of F's other two columns. Inlined: each Newton iteration of the polar rotation takes
// one, and a call costs a fifth of its arithmetic.
template <class T>
[[gnu::always_inline]] inline Mat<3, T> cofactor3(const Mat<3, T>& F) {
  Mat<3, T> cofactor;
  cofactor.col(0) = F.col(1).cross(F.col(2));
  cofactor.col(1) = F.col(2).cross(F.col(0));
  cofactor.col(2) = F.col(0).cross(F.col(1));
  return cofactor;
}

// 2x2 polar rotation in closed form: R is the rotation by atan2(c - b, a + d) for F = [a b; c d]
// (the rotation closest to F in the Frobenius norm).
template <class T>
Mat<2, T> polar2(const Mat<2, T>& F) {
  const T x = F(0, 0) + F(1, 1);
  const T y = F(1, 0) - F(0, 1);
  const T r = std::sqrt(x * x + y * y);
  Mat<2, T> R;
  if (r == 0) {
    R.setIdentity();
    return R;
  }
  const T c = x / r, s = y / r;
  R << c, -s, s, c;
  return R;
}

// The rotation by phi from (cos 2phi, sin 2phi), phi in (-pi/2, pi/2]: the half-angle formulas
// without trigonometric calls, taking the square root on the side where it is well conditioned.
template <class T>
Mat<2, T> halfAngleRotation(T cos2, T sin2) {
  T c, s;
  if (cos2 >= 0) {
    c = std::sqrt(T(0.5) * (1 + cos2));
    s = sin2 / (2 * c);
  } else {
    s = std::copysign(std::sqrt(T(0.5) * (1 - cos2)), sin2);
    c = sin2 / (2 * s);
  }
  Mat<2, T> V;
  V << c, -s, s, c;
  return V;
}

// 2x2 SVD in closed form: F = R S (polar), then S = W diag(sigma) W^T (symmetric eigenproblem),
// so U = R W, V = W.
template <class T>
void svd2(const Mat<2, T>& F, Mat<2, T>& U, Vec<2, T>& sigma, Mat<2, T>& V) {
  const Mat<2, T> R = polar2(F);
  const Mat<2, T> S = R.transpose() * F;  // symmetric
  const T a = S(0, 0), b = T(0.5) * (S(0, 1) + S(1, 0)), d = S(1, 1);
  const T mean = T(0.5) * (a + d), half = T(0.5) * (a - d);
  const T rad = std::sqrt(half * half + b * b);
  sigma << mean + rad, mean - rad;
  V = rad > 0 ? halfAngleRotation(half / rad, b / rad) : Mat<2, T>::Identity();
  U = R * V;
}

// Diagonalises the symmetric 3x3 A by cyclic Jacobi rotations (Golub and Van Loan, section
// 8.5), accumulating them into V: V^T A_in V = A_out. A handful of sweeps finish it. A rotation is
// skipped once its off-diagonal entry no longer changes the diagonal (|a_pq| <= 1e-16 sqrt(a_pp
// a_qq) for the positive semi-definite A here), which also ends the sweeps.
template <class T>
void jacobiEigen3(Mat<3, T>& A, Mat<3, T>& V) {
  constexpr int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  constexpr int max_sweeps = 12;  // round-off is reached in under ten from any start
  for (int sweep = 0; sweep < max_sweeps; ++sweep) {
    bool rotated = false;
    for (const auto& [p, q] : pairs) {
      const T apq = A(p, q);
      if (apq * apq <= Tolerance<T>::jacobi * std::abs(A(p, p) * A(q, q))) continue;
      rotated = true;
      // The rotation that zeroes a_pq: tan of its angle t, the smaller root of
      // t^2 + 2 theta t - 1 = 0 with theta = (a_qq - a_pp) / (2 a_pq).
      const T theta = (A(q, q) - A(p, p)) / (2 * apq);
      const T t =
          std::abs(theta) > Tolerance<T>::huge
              ? 1 / (2 * theta)
              : std::copysign(T(1), theta) / (std::abs(theta) + std::sqrt(theta * theta + 1));
      const T c = 1 / std::sqrt(t * t + 1), s = t * c;
      const int r = 3 - p - q;  // the third axis
      const T arp = A(r, p), arq = A(r, q);
      A(p, p) -= t * apq;
      A(q, q) += t * apq;
      A(p, q) = A(q, p) = 0;
      A(r, p) = A(p, r) = c * arp - s * arq;
      A(r, q) = A(q, r) = s * arp + c * arq;
      const Vec<3, T> vp = V.col(p), vq = V.col(q);
      V.col(p) = c * vp - s * vq;
      V.col(q) = s * vp + c * vq;
    }
    if (!rotated) return;
  }
}

// 3x3 SVD from the eigenvectors of F^T F, found by Jacobi rotations: V the eigenvectors ordered by
// decreasing eigenvalue, re-orthonormalised so that it is a rotation to round-off; then U by
// Gram-Schmidt on the columns of F V, which stays orthonormal when singular values nearly
// coincide; the last singular value takes the sign of det F.
template <class T>
void svd3(const Mat<3, T>& F, Mat<3, T>& U, Vec<3, T>& sigma, Mat<3, T>& V) {
  Mat<3, T> A = F.transpose() * F;
  V.setIdentity();
  jacobiEigen3(A, V);
  // Decreasing eigenvalues; a swap of two columns negates one so that V stays a rotation.
  auto order = [&](int i, int j) {
    if (A(i, i) >= A(j, j)) return;
    std::swap(A(i, i), A(j, j));
    const Vec<3, T> vi = V.col(i);
    V.col(i) = V.col(j);
    V.col(j) = -vi;
  };
  order(0, 1);
  order(0, 2);
  order(1, 2);
  V.col(0).normalize();
  V.col(1) = (V.col(1) - V.col(0).dot(V.col(1)) * V.col(0)).normalized();
  V.col(2) = V.col(0).cross(V.col(1));
  const Mat<3, T> FV = F * V;
  sigma[0] = FV.col(0).norm();
  if (sigma[0] == 0) {  // F = 0
    U.setIdentity();
    sigma.setZero();
    return;
  }
  const Vec<3, T> u0 = FV.col(0) / sigma[0];
  Vec<3, T> u1 = FV.col(1) - u0.dot(FV.col(1)) * u0;
  sigma[1] = u1.norm();
  if (sigma[1] > Tolerance<T>::rank) {
    u1 /= sigma[1];
  } else {  // rank one: any unit vector orthogonal to u0
    u1 = u0.unitOrthogonal();
  }
  const Vec<3, T> u2 = u0.cross(u1);
  sigma[2] = u2.dot(FV.col(2));
  U.col(0) = u0;
  U.col(1) = u1;
  U.col(2) = u2;
}

}  // namespace

template <int D, class T>
void signedSvd(const MatArg<D, T>& F, Mat<D, T>& U, Vec<D, T>& sigma, Mat<D, T>& V) {
  if constexpr (D == 2) {
    svd2(F, U, sigma, V);
  } else {
    svd3(F, U, sigma, V);
  }
}

template <int D, class T>
Mat<D, T> polarRotation(const MatArg<D, T>& F) {
  if constexpr (D == 2) {
    return polar2(F);
  } else {
    Mat<3, T> U, V;
    Vec<3, T> s;
    signedSvd<3, T>(F, U, s, V);
    return U * V.transpose();
  }
}

template <int D, class T>
Mat<D, T> fixedCorotatedPiola(const MatArg<D, T>& F_E, const LameOf<T>& lame) {
  const Mat<D, T> R = polarRotation<D, T>(F_E);
  const T J = F_E.determinant();
  // J F^{-T} is the cofactor matrix of F, which stays finite for singular F.
  Mat<D, T> JFinvT;
  if constexpr (D == 2) {
    JFinvT << F_E(1, 1), -F_E(1, 0), -F_E(0, 1), F_E(0, 0);
  } else {
    JFinvT = cofactor3(F_E);
  }
  return 2 * lame.mu * (F_E - R) + lame.lambda * (J - 1) * JFinvT;
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

template <class T>
T plasticReturnMappingJ(const SnowMaterial& m, Mat<2, T>& F_E, std::type_identity_t<T> J_P,
                        Mat<2, T>& R_E) {
  // F = [a b; c d] splits into a scaled rotation and a symmetric traceless part,
  // F = (r/2) R + A with r = |(a + d, c - b)|, R its rotation and A = [e g; g -e],
  // e = (a - d)/2, g = (b + c)/2. Then F = R S with S = (r/2) I + R^T A, whose eigenvalues, the
  // signed singular values, are r/2 +- |(e, g)|; and replacing them by clamped ones gives
  // F' = mean' R + (half-difference' / |(e, g)|) A. Two independent square roots, no SVD.
  const T x = F_E(0, 0) + F_E(1, 1), y = F_E(1, 0) - F_E(0, 1);
  const T e = T(0.5) * (F_E(0, 0) - F_E(1, 1)), g = T(0.5) * (F_E(0, 1) + F_E(1, 0));
  const T r = std::sqrt(x * x + y * y), rad = std::sqrt(e * e + g * g);
  const T s0 = T(0.5) * r + rad, s1 = T(0.5) * r - rad;
  const T lo = T(1 - m.theta_c), hi = T(1 + m.theta_s);
  const T c0 = std::clamp(s0, lo, hi), c1 = std::clamp(s1, lo, hi);  // eq. 11
  if (r > 0) {
    const T c = x / r, s = y / r;  // (-y) / r is -(y / r) (rounding is symmetric): two divisions
    R_E << c, -s, s, c;
  } else {
    R_E.setIdentity();  // as polarRotation: any rotation will do
  }
  if (c0 == s0 && c1 == s1) return J_P;  // inside the elastic range: F_E stays as it is
  F_E = T(0.5) * (c0 + c1) * R_E;
  if (rad > 0) {
    const T k = T(0.5) * (c0 - c1) / rad;
    F_E(0, 0) += k * e;
    F_E(1, 1) -= k * e;
    F_E(0, 1) += k * g;
    F_E(1, 0) += k * g;
  }
  // det F = J_E J_P is unchanged by the return mapping: J_P' = J_P J_trial / J_clamped.
  return J_P * (s0 * s1) / (c0 * c1);
}

// The 3D return mapping runs a particle per vector lane, eight at a time. The polar rotation by
// Newton's iteration X <- (X + X^-T) / 2 (Higham 1986), started from F itself, squares the distance
// of each singular value from 1 per iteration, so the few percent that snow's F_E strays from a
// rotation take about four iterations to round-off; the particles whose singular values leave
// their bounds take the Jacobi SVD, in lanes of their own. One particle's iteration is
// a chain of dependent divisions and square roots; eight in lanes overlap their chains. Each lane
// stops when its own iteration converges, so a particle's result does not depend on the others in
// its batch. The helpers below are always inlined and local to this file: the calling convention
// that -Wpsabi warns about for vectors passed by value never applies. (GCC warns where templates
// are instantiated, at the end of the file: the pragma holds to there.)
#pragma GCC diagnostic ignored "-Wpsabi"
namespace {

template <class T>
using Lanes = typename Lanes8<T>::type;
template <class T>
using LaneMask = decltype(Lanes<T>{} > Lanes<T>{});
constexpr int lanes = returnMappingLanes;
#define SNOWSIM_LANES_INLINE [[gnu::always_inline]] inline

// A 3x3 matrix per lane: a[i][j] holds entry (i, j) of every lane's matrix.
template <class T>
struct Mat3Lanes {
  Lanes<T> a[3][3];
};

template <class T>
SNOWSIM_LANES_INLINE bool anyLane(const LaneMask<T>& mask) {
  bool any = false;
  for (int l = 0; l < lanes; ++l) any |= mask[l] != 0;
  return any;
}
template <class T>
SNOWSIM_LANES_INLINE Lanes<T> sqrtLanes(Lanes<T> a) {
  for (int l = 0; l < lanes; ++l) a[l] = std::sqrt(a[l]);  // one instruction (-fno-math-errno)
  return a;
}
template <class T>
SNOWSIM_LANES_INLINE Lanes<T> clampLanes(Lanes<T> a, T lo, T hi) {  // std::clamp's comparisons
  return a < lo ? Lanes<T>{} + lo : hi < a ? Lanes<T>{} + hi : a;
}
template <class T>
SNOWSIM_LANES_INLINE Lanes<T> absLanes(Lanes<T> a) {
  return a < 0 ? -a : a;
}
template <class T>
SNOWSIM_LANES_INLINE Lanes<T> dotLanes(const Lanes<T> (&a)[3], const Lanes<T> (&b)[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
template <class T>
SNOWSIM_LANES_INLINE void crossLanes(const Lanes<T> (&a)[3], const Lanes<T> (&b)[3],
                                     Lanes<T> (&out)[3]) {
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    out[i] = a[j] * b[k] - a[k] * b[j];
  }
}
// Column j of X as three lane vectors, and back.
template <class T>
SNOWSIM_LANES_INLINE void column(const Mat3Lanes<T>& X, int j, Lanes<T> (&out)[3]) {
  for (int i = 0; i < 3; ++i) out[i] = X.a[i][j];
}
template <class T>
SNOWSIM_LANES_INLINE void setColumn(Mat3Lanes<T>& X, int j, const Lanes<T> (&v)[3]) {
  for (int i = 0; i < 3; ++i) X.a[i][j] = v[i];
}
// A B and A^T B.
template <class T>
SNOWSIM_LANES_INLINE Mat3Lanes<T> productLanes(const Mat3Lanes<T>& A, const Mat3Lanes<T>& B) {
  Mat3Lanes<T> out;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      out.a[i][j] = A.a[i][0] * B.a[0][j] + A.a[i][1] * B.a[1][j] + A.a[i][2] * B.a[2][j];
  return out;
}
template <class T>
SNOWSIM_LANES_INLINE Mat3Lanes<T> transposeProductLanes(const Mat3Lanes<T>& A,
                                                        const Mat3Lanes<T>& B) {
  Mat3Lanes<T> out;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      out.a[i][j] = A.a[0][i] * B.a[0][j] + A.a[1][i] * B.a[1][j] + A.a[2][i] * B.a[2][j];
  return out;
}

// Entry (i, j) of matrix ps[l] of M into lane l, 2x2 or 3x3; lanes past ps hold the identity.
// Each lane vector is built from its eight scalars: no branch per entry, and no narrow stores
// read back wide.
template <int D, class T>
SNOWSIM_LANES_INLINE void loadLanes(const Mat<D, T>* M, std::span<const int> ps,
                                    Lanes<T> (&out)[D][D]) {
  static_assert(lanes == 8, "a lane vector is built from eight scalars below");
  static constexpr std::array<T, D* D> identity = [] {
    std::array<T, D * D> a{};
    for (int i = 0; i < D; ++i) a[i * (D + 1)] = 1;
    return a;
  }();
  const T* from[lanes];
  for (int l = 0; l < lanes; ++l) from[l] = l < int(ps.size()) ? M[ps[l]].data() : identity.data();
  for (int j = 0; j < D; ++j)
    for (int i = 0; i < D; ++i) {
      const int e = i + D * j;  // column-major
      out[i][j] = Lanes<T>{from[0][e], from[1][e], from[2][e], from[3][e],
                           from[4][e], from[5][e], from[6][e], from[7][e]};
    }
}
template <class T>
SNOWSIM_LANES_INLINE Mat3Lanes<T> loadLanes(const Mat<3, T>* M, std::span<const int> ps) {
  Mat3Lanes<T> out;
  loadLanes<3, T>(M, ps, out.a);
  return out;
}
template <class T>
SNOWSIM_LANES_INLINE Mat3Lanes<T> identityLanes() {
  Mat3Lanes<T> out;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out.a[i][j] = Lanes<T>{} + T(i == j);
  return out;
}
template <class T>
SNOWSIM_LANES_INLINE void storeLane(const Mat3Lanes<T>& X, int l, Mat<3, T>& out) {
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) out(i, j) = X.a[i][j][l];
}

// Newton's polar iteration in every lane: true where it converged, X then the lane's rotation.
// A lane converges when a step's squared change falls below Tolerance::newton; it fails where
// det X <= 0 (the polar factor would be a reflection) or it has not converged in eight steps.
template <class T>
SNOWSIM_LANES_INLINE LaneMask<T> newtonPolarLanes(Mat3Lanes<T>& X) {
  LaneMask<T> active = LaneMask<T>{} == 0, converged = {};
  for (int iteration = 0; iteration < 8; ++iteration) {
    // The cofactor matrix det(X) X^-T, finite for singular X: its columns are the cross products
    // of X's other two columns.
    Lanes<T> x[3][3], cofactor[3][3];
    for (int j = 0; j < 3; ++j) column(X, j, x[j]);
    for (int j = 0; j < 3; ++j) crossLanes<T>(x[(j + 1) % 3], x[(j + 2) % 3], cofactor[j]);
    const Lanes<T> det = dotLanes<T>(x[0], cofactor[0]);
    active &= det > 0;  // false for NaN too
    const Lanes<T> half_inverse = T(0.5) / det;
    Lanes<T> change = {};
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) {
        const Lanes<T> next = T(0.5) * x[j][i] + half_inverse * cofactor[j][i];
        const Lanes<T> step = next - x[j][i];
        change += step * step;
        X.a[i][j] = active ? next : x[j][i];
      }
    // The next change would be about change^2: X is exact to round-off.
    const LaneMask<T> done = active & (change <= Tolerance<T>::newton);
    converged |= done;
    active &= ~done;
    if (!anyLane<T>(active)) break;
  }
  return converged;
}

// Sylvester's criterion for the symmetric A: leading principal minors all positive.
template <class T>
SNOWSIM_LANES_INLINE LaneMask<T> positiveDefiniteLanes(const Mat3Lanes<T>& M) {
  const auto& A = M.a;
  const Lanes<T> minor2 = A[0][0] * A[1][1] - A[0][1] * A[1][0];
  const Lanes<T> det = A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1]) -
                       A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0]) +
                       A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]);
  return (A[0][0] > 0) & (minor2 > 0) & (det > 0);
}

// Whether every eigenvalue of the symmetric part of S = R^T F lies in [lo, hi], per lane (S has
// the singular values of F as eigenvalues): S - lo I and hi I - S positive definite.
template <class T>
SNOWSIM_LANES_INLINE LaneMask<T> singularValuesWithinLanes(const Mat3Lanes<T>& R,
                                                           const Mat3Lanes<T>& F, T lo, T hi) {
  const Mat3Lanes<T> S = transposeProductLanes(R, F);
  Mat3Lanes<T> minus_lo, hi_minus;  // sym(S) - lo I and hi I - sym(S)
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const Lanes<T> sym = T(0.5) * (S.a[i][j] + S.a[j][i]);
      minus_lo.a[i][j] = i == j ? sym - lo : sym;
      hi_minus.a[i][j] = i == j ? hi - sym : -sym;
    }
  return positiveDefiniteLanes(minus_lo) & positiveDefiniteLanes(hi_minus);
}

// Diagonalises the symmetric A in every lane by cyclic Jacobi rotations (Golub and Van Loan,
// section 8.5), accumulating them into V: V^T A_in V = A_out. A handful of sweeps finish it. A
// lane skips a rotation once its off-diagonal entry no longer changes the diagonal (|a_pq| <=
// 1e-16 sqrt(a_pp a_qq) for the positive semi-definite A here); a sweep that rotates no lane ends
// them, and a lane whose sweep rotated nothing is left as it is by the next.
template <class T>
SNOWSIM_LANES_INLINE void jacobiEigenLanes(Mat3Lanes<T>& A, Mat3Lanes<T>& V) {
  constexpr int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  constexpr int max_sweeps = 12;  // round-off is reached in under ten from any start
  for (int sweep = 0; sweep < max_sweeps; ++sweep) {
    LaneMask<T> rotated = {};
    for (const auto& [p, q] : pairs) {
      const Lanes<T> apq = A.a[p][q];
      const LaneMask<T> rotate =
          !(apq * apq <= Tolerance<T>::jacobi * absLanes<T>(A.a[p][p] * A.a[q][q]));
      if (!anyLane<T>(rotate)) continue;
      rotated |= rotate;
      // The rotation that zeroes a_pq: tan of its angle t, the smaller root of
      // t^2 + 2 theta t - 1 = 0 with theta = (a_qq - a_pp) / (2 a_pq).
      const Lanes<T> theta = (A.a[q][q] - A.a[p][p]) / (2 * apq);
      const Lanes<T> abs_theta = absLanes<T>(theta);
      const Lanes<T> sign = theta < 0 ? Lanes<T>{} - 1 : Lanes<T>{} + 1;
      const Lanes<T> t = abs_theta > Tolerance<T>::huge
                             ? 1 / (2 * theta)
                             : sign / (abs_theta + sqrtLanes<T>(theta * theta + 1));
      const Lanes<T> c = 1 / sqrtLanes<T>(t * t + 1), s = t * c;
      const int r = 3 - p - q;  // the third axis
      const Lanes<T> arp = A.a[r][p], arq = A.a[r][q];
      A.a[p][p] = rotate ? A.a[p][p] - t * apq : A.a[p][p];
      A.a[q][q] = rotate ? A.a[q][q] + t * apq : A.a[q][q];
      A.a[p][q] = A.a[q][p] = rotate ? Lanes<T>{} : apq;
      A.a[r][p] = A.a[p][r] = rotate ? c * arp - s * arq : arp;
      A.a[r][q] = A.a[q][r] = rotate ? s * arp + c * arq : arq;
      for (int i = 0; i < 3; ++i) {
        const Lanes<T> vp = V.a[i][p], vq = V.a[i][q];
        V.a[i][p] = rotate ? c * vp - s * vq : vp;
        V.a[i][q] = rotate ? s * vp + c * vq : vq;
      }
    }
    if (!anyLane<T>(rotated)) return;
  }
}

template <class T>
SNOWSIM_LANES_INLINE void normalizeLanes(Lanes<T> (&v)[3], Lanes<T> norm) {
  for (int i = 0; i < 3; ++i) v[i] /= norm;
}

// The 3x3 SVD F = U diag(sigma) V^T in every lane, from the eigenvectors of F^T F found by Jacobi
// rotations from the identity (a guess kept per particle would save a few sweeps but cost a
// matrix a particle to store, sort and migrate): V the eigenvectors ordered by decreasing
// eigenvalue, re-orthonormalised so that it is a rotation to round-off; then U by Gram-Schmidt on
// the columns of F V, which stays orthonormal when singular values nearly coincide; the last
// singular value takes the sign of det F.
template <class T>
SNOWSIM_LANES_INLINE void svdLanes(const Mat3Lanes<T>& F, Mat3Lanes<T>& U, Lanes<T> (&sigma)[3],
                                   Mat3Lanes<T>& V) {
  Mat3Lanes<T> A = transposeProductLanes(F, F);
  V = identityLanes<T>();
  jacobiEigenLanes(A, V);
  // Decreasing eigenvalues; a swap of two columns negates one so that V stays a rotation.
  auto order = [&](int i, int j) {
    const LaneMask<T> swap = !(A.a[i][i] >= A.a[j][j]);
    const Lanes<T> aii = A.a[i][i];
    A.a[i][i] = swap ? A.a[j][j] : aii;
    A.a[j][j] = swap ? aii : A.a[j][j];
    for (int k = 0; k < 3; ++k) {
      const Lanes<T> vi = V.a[k][i];
      V.a[k][i] = swap ? V.a[k][j] : vi;
      V.a[k][j] = swap ? -vi : V.a[k][j];
    }
  };
  order(0, 1);
  order(0, 2);
  order(1, 2);
  Lanes<T> v[3][3];
  column(V, 0, v[0]);
  column(V, 1, v[1]);
  normalizeLanes<T>(v[0], sqrtLanes<T>(dotLanes<T>(v[0], v[0])));
  const Lanes<T> along = dotLanes<T>(v[0], v[1]);
  for (int i = 0; i < 3; ++i) v[1][i] -= along * v[0][i];
  normalizeLanes<T>(v[1], sqrtLanes<T>(dotLanes<T>(v[1], v[1])));
  crossLanes<T>(v[0], v[1], v[2]);
  for (int j = 0; j < 3; ++j) setColumn(V, j, v[j]);
  const Mat3Lanes<T> FV = productLanes(F, V);
  Lanes<T> fv[3][3], u[3][3];
  for (int j = 0; j < 3; ++j) column(FV, j, fv[j]);
  sigma[0] = sqrtLanes<T>(dotLanes<T>(fv[0], fv[0]));
  for (int i = 0; i < 3; ++i) u[0][i] = fv[0][i] / sigma[0];
  const Lanes<T> along_u0 = dotLanes<T>(u[0], fv[1]);
  for (int i = 0; i < 3; ++i) u[1][i] = fv[1][i] - along_u0 * u[0][i];
  sigma[1] = sqrtLanes<T>(dotLanes<T>(u[1], u[1]));
  const LaneMask<T> rank_two = sigma[1] > Tolerance<T>::rank;
  if (!anyLane<T>(~rank_two)) {
    normalizeLanes<T>(u[1], sigma[1]);
  } else {
    // Rank one where !rank_two: u1 any unit vector orthogonal to u0, (-y, x, 0) or, for u0 near
    // the z axis, (0, -z, y), normalised.
    const Lanes<T> small = absLanes<T>(u[0][2]) * T(1e-3);
    const LaneMask<T> near_z = (absLanes<T>(u[0][0]) <= small) & (absLanes<T>(u[0][1]) <= small);
    Lanes<T> w[3] = {near_z ? Lanes<T>{} : -u[0][1], near_z ? -u[0][2] : u[0][0],
                     near_z ? u[0][1] : Lanes<T>{}};
    normalizeLanes<T>(w, sqrtLanes<T>(dotLanes<T>(w, w)));
    for (int i = 0; i < 3; ++i) u[1][i] = rank_two ? u[1][i] / sigma[1] : w[i];
  }
  crossLanes<T>(u[0], u[1], u[2]);
  sigma[2] = dotLanes<T>(u[2], fv[2]);
  for (int j = 0; j < 3; ++j) setColumn(U, j, u[j]);
  // F = 0: U = I, sigma = 0.
  const LaneMask<T> zero = sigma[0] == 0;
  if (anyLane<T>(zero)) {
    for (int i = 0; i < 3; ++i) {
      sigma[i] = zero ? Lanes<T>{} : sigma[i];
      for (int j = 0; j < 3; ++j) U.a[i][j] = zero ? Lanes<T>{} + T(i == j) : U.a[i][j];
    }
  }
}

// The Kirchhoff stress of the lanes' F and rotation R with the Lamé parameters of particles ps
// (the unhardened pair times each one's hardening), into lane l's tau[ps[l]] where store[l]
// holds: as fixedCorotatedKirchhoffUpper.
template <class T>
SNOWSIM_LANES_INLINE void storeKirchhoffLanes(const Mat3Lanes<T>& F, const Mat3Lanes<T>& R,
                                              std::span<const int> ps, const LameOf<T>& unhardened,
                                              const T* hardening, const bool* store,
                                              Symmetric<3, T>* tau) {
  const int n = int(ps.size());
  Lanes<T> mu{}, lambda{};
  for (int l = 0; l < n; ++l) {
    const LameOf<T> lame = lameOf(unhardened, hardening[ps[l]]);
    mu[l] = lame.mu, lambda[l] = lame.lambda;
  }
  const auto& f = F.a;
  const Lanes<T> J = f[0][0] * (f[1][1] * f[2][2] - f[1][2] * f[2][1]) -
                     f[0][1] * (f[1][0] * f[2][2] - f[1][2] * f[2][0]) +
                     f[0][2] * (f[1][0] * f[2][1] - f[1][1] * f[2][0]);
  const Lanes<T> pressure = lambda * (J - 1) * J;
  Lanes<T> upper[Symmetric<3, T>::entries];
  for (int i = 0, k = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j, ++k) {
      const Lanes<T> sum = (f[i][0] - R.a[i][0]) * f[j][0] + (f[i][1] - R.a[i][1]) * f[j][1] +
                           (f[i][2] - R.a[i][2]) * f[j][2];
      upper[k] = 2 * mu * sum;
      if (i == j) upper[k] += pressure;
    }
  for (int l = 0; l < n; ++l)
    if (store[l])
      for (int k = 0; k < Symmetric<3, T>::entries; ++k) tau[ps[l]].upper[k] = upper[k][l];
}

// Particles ps (at most `lanes`), whose singular values leave [lo, hi]: clamped through the SVD
// (eq. 11); R_E[at[l]] = U V^T (unless R_E is null), J_P' = J_P J_trial / J_clamped (as in 2D),
// the hardening computed anew and the stress of the new F_E.
template <class T>
SNOWSIM_LANES_INLINE void clampSingularValuesLanes(const SnowMaterial& m, std::span<const int> ps,
                                                   const int* at, Mat<3, T>* F_E, T* J_P,
                                                   Mat<3, T>* R_E, T* hardening,
                                                   Symmetric<3, T>* tau, T lo, T hi) {
  const Mat3Lanes<T> F = loadLanes(F_E, ps);
  Mat3Lanes<T> U, V;
  Lanes<T> sigma[3];
  svdLanes(F, U, sigma, V);
  const Lanes<T> J_trial = sigma[0] * sigma[1] * sigma[2];
  for (int a = 0; a < 3; ++a) sigma[a] = clampLanes<T>(sigma[a], lo, hi);
  const Lanes<T> J_clamped = sigma[0] * sigma[1] * sigma[2];
  Mat3Lanes<T> clamped_U, V_transposed;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      clamped_U.a[i][j] = U.a[i][j] * sigma[j];
      V_transposed.a[i][j] = V.a[j][i];
    }
  const Mat3Lanes<T> new_F_E = productLanes(clamped_U, V_transposed);
  const Mat3Lanes<T> rotation = productLanes(U, V_transposed);
  for (int l = 0; l < int(ps.size()); ++l) {
    const int p = ps[l];
    storeLane(new_F_E, l, F_E[p]);
    if (R_E) storeLane(rotation, l, R_E[at[l]]);
    const T J_P_before = J_P[p];
    J_P[p] = J_P[p] * J_trial[l] / J_clamped[l];
    // Hardening depends on J_P alone: no exp while it stays as it is.
    if (J_P[p] != J_P_before) hardening[p] = hardeningFactor<T>(m, J_P[p]);
  }
  static constexpr bool every[lanes] = {true, true, true, true, true, true, true, true};
  storeKirchhoffLanes(new_F_E, rotation, ps, unhardenedLame<T>(m), hardening, every, tau);
}

// The whole return mapping of ps (at most returnMappingBatch), R_E in the order of ps: Newton, the
// bounds test and the stress of those within them eight at a time; those outside their bounds
// gathered into lanes of their own for the SVD.
template <class T>
SNOWSIM_LANES_INLINE void mapInLanes(const SnowMaterial& m, std::span<const int> ps, Mat<3, T>* F_E,
                                     T* J_P, Mat<3, T>* R_E, T* hardening, Symmetric<3, T>* tau,
                                     T lo, T hi) {
  const LameOf<T> unhardened = unhardenedLame<T>(m);
  int beyond[returnMappingBatch], beyond_at[returnMappingBatch];
  int count = 0;
  for (size_t first = 0; first < ps.size(); first += lanes) {
    const std::span<const int> group =
        ps.subspan(first, std::min<size_t>(lanes, ps.size() - first));
    const Mat3Lanes<T> F = loadLanes(F_E, group);
    Mat3Lanes<T> X = F;
    const LaneMask<T> within = newtonPolarLanes(X) & singularValuesWithinLanes(X, F, lo, hi);
    bool stays[lanes];
    for (int l = 0; l < int(group.size()); ++l) {
      stays[l] = within[l];
      if (stays[l]) {
        // F_E, J_P and the hardening stay as they are.
        if (R_E) storeLane(X, l, R_E[first + l]);
      } else {
        beyond[count] = group[l];
        beyond_at[count++] = int(first) + l;
      }
    }
    storeKirchhoffLanes(F, X, group, unhardened, hardening, stays, tau);
  }
  for (int first = 0; first < count; first += lanes)
    clampSingularValuesLanes(m,
                             std::span<const int>(beyond + first, std::min(lanes, count - first)),
                             beyond_at + first, F_E, J_P, R_E, hardening, tau, lo, hi);
}

// The arrays of the 3D return mapping, for the builds below.
template <class T>
struct MappingArrays {
  Mat<3, T>* F_E;
  T* J_P;
  Mat<3, T>* R_E;
  T* hardening;
  Symmetric<3, T>* tau;
};

template <class T>
SNOWSIM_LANES_INLINE void mapInLanes(const SnowMaterial& m, std::span<const int> ps,
                                     const MappingArrays<T>& a) {
  mapInLanes(m, ps, a.F_E, a.J_P, a.R_E, a.hardening, a.tau, T(1 - m.theta_c), T(1 + m.theta_s));
}
template <class T>
void returnMappingBaseline(const SnowMaterial& m, std::span<const int> ps,
                           const MappingArrays<T>& a) {
  mapInLanes(m, ps, a);
}
template <class T>
SNOWSIM_TARGET_AVX2 void returnMappingAvx2(const SnowMaterial& m, std::span<const int> ps,
                                           const MappingArrays<T>& a) {
  mapInLanes(m, ps, a);
}
template <class T>
SNOWSIM_TARGET_AVX512 void returnMappingAvx512(const SnowMaterial& m, std::span<const int> ps,
                                               const MappingArrays<T>& a) {
  mapInLanes(m, ps, a);
}

// The 2D return mapping of ps (at most `lanes`) in lanes: the scalar plasticReturnMappingJ's
// closed form and fixedCorotatedKirchhoffUpper, their operations in the same order, so that each
// lane rounds as the scalar code does; the cases the scalar code branches on (r = 0, rad = 0,
// singular values within their bounds) are selected per lane.
template <class T>
SNOWSIM_LANES_INLINE void mapInLanes2(std::span<const int> ps, Mat<2, T>* F_E, T* J_P, T* hardening,
                                      Symmetric<2, T>* tau, const SnowMaterial& m) {
  const int n = int(ps.size());
  const LameOf<T> unhardened = unhardenedLame<T>(m);
  Lanes<T> f[2][2];
  loadLanes<2, T>(F_E, ps, f);
  const Lanes<T> x = f[0][0] + f[1][1], y = f[1][0] - f[0][1];
  const Lanes<T> e = T(0.5) * (f[0][0] - f[1][1]), g = T(0.5) * (f[0][1] + f[1][0]);
  const Lanes<T> r = sqrtLanes<T>(x * x + y * y), rad = sqrtLanes<T>(e * e + g * g);
  const Lanes<T> s0 = T(0.5) * r + rad, s1 = T(0.5) * r - rad;
  const T lo = T(1 - m.theta_c), hi = T(1 + m.theta_s);
  const Lanes<T> c0 = clampLanes<T>(s0, lo, hi), c1 = clampLanes<T>(s1, lo, hi);  // eq. 11
  const Lanes<T> one = Lanes<T>{} + 1;
  const LaneMask<T> turned = r > 0, stretched = rad > 0;
  const Lanes<T> cosine = turned ? x / (turned ? r : one) : one;
  const Lanes<T> sine = turned ? y / (turned ? r : one) : Lanes<T>{};
  // The identity where r = 0, +0 off the diagonal as the scalar code sets it.
  const Lanes<T> rotation[2][2] = {{cosine, turned ? -sine : Lanes<T>{}}, {sine, cosine}};
  const LaneMask<T> within = (c0 == s0) & (c1 == s1);
  const Lanes<T> mean = T(0.5) * (c0 + c1);
  const Lanes<T> k = T(0.5) * (c0 - c1) / (stretched ? rad : one);
  Lanes<T> clamped[2][2];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) clamped[i][j] = mean * rotation[i][j];
  clamped[0][0] = stretched ? clamped[0][0] + k * e : clamped[0][0];
  clamped[1][1] = stretched ? clamped[1][1] - k * e : clamped[1][1];
  clamped[0][1] = stretched ? clamped[0][1] + k * g : clamped[0][1];
  clamped[1][0] = stretched ? clamped[1][0] + k * g : clamped[1][0];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) f[i][j] = within ? f[i][j] : clamped[i][j];
  // det F = J_E J_P is unchanged by the return mapping: J_P' = J_P J_trial / J_clamped.
  Lanes<T> J_P_before{}, mu{}, lambda{};
  for (int l = 0; l < n; ++l) J_P_before[l] = J_P[ps[l]];
  const Lanes<T> J_P_after = J_P_before * (s0 * s1) / (c0 * c1);
  for (int l = 0; l < n; ++l) {
    const int p = ps[l];
    if (!within[l]) {
      for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i) F_E[p](i, j) = f[i][j][l];
      J_P[p] = J_P_after[l];
    }
    // Hardening depends on J_P alone: no exp while it stays as it is (a NaN never does).
    if (J_P[p] != J_P_before[l]) hardening[p] = hardeningFactor<T>(m, J_P[p]);
    const LameOf<T> lame = lameOf(unhardened, hardening[p]);
    mu[l] = lame.mu;
    lambda[l] = lame.lambda;
  }
  const Lanes<T> J = f[0][0] * f[1][1] - f[1][0] * f[0][1];
  const Lanes<T> pressure = lambda * (J - 1) * J;
  Lanes<T> upper[Symmetric<2, T>::entries];
  for (int i = 0, c = 0; i < 2; ++i)
    for (int j = i; j < 2; ++j, ++c) {
      const Lanes<T> sum =
          Lanes<T>{} + (f[i][0] - rotation[i][0]) * f[j][0] + (f[i][1] - rotation[i][1]) * f[j][1];
      upper[c] = T(2) * mu * sum + (i == j ? pressure : Lanes<T>{});
    }
  for (int l = 0; l < n; ++l)
    for (int c = 0; c < Symmetric<2, T>::entries; ++c) tau[ps[l]].upper[c] = upper[c][l];
}

template <class T>
struct MappingArrays2 {
  Mat<2, T>* F_E;
  T* J_P;
  T* hardening;
  Symmetric<2, T>* tau;
};
template <class T>
SNOWSIM_LANES_INLINE void mapAllInLanes2(const SnowMaterial& m, std::span<const int> ps,
                                         const MappingArrays2<T>& a) {
  for (size_t first = 0; first < ps.size(); first += lanes)
    mapInLanes2(ps.subspan(first, std::min<size_t>(lanes, ps.size() - first)), a.F_E, a.J_P,
                a.hardening, a.tau, m);
}
template <class T>
void returnMapping2Baseline(const SnowMaterial& m, std::span<const int> ps,
                            const MappingArrays2<T>& a) {
  mapAllInLanes2(m, ps, a);
}
template <class T>
SNOWSIM_TARGET_AVX2 void returnMapping2Avx2(const SnowMaterial& m, std::span<const int> ps,
                                            const MappingArrays2<T>& a) {
  mapAllInLanes2(m, ps, a);
}
template <class T>
SNOWSIM_TARGET_AVX512 void returnMapping2Avx512(const SnowMaterial& m, std::span<const int> ps,
                                                const MappingArrays2<T>& a) {
  mapAllInLanes2(m, ps, a);
}

#undef SNOWSIM_LANES_INLINE
}  // namespace

template <class T>
void plasticReturnMappingJ(const SnowMaterial& m, std::span<const int> ps, Mat<2, T>* F_E, T* J_P,
                           T* hardening, Symmetric<2, T>* tau, VectorIsa isa) {
  const MappingArrays2<T> arrays{F_E, J_P, hardening, tau};
  switch (isa) {
    case VectorIsa::avx512:
      return returnMapping2Avx512(m, ps, arrays);
    case VectorIsa::avx2:
      return returnMapping2Avx2(m, ps, arrays);
    case VectorIsa::baseline:
      return returnMapping2Baseline(m, ps, arrays);
  }
}

template <class T>
void plasticReturnMappingJ(const SnowMaterial& m, std::span<const int> ps, Mat<3, T>* F_E, T* J_P,
                           Mat<3, T>* R_E, T* hardening, Symmetric<3, T>* tau, VectorIsa isa) {
  // Most snow is within its elastic range most of the time: its polar rotation comes cheaper than
  // an SVD, and when the singular values are inside the bounds F_E and J_P stay as they are.
  for (size_t first = 0; first < ps.size(); first += returnMappingBatch) {
    const std::span<const int> batch =
        ps.subspan(first, std::min<size_t>(returnMappingBatch, ps.size() - first));
    const MappingArrays<T> arrays{F_E, J_P, R_E ? R_E + first : nullptr, hardening, tau};
    switch (isa) {
      case VectorIsa::avx512:
        returnMappingAvx512(m, batch, arrays);
        break;
      case VectorIsa::avx2:
        returnMappingAvx2(m, batch, arrays);
        break;
      case VectorIsa::baseline:
        returnMappingBaseline(m, batch, arrays);
        break;
    }
  }
}

template <class T>
T plasticReturnMappingJ(const SnowMaterial& m, Mat<3, T>& F_E, std::type_identity_t<T> J_P,
                        Mat<3, T>& R_E) {
  const int first = 0;
  T hardening = hardeningFactor<T>(m, J_P);  // the lanes harden it and take the stress: unused here
  Symmetric<3, T> tau;
  plasticReturnMappingJ<T>(m, std::span<const int>(&first, 1), &F_E, &J_P, &R_E, &hardening, &tau,
                           vectorIsa());
  return J_P;
}

#define SNOWSIM_SNOW_MATERIAL(T)                                                                \
  template T hardeningFactor<T>(const SnowMaterial&, T);                                        \
  template Mat<2, T> polarRotation<2, T>(const Mat<2, T>&);                                     \
  template Mat<3, T> polarRotation<3, T>(const Mat<3, T>&);                                     \
  template void signedSvd<2, T>(const Mat<2, T>&, Mat<2, T>&, Vec<2, T>&, Mat<2, T>&);          \
  template void signedSvd<3, T>(const Mat<3, T>&, Mat<3, T>&, Vec<3, T>&, Mat<3, T>&);          \
  template Mat<2, T> fixedCorotatedPiola<2, T>(const Mat<2, T>&, const LameOf<T>&);             \
  template Mat<3, T> fixedCorotatedPiola<3, T>(const Mat<3, T>&, const LameOf<T>&);             \
  template T plasticReturnMappingJ<T>(const SnowMaterial&, Mat<2, T>&, T, Mat<2, T>&);          \
  template T plasticReturnMappingJ<T>(const SnowMaterial&, Mat<3, T>&, T, Mat<3, T>&);          \
  template void plasticReturnMappingJ<T>(const SnowMaterial&, std::span<const int>, Mat<3, T>*, \
                                         T*, Mat<3, T>*, T*, Symmetric<3, T>*, VectorIsa);      \
  template void plasticReturnMappingJ<T>(const SnowMaterial&, std::span<const int>, Mat<2, T>*, \
                                         T*, T*, Symmetric<2, T>*, VectorIsa);
SNOWSIM_SNOW_MATERIAL(double)
SNOWSIM_SNOW_MATERIAL(float)
#undef SNOWSIM_SNOW_MATERIAL
template Real plasticReturnMapping<2>(const SnowMaterial&, Mat<2>&, Mat<2>&);
template Real plasticReturnMapping<3>(const SnowMaterial&, Mat<3>&, Mat<3>&);

}  // namespace snowsim
