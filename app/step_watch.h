// A warning, once, when the step the time-step policy chooses collapses: below a quarter of the
// step the run started with, a run costs over four times what its start promised. It says which
// term of the stable step grew (sim/solver.h, StepLimit): the elastic wave speed of hardened
// snow, or the speed of the snow.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "sim/scene/scene.h"
#include "sim/simulation.h"

namespace snowsim {

class StepWatch {
 public:
  // A ball that falls and comes to rest keeps over half its first step (0.52 on the MPM drop); a
  // ball thrown at a wall at 3 m/s hardens and falls to 0.16 of it (docs/performance.md, "Running
  // at scale"). A quarter is past the first and early in the second.
  static constexpr double collapse_fraction = 0.25;

  // initial_step: the first step of the run; the limit of the state it starts from.
  StepWatch(const Scene& scene, double initial_step, const StepLimit& initial_limit);

  // What a checkpoint keeps of the watch, and the watch continued from it (resume).
  nlohmann::json state() const;
  StepWatch(const Scene& scene, const nlohmann::json& state);

  // Between steps: the warning, the first time the smallest step chosen fell below
  // collapse_fraction of the initial step; empty otherwise.
  std::string check(const Simulation& simulation);
  // What run.json records of it: null when the step held.
  const nlohmann::json& record() const { return record_; }

 private:
  const Scene& scene_;
  double initial_step_;
  StepLimit initial_limit_;
  nlohmann::json record_;
};

}  // namespace snowsim
