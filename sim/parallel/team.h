// The threads that share the stages of one MPM step: the solver's one concurrency model. A stage
// is cut into parts, one per thread; each part runs on one thread and the stages meet at
// barriers. The team keeps its own worker threads, which wait for the next stage spinning
// briefly, then asleep. Plain OpenMP with its default waiting, which spins far longer, ran a
// real scene several times slower on a machine shared with other work, and no faster on an idle
// one (docs/performance.md, "Threads").
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <memory>
#include <string_view>
#include <thread>
#include <type_traits>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace snowsim {

// A counter that threads wait to see change: they spin, then sleep (a futex wait through
// std::atomic::wait), so that more threads than cores, or a busy machine, still make progress.
// It counts its own sleepers rather than calling notify_all after every change: libstdc++ 12
// files the sleepers of all 64-byte aligned atomics under one entry of its table, so one sleeping
// thread anywhere would make every notify_all a system call (bench/sync_bench).
class Signal {
 public:
  unsigned load() const { return value_.load(std::memory_order_acquire); }

  // Changes the value; wakes the sleepers with wake().
  void store(unsigned value) { value_.store(value, std::memory_order_release); }
  void add(unsigned n) { value_.fetch_add(n, std::memory_order_release); }

  // Wakes those asleep in awaitChange: either this sees the sleeper or the sleeper sees the change.
  void wake() {
    if (sleepersAfterChange() > 0) value_.notify_all();
  }

  // Returns once the value is no longer `old`.
  void awaitChange(unsigned old) {
    constexpr int spins_before_sleep = 4096;  // tens to hundreds of µs, by processor
    for (int spins = 0; spins < spins_before_sleep; ++spins) {
      if (load() != old) return;
      pause();
    }
    countSleeper();
    while (load() == old) value_.wait(old, std::memory_order_acquire);
    sleepers_.fetch_sub(1, std::memory_order_relaxed);
  }

 private:
  // The handshake of wake() and awaitChange. Fences order the change before the check for
  // sleepers, and the count of a sleeper before its check of the value. ThreadSanitizer does not
  // model fences, so under it both sides are acq_rel read-modify-writes of the count instead: of
  // the two, the later reads from the earlier, which then happens-before it. The same guarantee,
  // but a locked write to the shared line on every wake: Team's task round trip measured far
  // slower with it (bench/sync_bench), so the normal build keeps the fences.
#if defined(__SANITIZE_THREAD__)
  int sleepersAfterChange() {
    return sleepers_.fetch_add(0, std::memory_order_acq_rel);
  }
  void countSleeper() {
    sleepers_.fetch_add(1, std::memory_order_acq_rel);
  }
#else
  int sleepersAfterChange() {
    std::atomic_thread_fence(std::memory_order_seq_cst);
    return sleepers_.load(std::memory_order_relaxed);
  }
  void countSleeper() {
    sleepers_.fetch_add(1, std::memory_order_seq_cst);
    std::atomic_thread_fence(std::memory_order_seq_cst);
  }
#endif

  static void pause() {
#if defined(__x86_64__) || defined(__i386__)
    _mm_pause();
#endif
  }
  std::atomic<unsigned> value_{0};
  std::atomic<int> sleepers_{0};
};

// Waits for the threads of a team, each naming itself: a dissemination barrier (Hensgen, Finkel
// and Manber 1988). In round k thread i signals thread i + 2^k and waits for the signal of thread
// i - 2^k (mod the thread count), each signal a counter on its own cache line, written by one
// thread only. The last thread to arrive is released after one cache-line transfer per round,
// where a shared arrival counter costs three (bench/sync_bench). The signals' release and acquire
// order every write before the barrier before every read after it, on every thread.
class SpinBarrier {
 public:
  explicit SpinBarrier(int threads = 1) { resize(threads); }

  // While no thread waits.
  void resize(int threads) {
    threads_ = threads;
    rounds_ = 0;
    while ((1 << rounds_) < threads) ++rounds_;
    signals_ = std::make_unique<PaddedSignal[]>(static_cast<size_t>(rounds_) * threads);
    passed_ = std::make_unique<PaddedCount[]>(threads);
  }

  void wait(int thread) {
    const unsigned episode = ++passed_[thread].count;
    for (int round = 0; round < rounds_; ++round) {
      Signal& partner = signals_[round * threads_ + (thread + (1 << round)) % threads_].signal;
      partner.store(episode);
      Signal& mine = signals_[round * threads_ + thread].signal;
      // The signaller is at most one episode ahead: it cannot pass this one without us.
      for (unsigned seen; (seen = mine.load()) != episode && seen != episode + 1;)
        mine.awaitChange(seen);
      // Only now, so that the signal's transfer overlaps our wait. A partner asleep in this
      // round has signalled its own partner already, so every sleeper is woken in turn.
      partner.wake();
    }
  }

 private:
  struct alignas(64) PaddedSignal {
    Signal signal;
  };
  struct alignas(64) PaddedCount {
    unsigned count = 0;
  };
  int threads_ = 1, rounds_ = 0;
  std::unique_ptr<PaddedSignal[]> signals_;  // [round * threads + receiver]: the sender's episode
  std::unique_ptr<PaddedCount[]> passed_;    // per thread: the episodes it has passed
};

// Where one thread's time went in one stage, over the steps profiled: running its parts, and
// waiting at the stage's end for the other threads.
struct StageTime {
  std::string_view stage;
  double work_seconds = 0, wait_seconds = 0;
  long meetings = 0;
};

// Runs the parts of each stage on the team's threads: the calling thread is thread 0, and
// configure() starts one worker thread for each further part. Inside together(), every thread
// runs the body: code there outside forEachPart and serially runs on every thread, so it may read
// shared state but never write it, and it must not throw on any thread (a worker has no one to
// throw to, and a caller that threw would leave the workers waiting for it).
// Outside together(), each forEachPart is a meeting of its own.
class Team {
 public:
  Team() = default;
  // The workers know their team by address: a moved team stops them, and the next configure()
  // starts new ones.
  Team(Team&& other) : parts_(other.parts_) { other.stopWorkers(); }
  Team& operator=(Team&&) = delete;
  ~Team() { stopWorkers(); }

  // The number of parts of each stage, and whether they run in parallel at all: then one thread
  // per part.
  void configure(int parts, bool parallel) {
    parts_ = parts;
    const int threads = parallel ? parts : 1;
    if (threads == threads_) return;
    stopWorkers();
    threads_ = threads;
    if (profiling_) profile_.assign(threads, {});
    barrier_.resize(threads);
    finished_.resize(threads);
    const unsigned started = next_.start.load();
    for (int thread = 1; thread < threads; ++thread)
      workers_.emplace_back([this, thread, started] { work(thread, started); });
  }

  int parts() const { return parts_; }
  // Whether this is the thread that calls the team (thread 0), not one of its workers.
  static bool onCallingThread() { return thread_index == 0; }

  // body() on every thread of the team if `shared`, else on the calling thread alone (each stage
  // then meets on its own).
  template <class F>
  void together(bool shared, F&& body) {
    if (!shared || threads_ == 1) {
      body();
      return;
    }
    runOnAll(body, true);
  }

  // f(part) for every part of the stage named `stage`, then all threads wait for the last part
  // to finish. A profile keeps the name: it must outlive the team (a string literal does).
  template <class F>
  void forEachPart(std::string_view stage, F&& f) {
    const auto my_parts = [&] {
      for (int part = thread_index; part < parts_; part += threads_) f(part);
    };
    if (threads_ == 1) {
      runStage(stage, my_parts, [] {});
    } else if (!next_.shared) {  // the wait is runOnAll's, not profiled
      runOnAll([&] { runStage(stage, my_parts, [] {}); }, false);
    } else {
      runStage(stage, my_parts, [&] { barrier_.wait(thread_index); });
    }
  }

  // f() on one thread, the others waiting for it.
  template <class F>
  void serially(std::string_view stage, F&& f) {
    if (!next_.shared) {
      runStage(stage, f, [] {});
      return;
    }
    runStage(
        stage,
        [&] {
          if (thread_index == 0) f();
        },
        [&] { barrier_.wait(thread_index); });
  }

  // Profiling: while on, each thread adds the time of each stage to its own StageTimes, one per
  // stage name in the order first met. Turning it on clears the last profile; turn it on and off
  // between steps only.
  void profileStages(bool on) {
    profiling_ = on;
    if (on) profile_.assign(threads_, {});
  }
  // Thread `thread`'s times (0 is the caller), for `threads()` threads.
  const std::vector<StageTime>& stageTimes(int thread) const { return profile_[thread]; }
  int threads() const { return threads_; }

 private:
  using Clock = std::chrono::steady_clock;

  template <class Work, class Meet>
  void runStage(std::string_view stage, Work&& work, Meet&& meet) {
    if (!profiling_) {
      work();
      meet();
      return;
    }
    const auto start = Clock::now();
    work();
    const auto worked = Clock::now();
    meet();
    StageTime& time = timeOf(stage);
    time.work_seconds += std::chrono::duration<double>(worked - start).count();
    time.wait_seconds += std::chrono::duration<double>(Clock::now() - worked).count();
    ++time.meetings;
  }

  StageTime& timeOf(std::string_view stage) {
    std::vector<StageTime>& mine = profile_[thread_index];
    for (StageTime& time : mine)
      if (time.stage == stage) return time;
    return mine.emplace_back(StageTime{stage});
  }

  // body() on the calling thread and every worker, returning when all have finished it.
  template <class F>
  void runOnAll(F&& body, bool shared) {
    using Body = std::remove_reference_t<F>;
    next_.task = [](void* b) { (*static_cast<Body*>(b))(); };
    next_.body = const_cast<void*>(static_cast<const void*>(&body));
    next_.shared = shared;
    start();
    body();
    finished_.wait(0);
    next_.shared = false;
  }

  // Publishes next_ to the workers.
  void start() {
    next_.start.add(1);
    next_.start.wake();
  }

  void work(int thread, unsigned seen) {  // seen: the start of the last task before this one
    thread_index = thread;
    for (;;) {
      next_.start.awaitChange(seen);
      seen = next_.start.load();
      if (next_.stopping) return;
      next_.task(next_.body);
      finished_.wait(thread);
    }
  }

  void stopWorkers() {
    if (workers_.empty()) return;
    next_.stopping = true;
    start();
    for (std::thread& worker : workers_) worker.join();
    workers_.clear();
    threads_ = 1;
    next_.stopping = false;
  }

  // Which thread of the team this is: 0 for the caller, set once by each worker. The caller of
  // one team may be a worker of no other.
  static inline thread_local int thread_index = 0;

  int parts_ = 1;
  int threads_ = 1;
  bool profiling_ = false;
  std::vector<std::vector<StageTime>> profile_;  // per thread
  std::vector<std::thread> workers_;
  // The next task, on one cache line: a worker woken by `start` finds the rest with it. The caller
  // writes the rest before changing `start`, the workers read it after.
  struct alignas(64) Task {
    Signal start;
    void (*task)(void*) = nullptr;
    void* body = nullptr;
    bool shared = false;  // a task of together(): its stages meet at barrier_
    bool stopping = false;
  } next_;
  SpinBarrier barrier_;   // between the stages of a task
  SpinBarrier finished_;  // at the end of a task
};

}  // namespace snowsim
