// How one stage's work is cut among the parts of a team (sim/parallel/team.h) so that they finish
// together. The threads of a shared machine are not equally fast, and a part's items cost more
// near a cut, where its data is in the other core's cache: each part's share follows its measured
// speed (items per second) relative to the parts' mean, bounded and smoothed over steps, so that
// one preempted step does not move the cut much. The cut changes no result.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

namespace snowsim {

class WorkShares {
 public:
  // Equal shares, nothing measured.
  void reset(int parts) {
    speed_.assign(parts, 1);
    measures_.assign(parts, Measure());
    share_.resize(parts + 1);
    cutBySpeed();
  }
  int parts() const { return static_cast<int>(speed_.size()); }

  // Where part `part` starts among `count` items.
  int start(int part, int count) const {
    return static_cast<int>(std::lround(count * share_[part]));
  }

  // What part `part` did in the last stage; each part records its own.
  void record(int part, int items, double seconds) { measures_[part] = {items, seconds}; }

  // The next cut, from the speeds recorded since the last one.
  void update() {
    const auto rate = [&](int part) {  // items per second, 0 if the part had none
      const Measure& m = measures_[part];
      return m.items > 0 && m.seconds > 0 ? m.items / m.seconds : 0.0;
    };
    double mean = 0;
    int measured = 0;
    for (int part = 0; part < parts(); ++part)
      if (rate(part) > 0) mean += rate(part), ++measured;
    // A part that had no items is tried again at the mean.
    if (measured > 0) {
      mean /= measured;
      for (int part = 0; part < parts(); ++part) {
        const double relative = rate(part) > 0 ? std::clamp(rate(part) / mean, 0.25, 4.0) : 1.0;
        speed_[part] = 0.75 * speed_[part] + 0.25 * relative;
      }
    }
    cutBySpeed();
  }

 private:
  void cutBySpeed() {
    double total = 0;
    for (const double s : speed_) total += s;
    double sum = 0;
    for (int part = 0; part < parts(); ++part) {
      share_[part] = sum / total;
      sum += speed_[part];
    }
    share_[parts()] = 1;
  }

  struct Measure {
    int items = 0;
    double seconds = 0;
  };
  std::vector<double> speed_;  // relative to the parts' mean, smoothed over steps
  std::vector<double> share_;  // part t takes the fractions share_[t] .. share_[t + 1] of all
  std::vector<Measure> measures_;
};

}  // namespace snowsim
