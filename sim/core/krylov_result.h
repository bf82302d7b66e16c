// What an iterative linear solve reports, and a run's tally of them: apart from sim/core/krylov.h
// so that the solver and simulation interfaces report solves without pulling in Eigen.
#pragma once

#include <algorithm>

namespace snowsim {

struct KrylovResult {
  int iterations = 0;
  double residual = 0;  // ||b - A x|| / ||b|| at exit
  bool converged = false;
};

// The solves of a run, for its summary: a solve that ends short of its tolerance (at its
// iteration limit, or on a breakdown) leaves its residual above it and the run goes on with that
// answer, so the count is reported.
struct SolveTally {
  // All long: no padding, so a checkpoint that stores the tally as bytes holds no unset ones.
  long solves = 0, iterations = 0, unconverged = 0, most_iterations = 0;
  void add(const KrylovResult& r) {
    ++solves;
    iterations += r.iterations;
    unconverged += r.converged ? 0 : 1;
    most_iterations = std::max(most_iterations, long{r.iterations});
  }
};

}  // namespace snowsim
