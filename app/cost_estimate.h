// What a run will cost, said before it starts (or resumes): its particles, its grid, and the steps
// and particle-steps its duration (or what is left of it) takes at the step it starts with and,
// for explicit MPM, the step it comes down to once its snow hardens on impact
// (app/step_forecast.h); then, once its first steps are measured, the time those particle-steps
// take at their rate, a range where a moving collider or cracks that open make it uncertain.
#pragma once

#include <optional>
#include <string>

#include "app/step_forecast.h"
#include "sim/scene/scene.h"
#include "sim/simulation.h"

namespace snowsim {

class CostEstimate {
 public:
  // Steps timed for the rate, after the first (which also sets up the solver's arrays and pages):
  // at least measured_steps and measured_seconds of them, so that a small scene's rate is not a
  // few milliseconds' noise, and at most most_measured_steps.
  static constexpr int measured_steps = 10;
  static constexpr double measured_seconds = 0.1;
  static constexpr int most_measured_steps = 100;

  // Before the first step, which is time.dt or the stable step of `start`, whichever is smaller.
  // A resumed run gives the time it had simulated and the steps it had taken: the estimate is of
  // what is left.
  struct Resumed {
    double simulated;
    long steps_taken;
  };
  CostEstimate(const Scene& scene, int particles, const StepLimit& start,
               std::optional<Resumed> resumed = std::nullopt);

  // The step the run starts with.
  double initialStep() const { return initial_step_; }
  // The step after impact, its impact time counted from where the run starts or resumes.
  const std::optional<StepForecast>& forecast() const { return forecast_; }

  // "snowball_drop: 25 particles, 10 x 12 cells of 0.01 m; 1 s simulated at a first step of
  // 0.001 s: about 1000 steps, 25 thousand particle-steps"
  std::string before() const;
  // Between steps: once the steps after the first are timed, the time estimate and the rate it
  // is from (empty before that, and after it was given once).
  std::string afterStep(const Simulation& simulation);

 private:
  double stepCount() const;  // of the duration, the step shrinking on impact
  std::string name_;
  std::string grid_;  // "10 x 12 cells of 0.01 m"
  double duration_;   // left to simulate
  bool resumed_;
  long steps_taken_;
  int particles_;
  double initial_step_;
  std::optional<StepForecast> forecast_;
  bool may_harden_further_ = false;  // a moving collider keeps compacting unbounded hardening
  bool mesh_collider_ = false;       // steps in contact with a mesh cost more than in the air
  bool open_cracks_;                 // mpm.open_cracks: steps cost more once the snow stretches
  double particle_steps_;
  double seconds_after_first_ = -1;       // the steps' wall time after the first step
  double crack_seconds_after_first_ = 0;  // of it, in the crack stages
  bool cracks_timed_ = false;             // the first timed step was a crack step
  bool said_ = false;
};

// "about 1.2 million" for counts from ten thousand up; the plain number below.
std::string roughCount(double count);
// "0.38 s", "45 s", "12 min", "3.2 h".
std::string roughDuration(double seconds);

}  // namespace snowsim
