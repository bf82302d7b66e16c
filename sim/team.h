// The threads that share the stages of one MPM step. A stage is cut into parts, one per thread;
// each part runs on one thread and the stages meet at barriers. The stages of a step can share
// one OpenMP parallel region, because opening a region costs about two of libgomp's barriers
// and each of those makes a futex call: 3 and 1.4 µs against 0.3-0.5 µs for SpinBarrier on this
// machine (bench/sync_bench), while a two-thread explicit step of the small 2D bench takes about
// 210 µs.
#pragma once

#include <omp.h>

#include <atomic>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace snowsim {

// Waits for all the threads of a parallel region; spins, then sleeps (a futex wait through
// std::atomic::wait), so that more threads than cores, or a busy machine, still make progress.
// Its release orders every write before it before every read after it.
class SpinBarrier {
 public:
  SpinBarrier() = default;
  // Between parallel regions no thread waits and the state is idle: a moved barrier starts anew.
  SpinBarrier(SpinBarrier&&) noexcept {}
  SpinBarrier& operator=(SpinBarrier&&) noexcept { return *this; }

  void wait(int threads) {
    const unsigned generation = generation_.load(std::memory_order_acquire);
    if (arrived_.fetch_add(1, std::memory_order_acq_rel) == threads - 1) {  // the last one
      arrived_.store(0, std::memory_order_relaxed);
      // Sequentially consistent, so that notify_all's check for sleepers cannot miss one that
      // went to sleep on the old generation.
      generation_.store(generation + 1, std::memory_order_seq_cst);
      generation_.notify_all();  // no system call unless a thread sleeps
      return;
    }
    for (int spins = 0; spins < spins_before_sleep; ++spins) {
      if (generation_.load(std::memory_order_acquire) != generation) return;
      pause();
    }
    while (generation_.load(std::memory_order_acquire) == generation)
      generation_.wait(generation, std::memory_order_acquire);
  }

 private:
  static void pause() {
#if defined(__x86_64__) || defined(__i386__)
    _mm_pause();
#endif
  }
  static constexpr int spins_before_sleep = 4096;  // tens to hundreds of µs, by processor
  alignas(64) std::atomic<int> arrived_{0};        // each on its own cache line
  alignas(64) std::atomic<unsigned> generation_{0};
};

// Runs the parts of each stage on the threads of a parallel region. Outside together(), each
// forEachPart opens a region of its own. Inside together(), every thread runs the body: code
// there outside forEachPart and serially runs on every thread, so it may read shared state but
// never write it.
class Team {
 public:
  // The number of parts of each stage, and whether they run in parallel at all.
  void configure(int parts, bool parallel) {
    parts_ = parts;
    parallel_ = parallel;
  }

  // body() on every thread of one parallel region if `shared`, else on the calling thread alone
  // (each stage then opens its own region).
  template <class F>
  void together(bool shared, F&& body) {
    if (!shared) {
      body();
      return;
    }
    shared_ = true;
#pragma omp parallel num_threads(parts_) if (parallel_)
    body();
    shared_ = false;
  }

  // f(part) for every part, then all threads wait for the last part to finish.
  template <class F>
  void forEachPart(F&& f) {
    if (shared_) {
      runMyParts(f);
      barrier_.wait(omp_get_num_threads());
      return;
    }
#pragma omp parallel num_threads(parts_) if (parallel_)
    runMyParts(f);
  }

  // f() on one thread, the others waiting for it.
  template <class F>
  void serially(F&& f) {
    if (!shared_) {
      f();
      return;
    }
    if (omp_get_thread_num() == 0) f();
    barrier_.wait(omp_get_num_threads());
  }

 private:
  template <class F>
  void runMyParts(F& f) {
    // The runtime may grant fewer threads than parts: a thread then takes several.
    const int threads = omp_get_num_threads();
    for (int part = omp_get_thread_num(); part < parts_; part += threads) f(part);
  }

  int parts_ = 1;
  bool parallel_ = false;
  bool shared_ = false;  // inside together(): set before the region opens, read inside it
  SpinBarrier barrier_;
};

}  // namespace snowsim
