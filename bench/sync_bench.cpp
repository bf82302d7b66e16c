// What it costs two threads to meet, which sim/parallel/team.h is built on, in µs per meeting
// (median of repetitions): an empty OpenMP parallel region, against an empty task of
// sim/parallel/team.h's Team (its worker woken, then both meeting at the end); an OpenMP barrier,
// std::barrier and SpinBarrier, meeting back to back and with one thread arriving 2 µs after the
// other. An explicit MPM step is one task with three barriers (scatter, grid stage, particle pass),
// two more when it bins the particles (every step in 3D, rarely in 2D), and eight more when it
// stores them sorted (two for each of the sort's four rounds; at most every 16 steps). Usage:
// sync_bench [meetings=20000] [repetitions=7]
#include <omp.h>

#include <barrier>
#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "bench/median.h"
#include "sim/parallel/team.h"

using snowsim::SpinBarrier;
using snowsim::Team;

namespace {

// Busy for `us` microseconds: a thread's share of a stage.
void work(double us) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double, std::micro>(us);
  while (std::chrono::steady_clock::now() < end) {
  }
}

}  // namespace

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
  Team team;
  team.configure(2, true);
  const double task = perMeeting([&] {
    for (int i = 0; i < meetings; ++i) team.forEachPart("stage", [](int) {});
  });
  SpinBarrier spin(2);
  const double spinning = perMeeting([&] {
#pragma omp parallel num_threads(2)
    for (int i = 0; i < meetings; ++i) spin.wait(omp_get_thread_num());
  });
  // Stages whose parts end 2 µs apart: what the barrier adds to the 2 µs of the later part.
  const auto apart = [&](auto&& meet) {
    return perMeeting([&] {
#pragma omp parallel num_threads(2)
             for (int i = 0; i < meetings; ++i) {
               work(omp_get_thread_num() == 1 ? 2.0 : 0.0);
               meet();
             }
           }) -
           2.0;
  };
  const double omp_apart = apart([] {
#pragma omp barrier
  });
  const double standard_apart = apart([&] { std_barrier.arrive_and_wait(); });
  const double spinning_apart = apart([&] { spin.wait(omp_get_thread_num()); });
  std::printf(
      "two threads meeting, µs each: OpenMP parallel region %.2f, Team task %.2f; back to back: "
      "OpenMP barrier %.2f, std::barrier %.2f, SpinBarrier %.2f; 2 µs apart: OpenMP barrier "
      "%.2f, std::barrier %.2f, SpinBarrier %.2f\n",
      region, task, omp_barrier, standard, spinning, omp_apart, standard_apart, spinning_apart);
}
