#include "app/progress.h"

#include <algorithm>
#include <cmath>

namespace snowsim {

Progress::Progress(int frames, double duration, bool terminal, std::FILE* out)
    : frames_(frames), duration_(duration), terminal_(terminal), out_(out) {}

void Progress::resumedAt(const Simulation& simulation) {
  steps_then_ = steps_at_start_ = simulation.steps();
  time_then_ = time_at_start_ = simulation.time();
}

void Progress::expectHardening(double impact_time, double hardened_step) {
  impact_time_ = impact_time;
  hardened_step_ = hardened_step;
}

double stepsLeft(double time, double duration, double step, double impact_time,
                 double hardened_step) {
  if (hardened_step <= 0 || time >= impact_time || impact_time >= duration)
    return (duration - time) / step;
  return (impact_time - time) / step + (duration - impact_time) / std::min(step, hardened_step);
}

std::string Progress::line(int frame, const Simulation& simulation) {
  const long steps = simulation.steps();
  const double time = simulation.time(), wall = elapsed();
  if (steps > steps_then_) dt_ = (time - time_then_) / double(steps - steps_then_);
  steps_then_ = steps;
  time_then_ = time;
  char text[200];
  int n = std::snprintf(
      text, sizeof text, "frame %d/%d  t = %.3f / %.3f s  %ld steps, %.0f a second", frame, frames_,
      time, duration_, steps, wall > 0 ? double(steps - steps_at_start_) / wall : 0.0);
  if (dt_ > 0) n += std::snprintf(text + n, sizeof text - n, "  dt %.1e s", dt_);
  const SleepTally sleep = simulation.statistics().auto_sleep;
  if (sleep.particles > 0)  // auto-sleep is on: the share asleep after the last step
    n += std::snprintf(text + n, sizeof text - n, "  %.0f%% asleep",
                       100.0 * double(sleep.asleep_now) / double(sleep.particles));
  if (dt_ > 0 && steps > steps_at_start_ && time < duration_)
    std::snprintf(text + n, sizeof text - n, "  ETA %.0f s",
                  stepsLeft(time, duration_, dt_, impact_time_, hardened_step_) * wall /
                      double(steps - steps_at_start_));
  return text;
}

void Progress::step(const Simulation& simulation) {
  if (!terminal_ || Clock::now() - drawn_ < std::chrono::milliseconds(250)) return;
  drawn_ = Clock::now();
  std::fprintf(out_, "\r%s\033[K", line(frame_, simulation).c_str());
  std::fflush(out_);
}

void Progress::frame(int frame, const Simulation& simulation) {
  frame_ = frame;
  if (terminal_) {
    drawn_ = Clock::now();
    std::fprintf(out_, "\r%s\033[K", line(frame, simulation).c_str());
  } else {
    std::fprintf(out_, "%s\n", line(frame, simulation).c_str());
  }
  std::fflush(out_);
}

void Progress::done() {
  if (terminal_) std::fprintf(out_, "\n");
}

void Progress::note(const std::string& text) {
  // On a terminal the progress line is cleared first and drawn again at the next step.
  std::fprintf(out_, "%s%s\n", terminal_ ? "\r\033[K" : "", text.c_str());
  std::fflush(out_);
}

}  // namespace snowsim
