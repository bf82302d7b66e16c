// What it costs two threads to meet, which sim/team.h is built on: an empty OpenMP parallel
// region, an OpenMP barrier, std::barrier and SpinBarrier, in µs per meeting (median of
// repetitions). An explicit MPM step opens one region and passes five barriers (six every 64
// steps, when the particles are stored sorted).
// Usage: sync_bench [meetings=20000] [repetitions=7]
#include <omp.h>

#include <barrier>
#include <cstdio>
#include <cstdlib>

#include "bench/median.h"
#include "sim/team.h"

using snowsim::SpinBarrier;

int main(int argc, char** argv) {
  const int meetings = argc > 1 ? std::atoi(argv[1]) : 20000;
  const int reps = argc > 2 ? std::atoi(argv[2]) : 7;
  if (meetings <= 0 || reps <= 0) {
    std::fprintf(stderr, "sync_bench: meetings and repetitions must be positive integers\n");
    return 2;
  }
  int threads = 0;
#pragma omp parallel num_threads(2)
#pragma omp single
  threads = omp_get_num_threads();
  if (threads != 2) {
    std::fprintf(stderr, "sync_bench: the OpenMP runtime granted %d threads, not 2\n", threads);
    return 1;
  }
  const auto perMeeting = [&](auto&& run) { return medianMs(reps, run) * 1e3 / meetings; };

  const double region = perMeeting([&] {
    for (int i = 0; i < meetings; ++i) {
#pragma omp parallel num_threads(2)
      { asm volatile("" ::: "memory"); }  // an empty body the compiler keeps
    }
  });
  const double omp_barrier = perMeeting([&] {
#pragma omp parallel num_threads(2)
    for (int i = 0; i < meetings; ++i) {
#pragma omp barrier
    }
  });
  std::barrier<> std_barrier(2);
  const double standard = perMeeting([&] {
#pragma omp parallel num_threads(2)
    for (int i = 0; i < meetings; ++i) std_barrier.arrive_and_wait();
  });
  SpinBarrier spin;
  const double spinning = perMeeting([&] {
#pragma omp parallel num_threads(2)
    for (int i = 0; i < meetings; ++i) spin.wait(2);
  });
  std::printf(
      "two threads meeting, µs each: OpenMP parallel region %.2f, OpenMP barrier %.2f, "
      "std::barrier %.2f, SpinBarrier %.2f\n",
      region, omp_barrier, standard, spinning);
}
