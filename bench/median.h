// Timing helper for the bench/ programs: the median of repeated runs, robust to a shared machine.
#pragma once

#include <algorithm>
#include <chrono>
#include <vector>

// Runs f `repetitions` times and returns the median wall time in milliseconds.
template <class F>
double medianMs(int repetitions, F&& f) {
  std::vector<double> ms;
  for (int r = 0; r < repetitions; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::nth_element(ms.begin(), ms.begin() + repetitions / 2, ms.end());
  return ms[repetitions / 2];
}
