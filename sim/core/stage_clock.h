// Wall time per named stage of a run, as one thread sees it: the thread that steps the solver
// (from a stage's start until every thread has finished it) or the command line's main thread.
// Stages are timed one after another, never inside one another, so their sum is at most the time
// they were taken in. Two clock reads per stage; an entry is made the first time a stage is met.
#pragma once

#include <chrono>
#include <string_view>
#include <vector>

namespace snowsim {

struct StageSeconds {
  std::string_view stage;  // a string literal: it outlives every clock
  double seconds = 0;
};

class StageClock {
 public:
  // Adds the time from its making to its end to the stage's; with no clock, times nothing.
  class Scope {
   public:
    Scope(StageClock* clock, std::string_view stage)
        : clock_(clock), stage_(stage), start_(clock ? Clock::now() : Clock::time_point()) {}
    ~Scope() {
      if (clock_) clock_->add(stage_, std::chrono::duration<double>(Clock::now() - start_).count());
    }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    StageClock* clock_;
    std::string_view stage_;
    std::chrono::steady_clock::time_point start_;
  };

  void add(std::string_view stage, double seconds) {
    for (StageSeconds& entry : stages_)
      if (entry.stage == stage) {
        entry.seconds += seconds;
        return;
      }
    stages_.push_back({stage, seconds});
  }
  // In the order first met.
  const std::vector<StageSeconds>& stages() const { return stages_; }

 private:
  using Clock = std::chrono::steady_clock;
  std::vector<StageSeconds> stages_;
};

}  // namespace snowsim
