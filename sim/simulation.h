// Time stepping from frame to frame, independent of dimension and solver: the driver the command
// line, the benchmarks and the tests share.
#pragma once

#include <functional>
#include <memory>

#include "sim/core/krylov_result.h"
#include "sim/core/snapshot.h"
#include "sim/scene/scene.h"
#include "sim/solver.h"

namespace snowsim {

class Simulation {
 public:
  virtual ~Simulation() = default;

  // Steps until the simulated time reaches t (the last step is shortened to land on it). Checks
  // stop_requested() before each step and returns false, short of t, once it says so. Throws
  // SimulationError when the state stops being finite.
  virtual bool advanceTo(double t, const std::function<bool()>& stop_requested = {}) = 0;

  virtual Snapshot snapshot(int frame) const = 0;
  virtual double time() const = 0;
  virtual long steps() const = 0;
  // The smallest and largest step the time-step policy chose (none before the first step).
  virtual StepSizes chosenSteps() const = 0;
  virtual int particleCount() const = 0;
  virtual SolveTally implicitSolves() const = 0;  // the semi-implicit solves so far
};

// Builds the particles and the solver the scene asks for, in the scene's dimension. `threads`
// bounds the solver's threads; 0 takes the OpenMP default (OMP_NUM_THREADS, else every core).
std::unique_ptr<Simulation> makeSimulation(const Scene& scene, int threads = 0);

}  // namespace snowsim
