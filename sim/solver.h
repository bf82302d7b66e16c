// What the time-stepping driver needs of a solver.
#pragma once

#include <limits>

#include "sim/core/krylov_result.h"
#include "sim/core/particles.h"
#include "sim/core/snapshot.h"

namespace snowsim {

template <int D>
class Solver {
 public:
  virtual ~Solver() = default;

  // Advances the state by dt seconds.
  virtual void step(Real dt) = 0;

  // The largest time step the solver's stability allows now (infinity when it has no limit).
  virtual Real stableTimeStep() const { return std::numeric_limits<Real>::infinity(); }

  virtual const Particles<D>& particles() const = 0;

  // The linear solves of its semi-implicit steps so far (none for an explicit solver).
  virtual SolveTally implicitSolves() const { return {}; }

  // Fills the solver-specific parts of a snapshot (per-particle density, grid densities, ...).
  virtual void describe(Snapshot& snapshot) const = 0;
};

}  // namespace snowsim
