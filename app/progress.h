// A run's progress on stderr: on a terminal, one line redrawn between steps at most four times a
// second; elsewhere (a log, a cluster job), one line per frame written.
#pragma once

#include <chrono>
#include <cstdio>
#include <string>

#include "sim/simulation.h"

namespace snowsim {

// The steps from simulated time `time` to `duration` at `step`, and past `impact_time` at
// `hardened_step` when that is shorter (none: hardened_step 0).
double stepsLeft(double time, double duration, double step, double impact_time,
                 double hardened_step);

class Progress {
 public:
  // frames: the last frame's number; duration: the simulated seconds the run ends at.
  Progress(int frames, double duration, bool terminal, std::FILE* out = stderr);

  // The run resumed from a checkpoint: rates count from the simulation's state now.
  void resumedAt(const Simulation& simulation);
  // The forecast step after impact (app/step_forecast.h): until simulated time `impact_time` the
  // steps left are counted at the step the run takes now, after it at `hardened_step` at most.
  void expectHardening(double impact_time, double hardened_step);
  // Between steps: redraws the terminal line if a quarter of a second has passed.
  void step(const Simulation& simulation);
  // After frame `frame` was written.
  void frame(int frame, const Simulation& simulation);
  void done();
  // A line of its own (an estimate, a warning), kept apart from the redrawn progress line.
  void note(const std::string& text);

  // "frame 3/50  t = 0.060 / 1.000 s  1234 steps, 5210 a second  dt 1.2e-04 s  ETA 12 s", with
  // "  62% asleep" before the ETA when auto-sleep is on. The ETA is the steps left at the step
  // now (and the hardened one after the impact to come) at the wall seconds a step took so far.
  std::string line(int frame, const Simulation& simulation);

 private:
  using Clock = std::chrono::steady_clock;
  double elapsed() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }

  int frames_;
  double duration_;
  bool terminal_;
  std::FILE* out_;
  Clock::time_point start_ = Clock::now();
  Clock::time_point drawn_ = Clock::now();
  int frame_ = 0;  // the last frame written
  // Where the last line was taken: the step size is the simulated time per step since then.
  long steps_then_ = 0;
  double time_then_ = 0;
  long steps_at_start_ = 0;  // where this process started: resumed, the checkpoint's
  double time_at_start_ = 0;
  double dt_ = 0;
  double impact_time_ = 0, hardened_step_ = 0;  // none: hardened_step_ 0
};

}  // namespace snowsim
