// Conjugate residual for symmetric, possibly indefinite systems A x = b (Saad, "Iterative Methods
// for Sparse Linear Systems", Algorithm 6.20), as the semi-implicit MPM solve uses it
// (Stomakhin et al. 2013, section 9). Matrix-free: A is a callable apply(x, y) setting y = A x.
#pragma once

#include <Eigen/Core>
#include <cmath>

namespace snowsim {

struct KrylovResult {
  int iterations = 0;
  double residual = 0;  // ||b - A x|| / ||b|| at exit
  bool converged = false;
};

// Work vectors, sized once and reused so iterations allocate nothing.
struct ConjugateResidualWork {
  Eigen::VectorXd r, p, Ar, Ap;
  void resize(Eigen::Index n) {
    r.resize(n);
    p.resize(n);
    Ar.resize(n);
    Ap.resize(n);
  }
};

// Solves A x = b starting from x; stops when ||r|| <= tolerance ||b|| or after max_iterations.
template <class Apply>
KrylovResult conjugateResidual(Apply&& apply, const Eigen::VectorXd& b, Eigen::VectorXd& x,
                               double tolerance, int max_iterations, ConjugateResidualWork& w) {
  KrylovResult result;
  const double b_norm = b.norm();
  if (b_norm == 0) {
    x.setZero();
    result.converged = true;
    return result;
  }
  w.resize(b.size());
  apply(x, w.Ar);
  w.r = b - w.Ar;
  w.p = w.r;
  apply(w.r, w.Ar);
  w.Ap = w.Ar;
  double rAr = w.r.dot(w.Ar);
  result.residual = w.r.norm() / b_norm;
  while (result.residual > tolerance && result.iterations < max_iterations) {
    const double ApAp = w.Ap.squaredNorm();
    if (ApAp == 0 || rAr == 0) break;  // breakdown: report as not converged
    const double alpha = rAr / ApAp;
    x += alpha * w.p;
    w.r -= alpha * w.Ap;
    ++result.iterations;
    result.residual = w.r.norm() / b_norm;
    if (result.residual <= tolerance) break;
    apply(w.r, w.Ar);
    const double rAr_new = w.r.dot(w.Ar);
    const double beta = rAr_new / rAr;
    rAr = rAr_new;
    w.p = w.r + beta * w.p;
    w.Ap = w.Ar + beta * w.Ap;
  }
  result.converged = result.residual <= tolerance && std::isfinite(result.residual);
  return result;
}

}  // namespace snowsim
