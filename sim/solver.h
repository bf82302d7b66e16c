// What the time-stepping driver needs of a solver, and the one clock of a run: a solver advances
// its state, the base counts the steps and the simulated time and checks the state after each.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

#include "sim/core/grid.h"
#include "sim/core/particles.h"
#include "sim/core/snapshot.h"
#include "sim/core/solver_statistics.h"
#include "sim/core/stage_clock.h"
#include "sim/scene/scene.h"

namespace snowsim {

class StateWriter;  // sim/io/checkpoint.h
class StateReader;

// What snapshotParticles writes, from particles of either precision (a float converts to double
// exactly, so the snapshot is the same bytes either way). The radius is half the side of the
// particle's share of its body's volume.
template <int D, class T>
void putParticles(const Particles<D, T>& p, const Scene& scene, Snapshot& s) {
  s.position.resize(p.size());
  s.velocity.resize(p.size());
  s.mass.resize(p.size());
  s.radius.resize(p.size());
  for (int i = 0; i < p.size(); ++i) {  // in creation order, however the solver stores them
    const int id = p.id[i];
    for (int a = 0; a < 3; ++a) {
      s.position[id][a] = a < D ? static_cast<float>(p.x[i][a]) : 0.f;
      s.velocity[id][a] = a < D ? static_cast<float>(p.v[i][a]) : 0.f;
    }
    const double mass = p.mass[i];
    s.mass[id] = static_cast<float>(mass);
    s.radius[id] =
        static_cast<float>(std::pow(mass / scene.bodies[p.body[i]].density, 1.0 / D) / 2);
  }
}

struct StepSizes {
  double smallest = std::numeric_limits<double>::infinity(), largest = 0;
};

// What bounds the stable step now, for telling a user why it shrank: the particle whose signal
// speed sets the step, that speed split into the particle's own speed (the step keeps it from
// crossing a cell) and its elastic wave speed (an explicit step must resolve the wave), which
// plastic hardening raises. A limit with no elastic term has wave_speed 0.
struct StepLimit {
  double step = std::numeric_limits<double>::infinity();  // the stable step (s)
  double particle_speed = 0;                              // |v_p| (m/s)
  double wave_speed = 0;                                  // the P-wave speed c_p (m/s)
  double plastic_j = 1;                                   // J_P
  double hardening = 1;  // exp(xi (1 - J_P)): the Lame parameters' factor, c_p's squared
};

template <int D>
class Solver {
 public:
  virtual ~Solver() = default;

  // Advances the state by dt seconds. Throws SimulationError (naming the step and the time, not
  // the scene file: the caller adds it) when the state has diverged.
  void step(Real dt) {
    const auto start = std::chrono::steady_clock::now();
    if (steps_ == 0) beforeFirstStep();
    advance(dt);
    ++steps_;
    time_ += dt;
    checkDivergence(dt);
    step_seconds_ +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  // Steps of at most max_dt, and at most what stability allows, until the time reaches target;
  // the last step is shortened to land on it. Returns false, short of the target, if
  // stop_requested() says so before a step.
  bool advanceTo(Real target, Real max_dt, const std::function<bool()>& stop_requested = {}) {
    while (target - time_ > 1e-9 * max_dt) {
      if (stop_requested && stop_requested()) return false;
      Real dt = chooseStep(max_dt);
      // Land exactly on the target instead of leaving a sliver for one more step.
      if (target - time_ - dt < 1e-6 * dt) dt = target - time_;
      step(dt);
    }
    time_ = std::max(time_, target);
    return true;
  }
  // One step of at most max_dt, and at most what stability allows, as advanceTo takes them.
  void stepOnce(Real max_dt) { step(chooseStep(max_dt)); }
  long steps() const { return steps_; }
  Real time() const { return time_; }
  // The smallest and largest steps advanceTo chose, before any was shortened to land on a target.
  const StepSizes& chosenSteps() const { return chosen_; }

  // The largest time step the solver's stability allows now (infinity when it has no limit).
  virtual Real stableTimeStep() const { return std::numeric_limits<Real>::infinity(); }
  // What sets stableTimeStep() now; a look over every particle, for messages, not for each step.
  // Across MPI ranks every rank calls it at once, each getting the particle of all ranks.
  virtual StepLimit stepLimit() const { return {stableTimeStep()}; }

  // The wall time of the steps so far, and of the stages a solver times within them.
  double stepSeconds() const { return step_seconds_; }
  virtual std::vector<StageSeconds> stageSeconds() const { return {}; }

  // Across MPI ranks every rank's particles on rank 0 and none on the others (each rank calls it
  // at once); particleCount() is every rank's count on each.
  virtual const Particles<D>& particles() const = 0;
  virtual int particleCount() const { return particles().size(); }  // across MPI ranks: all
  // The particles' positions, velocities, masses and radii into a snapshot, in creation order. A
  // solver that keeps its state in float writes them from its own arrays: particles() would make
  // a double copy of them first.
  virtual void snapshotParticles(const Scene& scene, Snapshot& snapshot) const {
    putParticles(particles(), scene, snapshot);
  }

  // What the solver counted so far (sim/core/solver_statistics.h).
  virtual SolverStatistics statistics() const { return {}; }

  // Fills the solver-specific parts of a snapshot (per-particle density, grid densities, ...).
  virtual void describe(Snapshot& snapshot) const = 0;

  // Everything later steps depend on, for a checkpoint: the clock, the step sizes chosen, and
  // the solver's own state. loadState restores it into a solver built from the same scene, which
  // then takes the very steps the saved one would have; throws InputError (naming the file the
  // reader reads) when the state does not fit this solver.
  void saveState(StateWriter& out) const;  // sim/solver.cpp
  void loadState(StateReader& in);

 protected:
  virtual void saveSolverState(StateWriter& out) const = 0;
  virtual void loadSolverState(StateReader& in) = 0;
  virtual void beforeFirstStep() {}
  virtual void advance(Real dt) = 0;
  // Throws SimulationError when the state after a step of dt cannot go on.
  virtual void checkDivergence(Real dt) const = 0;

 private:
  Real chooseStep(Real max_dt) {
    const Real dt = std::min(max_dt, stableTimeStep());
    chosen_.smallest = std::min(chosen_.smallest, dt);
    chosen_.largest = std::max(chosen_.largest, dt);
    return dt;
  }

  long steps_ = 0;
  Real time_ = 0;
  StepSizes chosen_;
  double step_seconds_ = 0;
};

// The scene's grid and gravity in the simulation's dimension.
template <int D>
GridGeometry<D> sceneGrid(const Scene& scene) {
  IVec<D> cells;
  for (int a = 0; a < D; ++a) cells[a] = scene.cells[a];
  return GridGeometry<D>(cells, scene.cell_size);
}
template <int D>
Vec<D> sceneGravity(const Scene& scene) {
  Vec<D> g;
  for (int a = 0; a < D; ++a) g[a] = scene.gravity[a];
  return g;
}

}  // namespace snowsim
