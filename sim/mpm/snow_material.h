// The snow constitutive model of Stomakhin et al. 2013 ("A Material Point Method for Snow
// Simulation", ACM TOG 32(4) 102): fixed-corotated elasticity with hardening and a plastic return
// mapping that clamps the singular values of the elastic deformation gradient. Pure functions.
#pragma once

#include <algorithm>
#include <cmath>
#include <span>
#include <type_traits>

#include "sim/core/lanes.h"
#include "sim/core/math.h"

namespace snowsim {

// Material parameters; defaults are the paper's reference snow (section 7, table 2).
struct SnowMaterial {
  Real E0 = 1.4e5;        // Young's modulus, Pa
  Real nu = 0.2;          // Poisson's ratio
  Real theta_c = 2.5e-2;  // critical compression
  Real theta_s = 7.5e-3;  // critical stretch
  Real xi = 10;           // hardening coefficient
  // Bounds on the hardening factor e^{xi (1 - J_P)}: the paper's eq. 8 has none, and without a
  // lower one snow stretched past theta_s softens without end and turns to dust at fine cells
  // (docs/snow-at-scale.md); the upper one bounds the stiffest wave speed, hence the step.
  Real hardening_min = 0;
  Real hardening_max = 1e300;
  // Viscosity eta (Pa s) of a Kelvin-Voigt damper beside the elastic stress, Kirchhoff
  // eta (grad v + grad v^T); not in the paper (0). Undamped, an explicit step rings, and as snow
  // yields in tension at theta_s (less than theta_c) each ring stretches it a little more: the
  // damper stops that swelling (docs/snow-at-scale.md).
  Real viscosity = 0;
  // Fracture strain eps_f: snow stretched past J_P = 1 keeps a share s = max(0, 1 - ln J_P / eps_f)
  // of its strength (its Lamé pair and its damper), none from ln J_P = eps_f on, where it has
  // failed. 0: never (the paper's model). The share scales the bounded hardening, so failing snow
  // goes below hardening_min. Crack softening of the kind later MPM fracture work uses
  // (docs/snow-at-scale.md, "Cracks that open in the solver").
  Real fracture_strain = 0;
  // Crack band width l_f (m) at which fracture_strain holds. Softening snow fails in a band one
  // cell wide, so the energy a crack takes per area is the band's energy per volume times the
  // cell: with l_f > 0 snow on a grid of cell h fails at fracture_strain l_f / h, the same energy
  // at every cell (the crack band model of Bazant and Oh 1983). 0: fracture_strain at every cell.
  Real fracture_length = 0;

  // Lamé parameters from E0 and nu: mu0 = E / (2 (1 + nu)), lambda0 = E nu / ((1 + nu)(1 - 2 nu)).
  Real mu0() const { return E0 / (2 * (1 + nu)); }
  Real lambda0() const { return E0 * nu / ((1 + nu) * (1 - 2 * nu)); }
};

// The material as a grid of cell h steps it: fracture_strain that of a crack band one cell wide
// (fracture_length).
inline SnowMaterial atCellSize(SnowMaterial m, Real h) {
  if (m.fracture_length > 0) m.fracture_strain *= m.fracture_length / h;
  return m;
}

// Hardened Lamé parameters of one particle (paper eq. 8: mu = mu0 h, lambda = lambda0 h with the
// hardening factor h = e^{xi (1 - J_P)} clamped to [hardening_min, hardening_max], times the
// strength left with a fracture strain), in the precision T of the particle's state.
template <class T>
struct LameOf {
  T mu;
  T lambda;
};
using Lame = LameOf<Real>;
// The hardening factor h alone, which is what a particle keeps: 4 bytes in float where the pair
// took 8, and the pair lameOf makes from it has the same bits as the pair kept before. With a
// fracture strain it is the bounded h times the strength left (strengthLeft).
template <class T = Real>
T hardeningFactor(const SnowMaterial& m, std::type_identity_t<T> J_P);
// The share of its strength snow at J_P keeps (SnowMaterial::fracture_strain): 1 without one.
template <class T = Real>
inline T strengthLeft(const SnowMaterial& m, std::type_identity_t<T> J_P) {
  if (!(m.fracture_strain > 0) || !(J_P > 1)) return 1;
  return std::max(T(0), 1 - std::log(J_P) / T(m.fracture_strain));
}
template <class T>
LameOf<T> unhardenedLame(const SnowMaterial& m) {
  return {T(m.mu0()), T(m.lambda0())};
}
template <class T>
LameOf<T> lameOf(const LameOf<T>& unhardened, std::type_identity_t<T> hardening) {
  return {unhardened.mu * hardening, unhardened.lambda * hardening};
}
template <class T>
LameOf<T> lameOf(const SnowMaterial& m, T hardening) {
  return lameOf(unhardenedLame<T>(m), hardening);
}
template <class T = Real>
LameOf<T> hardenedLame(const SnowMaterial& m, std::type_identity_t<T> J_P) {
  return lameOf<T>(m, hardeningFactor<T>(m, J_P));
}

// The functions below compute in the scalar T: double unless asked for, or float for a state kept
// in single precision (mpm.precision); the material's parameters are rounded to T. Their matrix
// arguments do not deduce T, so expressions convert as before.
template <int D, class T>
using MatArg = std::type_identity_t<Mat<D, T>>;

// Polar decomposition F = R S with R a rotation (det R = +1), S symmetric.
// 2x2: closed form; 3x3: from the SVD.
template <int D, class T = Real>
Mat<D, T> polarRotation(const MatArg<D, T>& F);

// Singular value decomposition F = U diag(sigma) V^T with U, V rotations (det = +1); a negative
// determinant of F shows up as a negative last singular value.
template <int D, class T = Real>
void signedSvd(const MatArg<D, T>& F, Mat<D, T>& U, Vec<D, T>& sigma, Mat<D, T>& V);

// Fixed-corotated first Piola-Kirchhoff stress (paper eq. 6 differentiated):
// P = dPsi/dF_E = 2 mu (F_E - R_E) + lambda (J_E - 1) J_E F_E^{-T}.
template <int D, class T = Real>
Mat<D, T> fixedCorotatedPiola(const MatArg<D, T>& F_E, const LameOf<T>& lame);

// The Kirchhoff stress P F_E^T = 2 mu (F_E - R_E) F_E^T + lambda (J_E - 1) J_E I, which is what the
// grid force sum needs (f_i = -sum_p V_p^0 P_p F_E^T grad w_ip, paper eq. 7) and is free of F^{-T}.
// R_E is the polar rotation of F_E (polarRotation, or the one the return mapping found).
template <int D, class T = Real>
inline Mat<D, T> fixedCorotatedKirchhoff(const MatArg<D, T>& F_E, const MatArg<D, T>& R_E,
                                         const LameOf<T>& lame) {
  const T J = F_E.determinant();
  return 2 * lame.mu * (F_E - R_E) * F_E.transpose() +
         lame.lambda * (J - 1) * J * Mat<D, T>::Identity();
}

// The same stress by its upper triangle, which is all a symmetric one needs: half the products,
// and no lower triangle to differ from the upper by round-off.
template <int D, class T = Real>
inline Symmetric<D, T> fixedCorotatedKirchhoffUpper(const Mat<D, T>& F_E, const Mat<D, T>& R_E,
                                                    const LameOf<T>& lame) {
  const T J = F_E.determinant();
  const T pressure = lame.lambda * (J - 1) * J;
  Symmetric<D, T> tau;
  for (int i = 0, k = 0; i < D; ++i)
    for (int j = i; j < D; ++j, ++k) {
      T sum = 0;
      for (int a = 0; a < D; ++a) sum += (F_E(i, a) - R_E(i, a)) * F_E(j, a);
      tau.upper[k] = 2 * lame.mu * sum + (i == j ? pressure : T(0));
    }
  return tau;
}

// The Kelvin-Voigt damper's Kirchhoff stress eta (grad v + grad v^T), upper triangle, from the
// particle's velocity gradient (the transfer's C). Kirchhoff rather than Cauchy: its Cauchy
// stress eta / J (...) weakens as snow dilates, as the hardening softens it, and the force it
// puts on a particle's nodes, V_p^0 eta grad v, damps them at a rate that J does not change, so
// one step bound holds however far the snow is torn (MpmSolver's viscous_speed_).
template <int D, class T>
inline Symmetric<D, T> viscousKirchhoffUpper(const Mat<D, T>& grad_v, T eta) {
  Symmetric<D, T> tau;
  for (int i = 0, k = 0; i < D; ++i)
    for (int j = i; j < D; ++j, ++k) tau.upper[k] = eta * (grad_v(i, j) + grad_v(j, i));
  return tau;
}

// Plastic return mapping (paper section 5, eqs. 9-11): F = F_E F_P with F_E the trial elastic
// gradient; clamps the singular values of F_E to [1 - theta_c, 1 + theta_s], moves the rest into
// F_P (F_P = V S^-1 U^T F) and returns the new J_P = det F_P. F_E and F_P are updated in place.
template <int D>
Real plasticReturnMapping(const SnowMaterial& m, Mat<D>& F_E, Mat<D>& F_P);

// Same, tracking only J_P (what the model needs: hardening depends on J_P alone). Returns new J_P
// and sets R_E to the polar rotation U V^T of the new F_E, which the next stress evaluation
// needs: one decomposition per particle per step instead of two. F_E is left bit for bit as it is
// when no singular value is clamped. 2D works in closed form through the polar decomposition. 3D
// finds the polar rotation by Newton's iteration and needs an SVD only when a singular value
// leaves its bounds.
template <class T>
T plasticReturnMappingJ(const SnowMaterial& m, Mat<2, T>& F_E, std::type_identity_t<T> J_P,
                        Mat<2, T>& R_E);
template <class T>
T plasticReturnMappingJ(const SnowMaterial& m, Mat<3, T>& F_E, std::type_identity_t<T> J_P,
                        Mat<3, T>& R_E);
// The 3D one for particles ps of the arrays F_E and J_P, with the results of the call above
// for each, the rotations in the order of ps (R_E[i] that of particle ps[i]; none if R_E is
// null), and, so that no rotation need be kept per particle, each one's hardening factor
// computed anew where J_P changed and its Kirchhoff stress (fixedCorotatedKirchhoffUpper) in tau: a
// particle per vector lane, returnMappingLanes at a time, and those of each returnMappingBatch
// beyond their bounds gathered for the SVD; compiled for isa (vectorIsa(); each build gives the
// same results).
inline constexpr int returnMappingLanes = 8;
inline constexpr int returnMappingBatch = 64;
template <class T>
void plasticReturnMappingJ(const SnowMaterial& m, std::span<const int> ps, Mat<3, T>* F_E, T* J_P,
                           Mat<3, T>* R_E, T* hardening, Symmetric<3, T>* tau, VectorIsa isa);

// The 2D one for particles ps, the rotations not kept: each particle's F_E and J_P as the call
// above leaves them, its hardening factor computed anew where J_P changed and its Kirchhoff stress
// in tau, a particle per vector lane; bit for bit the scalar closed form on every build.
template <class T>
void plasticReturnMappingJ(const SnowMaterial& m, std::span<const int> ps, Mat<2, T>* F_E, T* J_P,
                           T* hardening, Symmetric<2, T>* tau, VectorIsa isa);

// P-wave speed sqrt((lambda + 2 mu) / rho), used by the CFL limit.
template <class T>
inline T pWaveSpeed(const LameOf<T>& lame, T rho) {
  return std::sqrt((lame.lambda + 2 * lame.mu) / rho);
}

}  // namespace snowsim
