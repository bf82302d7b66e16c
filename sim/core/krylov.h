// Conjugate residual for symmetric, possibly indefinite systems A x = b (Saad, "Iterative Methods
// for Sparse Linear Systems", Algorithm 6.20), with an optional symmetric positive definite
// preconditioner, as the semi-implicit MPM solve uses it (Stomakhin et al. 2013, section 9).
// Matrix-free: A is a callable apply(x, y) setting y = A x.
#pragma once

#include <Eigen/Core>
#include <cmath>

#include "sim/core/krylov_result.h"

namespace snowsim {

// Work vectors, sized once and reused so iterations allocate nothing.
struct ConjugateResidualWork {
  Eigen::VectorXd r, z, p, Az, Ap, q;
  void resize(Eigen::Index n) {
    for (Eigen::VectorXd* v : {&r, &z, &p, &Az, &Ap, &q}) v->resize(n);
  }
};

// Solves A x = b starting from x; stops when ||r|| <= tolerance ||b|| or after max_iterations.
// precondition(r, z) sets z = P^-1 r for a symmetric positive definite P that approximates A:
// this is conjugate residual on P^-1 A, self-adjoint in the P inner product, and with P = I it is
// plain conjugate residual. The residual tested is the unpreconditioned b - A x (carried by
// recurrence), not P^-1 (b - A x).
template <class Apply, class Precondition>
KrylovResult conjugateResidual(Apply&& apply, Precondition&& precondition, const Eigen::VectorXd& b,
                               Eigen::VectorXd& x, double tolerance, int max_iterations,
                               ConjugateResidualWork& w) {
  KrylovResult result;
  const double b_norm = b.norm();
  if (b_norm == 0) {
    x.setZero();
    result.converged = true;
    return result;
  }
  w.resize(b.size());
  apply(x, w.Az);
  w.r = b - w.Az;
  precondition(w.r, w.z);
  w.p = w.z;
  apply(w.z, w.Az);
  w.Ap = w.Az;
  double zAz = w.z.dot(w.Az);
  result.residual = w.r.norm() / b_norm;
  while (result.residual > tolerance && result.iterations < max_iterations) {
    precondition(w.Ap, w.q);
    const double ApQ = w.Ap.dot(w.q);
    if (ApQ == 0 || zAz == 0) break;  // breakdown: report as not converged
    const double alpha = zAz / ApQ;
    x += alpha * w.p;
    w.r -= alpha * w.Ap;
    w.z -= alpha * w.q;
    ++result.iterations;
    result.residual = w.r.norm() / b_norm;
    if (result.residual <= tolerance) break;
    apply(w.z, w.Az);
    const double zAz_new = w.z.dot(w.Az);
    const double beta = zAz_new / zAz;
    zAz = zAz_new;
    w.p = w.z + beta * w.p;
    w.Ap = w.Az + beta * w.Ap;
  }
  result.converged = result.residual <= tolerance && std::isfinite(result.residual);
  return result;
}

// Plain conjugate residual (no preconditioner).
template <class Apply>
KrylovResult conjugateResidual(Apply&& apply, const Eigen::VectorXd& b, Eigen::VectorXd& x,
                               double tolerance, int max_iterations, ConjugateResidualWork& w) {
  return conjugateResidual(
      apply, [](const Eigen::VectorXd& r, Eigen::VectorXd& z) { z = r; }, b, x, tolerance,
      max_iterations, w);
}

}  // namespace snowsim
