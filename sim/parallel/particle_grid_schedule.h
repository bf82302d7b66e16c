// How the stages of a particle-grid step run over threads, apart from what they compute: the
// physics hands each stage a per-particle or per-node function, and this schedule decides which
// thread runs it on which particles and nodes (sim/parallel/row_binning.h), in an order that
// gives the same sums on any thread count. Each row of particles scatters into the partial grid
// of its colour; a node of a partial grid sums one row's particles in sorted order (or the sums a
// block of still particles kept, sim/parallel/still_blocks.h), and the grid sums the partial
// grids in colour order: the rows need no order among them, and the results are bit-identical on
// any thread count.
#pragma once

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstring>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "sim/core/grid.h"
#include "sim/core/stage_clock.h"
#include "sim/parallel/loop_runner.h"
#include "sim/parallel/row_binning.h"
#include "sim/parallel/still_blocks.h"
#include "sim/parallel/team.h"
#include "sim/parallel/work_shares.h"
#include "sim/parallel/zero_page_allocator.h"

namespace snowsim {

// The bytes of an element of `size` bytes that the sort permutes at once through a spare buffer of
// `spare` bytes a particle: the largest divisor of size that fits.
constexpr size_t sortPiece(size_t size, size_t spare) {
  size_t piece = std::min(size, spare);
  while (size % piece != 0) --piece;
  return piece;
}

// P: the particle container, with its scalar type Scalar (the precision of the partial grids),
// positions x, and forEachArray(f) over every per-particle array.
template <int D, class P>
class ParticleGridSchedule final : public LoopRunner {
 public:
  using Binning = RowBinning<D>;
  using Scalar = typename P::Scalar;
  using Position = Vec<D, Scalar>;
  using Fields = GridFields<D, Scalar>;
  static constexpr int drift_cells = Binning::drift_cells;
  static constexpr int colours = Binning::colours;
  // The particles the particle pass hands over at once: the 3D return mapping runs them in vector
  // lanes, and those that need an SVD in lanes of their own (sim/mpm/snow_material.h).
  static constexpr int pass_batch = 64;

  // Grid-sized, but only the nodes near the snow are ever touched, and only they take memory.
  template <class T>
  using ZeroPageVector = std::vector<T, ZeroPageAllocator<T>>;
  struct PartialGrid {
    ZeroPageVector<Scalar> mass;
    ZeroPageVector<Position> momentum, force;  // force stays empty when the physics has none
    // Which of the colours' grids this is: fields of the physics' own kept per colour (as the
    // crack opening's sides, sim/mpm/crack_opening.h) are written race-free where this one is.
    // The still blocks' scratch grids count on from `colours`: colours + the colour.
    int colour = 0;
  };

  // particles: how many the step moves; force_field: whether the scatter writes a force per node
  // besides mass and momentum; threads: how many threads a step may use, 0 for the OpenMP default
  // (OMP_NUM_THREADS, else every core).
  ParticleGridSchedule(const GridGeometry<D>& grid, int particles, bool force_field, int threads);

  void setThreads(int threads) { threads_ = threads > 0 ? threads : omp_get_max_threads(); }
  // The parts of the next step for the thread count now (step() calls it too); returns how many.
  int prepare();
  int parts() const { return team_.parts(); }
  // Another count of particles, or the same ones in another order (they moved between ranks):
  // binned anew at x, and stored in the new sorted order from the next step on.
  void resize(const std::vector<Position>& x);

  // One step: body() runs the step's stages (scatter, updateNodes, passOverParticles), on every
  // thread of the team at once if `shared` (then nothing in it may throw), else on this thread
  // with each stage meeting on its own. Before them the particles are binned anew if one left its
  // row's cells, and now and then stored in the sorted order (particles.forEachArray).
  template <class Body>
  void step(P& particles, bool shared, Body&& body);

  // The wall time of each stage of the steps so far, in the order first met: "bin", "sort",
  // "scatter", "grid update", the particle pass by its name, and those the physics timed().
  const std::vector<StageSeconds>& stageSeconds() const { return clock_.stages(); }
  // f() as a stage of a step of its own, e.g. a solve between the grid update and the particle
  // pass; the loops it runs (parallelFor, forActiveNodes) count in it.
  template <class F>
  void timed(std::string_view stage, F&& f) {
    const StageClock::Scope time = timeStage(stage);
    f();
  }

  // The stages. scatter: f(p, partial grid) for every particle, each row into the partial grid
  // of its colour. updateNodes: the grid's mass, momentum (into fields.velocity) and force are the
  // sums of the partial grids, which it empties; then f(k) for each of those nodes.
  // passOverParticles: f(batch, measure, shares) for every particle in sorted order, a batch of up
  // to pass_batch consecutive ones at a time (std::span<const int>), with the measure of its part
  // (measures[part], which starts from Measure() each pass); f sets shares[i], particle batch[i]'s
  // share of a total that orderedSum() adds up chunk by chunk, the same on any thread count. Each
  // part then also checks that its particles stayed within their rows' cells.
  template <class F>
  void scatter(F&& f, std::string_view stage = "scatter");
  // From now on, the scatter with stillness keeps what blocks of still particles scattered (3D
  // only: see below).
  void keepStillBlocks() {
    if constexpr (drift_cells == 0) {
      if (still_) return;
      still_ = std::make_unique<StillBlocks<D, PartialGrid, Scalar>>(
          grid_, binning_.blocks(), Binning::block_cells, force_field_);
      still_scratch_.resize(Binning::colours);
      for (int colour = 0; colour < Binning::colours; ++colour) {
        resizePartialGrid(still_scratch_[colour]);
        still_scratch_[colour].colour = colours + colour;
      }
    }
  }
  // What the still blocks kept no longer holds: the particles changed outside a step (a particle
  // pass run alone).
  void forgetStillBlocks() {
    if (still_) still_->forgetAll();
  }
  // The particles' scatters that still blocks added, kept, rather than made again, over this
  // schedule's steps.
  long keptScatters() const {
    long kept = 0;
    for (const long k : kept_scatters_) kept += k;
    return kept;
  }
  // The scatter of snow of which some rests (sim/parallel/still_blocks.h). stillness(p): 0 if
  // particle p moves; 1 if it is still, its scatter depending on the step only through a momentum
  // in proportion to `scale`, which unit(p, partial grid) scatters at scale 1; 2 if, moreover,
  // nothing of it changed since the last scatter. A block adds what its still particles
  // scattered at unit scale, kept from the first step they were the same ones, and its moving
  // ones scatter with f. Without keepStillBlocks(), and in 2D, whose rows are binned only now and
  // then, every particle scatters with f.
  // own: the fields of the physics' own that unit() writes where the scratch grid's colour says
  // (PartialGrid::colour), kept with the block's (NoOwnFields has none):
  // own.keep(block, colour, forStill, region) after the still particles scattered with unit(),
  // own.reuse(block, forStill) when their kept scatter is added instead, and
  // own.add(block, colour, scale) into the grids of `colour`. forStill(f) calls f(p) for the
  // block's still particles in sorted order, region(f) f(k) for the nodes they may reach.
  template <class F, class Stillness, class Unit, class Own>
  void scatter(F&& f, Stillness&& stillness, Unit&& unit, Own&& own, Scalar scale,
               std::string_view stage = "scatter");
  // The blocks of the scatter with stillness, as own's `block` counts them.
  int blockCount() const { return binning_.blocks().prod(); }
  template <class F>
  void updateNodes(Fields& fields, F&& f);
  // updateNodes with between() run on the calling thread once every node is summed and before f
  // runs on any (e.g. to add what other ranks' particles gave the nodes they share).
  template <class F, class Between>
  void updateNodes(Fields& fields, F&& f, Between&& between);
  // f(k) for the nodes updateNodes visits, those this step's scatter may have reached, without
  // summing the partial grids: for fields of the physics' own that a scatter of its own summed.
  template <class F>
  void forScatteredNodes(std::string_view stage, F&& f);
  // f(k) for every node of the box updateNodes visits, also those only other ranks' particles
  // reach (updateNodes with between).
  template <class F>
  void forBoxNodes(std::string_view stage, F&& f) {
    const StageClock::Scope time = timeStage(stage);
    overBoxNodes(stage, f);
  }
  // The nodes the particles reach now (sim/parallel/row_binning.h).
  const NodeBox<D>& activeNodes() const { return binning_.active(); }
  template <class Measure, class F>
  void passOverParticles(std::string_view stage, const std::vector<Position>& x,
                         std::vector<Measure>& measures, F&& f);
  Real orderedSum() const;
  // After each particle pass: the next cut of the work, and whether the next step must bin.
  void passDone();

  // The stages run alone, outside step(): a scatter binned anew, which drops any scatter no grid
  // stage summed, and the end of a grid stage.
  template <class F>
  void scatterAlone(const std::vector<Position>& x, F&& f);
  void gridStageDone();

  // f(k) for every node of the active box: independent items, in parallel for large scenes. The
  // schedule is also the LoopRunner of other independent loops (parallelFor). Both open a meeting
  // of their own: never inside a shared step's body.
  template <class F>
  void forActiveNodes(const GridGeometry<D>& grid, F&& f);
  void run(int count, void (*body)(void*, int, int), void* context) override;

  // What decides the next steps' order of summation, for a checkpoint: the binning, and when the
  // particles were last stored in sorted order. Plain data: the checkpoint's layer writes it.
  struct State {
    typename Binning::State binning;
    bool binned_since_stored = false;
    long stored_step = 0, steps = 0;
  };
  State state() const { return {binning_.state(), binned_since_stored_, stored_step_, steps_}; }
  // Restores a state into a schedule of the same grid and particle count; returns what does not
  // fit (empty when it fits, else the schedule is left as it was).
  std::string restore(State state) {
    std::string misfit = binning_.restore(std::move(state.binning));
    if (!misfit.empty()) return misfit;
    binned_since_stored_ = state.binned_since_stored;
    stored_step_ = state.stored_step;
    steps_ = state.steps;
    unsummed_scatter_ = false;
    forgetStillBlocks();
    return misfit;
  }

  // How many times the particles were binned into rows. 2D: again whenever one had moved more
  // than drift_cells beyond its row's cells; 3D: every step.
  long binnings() const { return binning_.binnings(); }
  // Where the steps' time goes, stage by stage and thread by thread (sim/parallel/team.h).
  void profileStages(bool on) { team_.profileStages(on); }
  int profiledThreads() const { return team_.threads(); }
  const std::vector<StageTime>& stageTimes(int thread) const { return team_.stageTimes(thread); }

 private:
  using Clock = std::chrono::steady_clock;
  static double secondsSince(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
  }
  // Threads pay off only from a few thousand particles: below, waking the threads and meeting
  // between the stages costs more than they share (docs/performance.md).
  static constexpr int parallel_min_particles = 2048;
  // Once a binning has changed the sorted order, the particles are stored in it, at most every
  // sorted_storage_interval steps, so that each part's particles lie together in memory and two
  // threads rarely write one cache line. Steps and binnings, never threads or time, decide it, so
  // the results stay the same on any thread count.
  static constexpr int sorted_storage_interval = 16;
  static constexpr int chunk = 64;  // particles of one term of orderedSum, in sorted order

  // Every per-particle array permuted into the sorted order of the last binning, one array after
  // the other and a scalar's bytes of each element at a time: gathered into the spare buffer,
  // then copied back.
  void storeInSortedOrder(P& particles);
  void resizeSpare() { spare_.resize(particles_); }
  void resizePartialGrid(PartialGrid& g) const {
    g.mass.resize(grid_.nodeCount());  // zero, untouched
    g.momentum.resize(grid_.nodeCount());
    if (force_field_) g.force.resize(grid_.nodeCount());
  }
  // f(k) over the nodes the scatter may have reached, each part its lines; measure: record the
  // parts' speeds, by which the lines are cut (the grid update's).
  template <class F>
  void overScatteredNodes(std::string_view stage, bool measure, F&& f);
  // f(k) over every node of the updated box, each part its lines.
  template <class F>
  void overBoxNodes(std::string_view stage, F&& f);
  // Zero over the updated nodes: only a scatter no grid stage followed needs it.
  void emptyPartialGrids();
  void sumPartialGrids(int k, Fields& fields);
  // The chunks of the sorted order that part `part`'s particle pass takes, [first, last).
  std::pair<int, int> passChunks(int part) const;
  int chunkStart(int c) const { return std::min(particles_, c * chunk); }
  // Times a stage of step() on the calling thread, where the stage ends once every thread is done.
  StageClock::Scope timeStage(std::string_view stage) {
    return {team_.onCallingThread() && stepping_ ? &clock_ : nullptr, stage};
  }

  GridGeometry<D> grid_;
  int particles_;
  bool parallel_;
  int threads_;
  std::vector<PartialGrid> partial_;  // one per colour
  Binning binning_;
  // Made by keepStillBlocks(): what still blocks scattered, and per colour a grid they scatter
  // into alone, empty between two blocks.
  std::unique_ptr<StillBlocks<D, PartialGrid, Scalar>> still_;
  std::vector<PartialGrid> still_scratch_;
  std::vector<long> kept_scatters_;  // per part
  bool force_field_;
  // The work is cut into parts, one per thread. In the scatter a part has consecutive rows; the
  // particle pass cuts the sorted order at the same shares, so the particles a thread writes in
  // one stage are mostly the ones it reads in the next, from its own cache. Each part's share
  // follows its measured speed (work_shares.h): the particles by the particle pass's speeds, the
  // grid stage's lines of nodes by its own.
  Team team_;
  WorkShares particle_shares_, line_shares_;
  std::vector<char> part_in_rows_;  // per part: its particles stayed within their rows' cells
  bool unsummed_scatter_ = false;   // a scatterAlone that no grid stage has summed
  bool binned_since_stored_ = true;
  bool stepping_ = false;  // inside step(): its stages are timed
  StageClock clock_;
  long steps_ = 0;
  long stored_step_ = -sorted_storage_interval;
  // The sort's target, one scalar a particle: a matrix is permuted a scalar at a time, since a
  // spare as wide as a matrix would cost more bytes a particle than most of the state's arrays.
  std::vector<Scalar> spare_;
  std::vector<Real> chunk_sums_;
};

template <int D, class P>
template <class Body>
void ParticleGridSchedule<D, P>::step(P& particles, bool shared, Body&& body) {
  prepare();
  // The rows hold until a particle has moved more than drift_cells beyond its row's cells; their
  // split between the parts follows the shares.
  const bool bin = binning_.mustBin();
  if (!bin) binning_.splitRows(particle_shares_);
  if (unsummed_scatter_) emptyPartialGrids();
  binned_since_stored_ = binned_since_stored_ || bin;
  const bool store = binned_since_stored_ && steps_ - stored_step_ >= sorted_storage_interval;
  if (store) {
    binned_since_stored_ = false;
    stored_step_ = steps_;
  }
  stepping_ = true;
  team_.together(shared, [&] {
    if (bin) timed("bin", [&] { binning_.bin(team_, particle_shares_, particles.x); });
    if (store) timed("sort", [&] { storeInSortedOrder(particles); });
    body();
  });
  stepping_ = false;
  gridStageDone();
  ++steps_;
}

template <int D, class P>
template <class F>
void ParticleGridSchedule<D, P>::scatter(F&& f, std::string_view stage) {
  const StageClock::Scope time = timeStage(stage);
  team_.forEachPart(stage, [&](int part) {
    const auto [first, last] = binning_.partRows(part);
    for (int row = first; row < last; ++row) {
      PartialGrid& g = partial_[binning_.rowColour(row)];
      for (int o = binning_.rowStart(row); o < binning_.rowStart(row + 1); ++o)
        f(binning_.sorted(o), g);
    }
  });
}

template <int D, class P>
template <class F, class Stillness, class Unit, class Own>
void ParticleGridSchedule<D, P>::scatter(F&& f, Stillness&& stillness, Unit&& unit, Own&& own,
                                         Scalar scale, std::string_view stage) {
  if (!still_) return scatter(f, stage);
  const StageClock::Scope time = timeStage(stage);
  team_.forEachPart(stage, [&](int part) {
    const auto [first, last] = binning_.partRows(part);
    for (int row = first; row < last; ++row) {
      PartialGrid& g = partial_[binning_.rowColour(row)];
      binning_.forBlocksOfRow(row, [&](int block, int begin, int end) {
        if (begin == end) return;
        // The block's still particles: whether one of them fell asleep since the last scatter.
        int still = 0;
        bool fell_asleep = false;
        for (int o = begin; o < end; ++o) {
          const int s = stillness(binning_.sorted(o));
          still += s > 0;
          fell_asleep |= s == 1;
        }
        if (still == 0 || !still_->mayKeep(block, still)) {
          still_->forget(block);
          for (int o = begin; o < end; ++o) f(binning_.sorted(o), g);
          return;
        }
        const auto forStill = [&](auto&& each) {
          for (int o = begin; o < end; ++o)
            if (const int p = binning_.sorted(o); stillness(p) > 0) each(p);
        };
        const auto forMoving = [&](auto&& each) {
          for (int o = begin; o < end; ++o)
            if (const int p = binning_.sorted(o); stillness(p) == 0) each(p);
        };
        const auto region = [&](auto&& node) {
          still_->forRegion(block, [&](int k, int) { node(k); });
        };
        // The same still particles as when it kept their scatter if there are as many and none
        // fell asleep since: one that wakes leaves them, and stays out until it falls asleep
        // again. (A particle that woke and fell asleep again within one pass has stillness 1:
        // with the sleep steps at 1 it may have moved.)
        if (fell_asleep || !still_->holds(block, still)) {
          // Rows of one colour reach no common node: they share its scratch grid.
          PartialGrid& scratch = still_scratch_[binning_.rowColour(row)];
          forStill([&](int p) { unit(p, scratch); });
          still_->keep(block, still, scratch);
          own.keep(block, scratch.colour, forStill, region);
        } else {
          kept_scatters_[part] += still;
          own.reuse(block, forStill);
        }
        still_->add(block, g, scale);
        own.add(block, g.colour, scale);
        forMoving([&](int p) { f(p, g); });
      });
    }
  });
}

template <int D, class P>
template <class F>
void ParticleGridSchedule<D, P>::scatterAlone(const std::vector<Position>& x, F&& f) {
  binning_.bin(team_, particle_shares_, x);
  if (unsummed_scatter_) emptyPartialGrids();
  scatter(f);
  unsummed_scatter_ = true;
}

template <int D, class P>
template <class F>
void ParticleGridSchedule<D, P>::updateNodes(Fields& fields, F&& f) {
  overScatteredNodes("grid update", true, [&](int k) {
    sumPartialGrids(k, fields);
    f(k);
  });
}

template <int D, class P>
template <class F>
void ParticleGridSchedule<D, P>::forScatteredNodes(std::string_view stage, F&& f) {
  overScatteredNodes(stage, false, f);
}

template <int D, class P>
template <class F>
void ParticleGridSchedule<D, P>::overScatteredNodes(std::string_view stage, bool measure, F&& f) {
  const NodeBox<D>& box = binning_.updated();
  // A part takes a run of consecutive lines of nodes along x, about those its thread scattered
  // to, still in its cache. The lines are cut by the grid update's own measured speeds, not at
  // the rows of the scatter: a line whose partial grids the other thread wrote costs more.
  const int width = box.hi[0] - box.lo[0];
  const int lines = width > 0 ? box.count() / width : 0;
  const StageClock::Scope time = timeStage(stage);
  team_.forEachPart(stage, [&](int part) {
    const auto start = parallel_ && measure ? Clock::now() : Clock::time_point();
    const int first = line_shares_.start(part, lines), last = line_shares_.start(part + 1, lines);
    for (int line = first; line < last; ++line)
      binning_.forUpdatedRuns(line, [&](int k, int count) {
        for (int i = 0; i < count; ++i) f(k + i);  // x is the grid's contiguous axis
      });
    if (parallel_ && measure) line_shares_.record(part, last - first, secondsSince(start));
  });
}

template <int D, class P>
template <class F, class Between>
void ParticleGridSchedule<D, P>::updateNodes(Fields& fields, F&& f, Between&& between) {
  // Every node of the box, not only the runs near this rank's particles: between() may give mass
  // to nodes that only the neighbour ranks' particles reach.
  const StageClock::Scope time = timeStage("grid update");
  overBoxNodes("grid sum", [&](int k) { sumPartialGrids(k, fields); });
  team_.serially("grid exchange", between);
  overBoxNodes("grid update", f);
}

template <int D, class P>
template <class F>
void ParticleGridSchedule<D, P>::overBoxNodes(std::string_view stage, F&& f) {
  const NodeBox<D>& box = binning_.updated();
  const int width = box.hi[0] - box.lo[0];
  const int lines = width > 0 ? box.count() / width : 0;
  team_.forEachPart(stage, [&](int part) {
    const int first = line_shares_.start(part, lines), last = line_shares_.start(part + 1, lines);
    for (int line = first; line < last; ++line) {
      const int k = box.flatIndex(grid_, line * width);
      for (int i = 0; i < width; ++i) f(k + i);
    }
  });
}

template <int D, class P>
template <class Measure, class F>
void ParticleGridSchedule<D, P>::passOverParticles(std::string_view stage,
                                                   const std::vector<Position>& x,
                                                   std::vector<Measure>& measures, F&& f) {
  // The particles in the scatter's order, cut at the parts' shares: a thread moves the particles
  // it scattered and stored, still in its cache.
  const StageClock::Scope time = timeStage(stage);
  team_.forEachPart(stage, [&](int part) {
    const auto start = parallel_ ? Clock::now() : Clock::time_point();
    Measure m{};
    bool in_rows = true;
    const auto [first, last] = passChunks(part);
    typename Binning::RowCells row;
    if constexpr (drift_cells > 0) row = binning_.rowCellsAt(chunkStart(first));
    for (int c = first; c < last; ++c) {
      Real sum = 0;
      for (int o = chunkStart(c); o < chunkStart(c + 1); o += pass_batch) {
        const int count = std::min(pass_batch, chunkStart(c + 1) - o);
        int batch[pass_batch];
        Real shares[pass_batch];
        for (int i = 0; i < count; ++i) batch[i] = binning_.sorted(o + i);
        f(std::span<const int>(batch, count), m, shares);
        for (int i = 0; i < count; ++i) {
          sum += shares[i];
          if constexpr (drift_cells > 0)
            in_rows &= binning_.withinRowCells(o + i, x[batch[i]], row);
        }
      }
      chunk_sums_[c] = sum;
    }
    if (parallel_)
      particle_shares_.record(part, chunkStart(last) - chunkStart(first), secondsSince(start));
    measures[part] = m;
    part_in_rows_[part] = in_rows;
  });
}

template <int D, class P>
template <class F>
void ParticleGridSchedule<D, P>::forActiveNodes(const GridGeometry<D>& grid, F&& f) {
  const NodeBox<D>& active = binning_.active();
  parallelFor(this, active.count(), [&](int n) { f(active.flatIndex(grid, n)); });
}

template <int D, class P>
void ParticleGridSchedule<D, P>::run(int count, void (*body)(void*, int, int), void* context) {
  prepare();
  team_.forEachPart("parallel loop", [&](int part) {
    const auto boundary = [&](int t) {
      return static_cast<int>(static_cast<long>(count) * t / parts());
    };
    body(context, boundary(part), boundary(part + 1));
  });
}

template <int D, class P>
void ParticleGridSchedule<D, P>::storeInSortedOrder(P& particles) {
  // Each part gathers the places its particle pass will read, so a part's particles end up in its
  // own thread's cache; it copies them back after every part has gathered from the array. Arrays
  // left empty (unused) are skipped.
  const auto places = [&](int part, auto&& f) {  // the places of the part's particle pass
    const auto [first, last] = passChunks(part);
    for (int o = chunkStart(first); o < chunkStart(last); ++o) f(o);
  };
  particles.forEachArray([&]<class E>(std::vector<E>& array) {
    constexpr size_t piece = sortPiece(sizeof(E), sizeof(Scalar));
    if (array.empty()) return;
    // The elements as bytes: scalars, ints and fixed-size Eigen matrices, plain storage all.
    std::byte* spare = reinterpret_cast<std::byte*>(spare_.data());
    std::byte* elements = reinterpret_cast<std::byte*>(array.data());
    for (size_t offset = 0; offset < sizeof(E); offset += piece) {
      team_.forEachPart("sort: gather", [&](int part) {
        places(part, [&](int o) {
          std::memcpy(spare + size_t(o) * piece,
                      elements + size_t(binning_.sorted(o)) * sizeof(E) + offset, piece);
        });
      });
      team_.forEachPart("sort: copy back", [&](int part) {
        places(part, [&](int o) {
          std::memcpy(elements + size_t(o) * sizeof(E) + offset, spare + size_t(o) * piece, piece);
        });
      });
    }
  });
  // A part reads the order at its own places only: it may reset them once every array is stored.
  team_.forEachPart("sort: reset",
                    [&](int part) { places(part, [&](int o) { binning_.storedInOrder(o); }); });
}

template <int D, class P>
ParticleGridSchedule<D, P>::ParticleGridSchedule(const GridGeometry<D>& grid, int particles,
                                                 bool force_field, int threads)
    : grid_(grid),
      particles_(particles),
      parallel_(particles >= parallel_min_particles),
      threads_(threads > 0 ? threads : omp_get_max_threads()),
      binning_(grid, particles),
      force_field_(force_field) {
  resizeSpare();
  chunk_sums_.resize((particles + chunk - 1) / chunk);
  partial_.resize(Binning::colours);
  for (int colour = 0; colour < Binning::colours; ++colour) {
    resizePartialGrid(partial_[colour]);
    partial_[colour].colour = colour;
  }
  prepare();
}

template <int D, class P>
void ParticleGridSchedule<D, P>::resize(const std::vector<Position>& x) {
  const int particles = static_cast<int>(x.size());
  particles_ = particles;
  binning_.resize(particles);
  binning_.bin(team_, particle_shares_, x);
  forgetStillBlocks();
  resizeSpare();
  chunk_sums_.assign((particles + chunk - 1) / chunk, 0);
  binned_since_stored_ = true;
}

template <int D, class P>
inline Real ParticleGridSchedule<D, P>::orderedSum() const {
  Real sum = 0;
  for (const Real c : chunk_sums_) sum += c;
  return sum;
}

template <int D, class P>
inline void ParticleGridSchedule<D, P>::passDone() {
  if (parallel_) {
    particle_shares_.update();
    line_shares_.update();
  }
  for (int part = 0; part < parts(); ++part)
    if (!part_in_rows_[part]) binning_.particlesLeftTheirRows();
}

template <int D, class P>
inline int ParticleGridSchedule<D, P>::prepare() {
  team_.configure(parallel_ ? threads_ : 1, parallel_);
  const int parts = this->parts();
  if (static_cast<int>(kept_scatters_.size()) < parts) kept_scatters_.resize(parts, 0);
  if (particle_shares_.parts() == parts) return parts;
  // The first step, or another thread count.
  binning_.setParts(parts);
  part_in_rows_.assign(parts, true);
  particle_shares_.reset(parts);
  line_shares_.reset(parts);
  return parts;
}

template <int D, class P>
inline void ParticleGridSchedule<D, P>::emptyPartialGrids() {
  unsummed_scatter_ = false;
  const NodeBox<D>& box = binning_.updated();
  const int width = box.hi[0] - box.lo[0];
  if (width <= 0) return;
  for (int line = 0, lines = box.count() / width; line < lines; ++line) {
    const int first = box.flatIndex(grid_, line * width);
    for (PartialGrid& g : partial_) {
      std::fill_n(g.mass.begin() + first, width, Scalar(0));
      std::fill_n(g.momentum.begin() + first, width, Position::Zero());
      if (!g.force.empty()) std::fill_n(g.force.begin() + first, width, Position::Zero());
    }
  }
}

template <int D, class P>
inline void ParticleGridSchedule<D, P>::sumPartialGrids(int k, Fields& fields) {
  const bool forces = !partial_[0].force.empty();
  Scalar mass = 0;
  Position momentum = Position::Zero(), force = Position::Zero();
  for (PartialGrid& g : partial_) {  // in colour order: the same sum on any thread count
    mass += g.mass[k];
    momentum += g.momentum[k];
    if (forces) force += g.force[k];
    // Emptied for the next scatter, only where a row wrote (a cubic weight may round to 0 where
    // its gradient does not), so the lines nobody scattered to are only read and do not pass
    // between the threads' caches every step.
    const bool written = g.mass[k] != 0 || (g.momentum[k].array() != 0).any() ||
                         (forces && (g.force[k].array() != 0).any());
    if (!written) continue;
    g.mass[k] = 0;
    g.momentum[k].setZero();
    if (forces) g.force[k].setZero();
  }
  fields.mass[k] = mass;
  fields.velocity[k] = momentum;
  if (forces) fields.force[k] = force;
}

template <int D, class P>
inline void ParticleGridSchedule<D, P>::gridStageDone() {
  unsummed_scatter_ = false;
  binning_.gridStageDone();
}

template <int D, class P>
inline std::pair<int, int> ParticleGridSchedule<D, P>::passChunks(int part) const {
  const int chunks = static_cast<int>(chunk_sums_.size());
  return {particle_shares_.start(part, chunks), particle_shares_.start(part + 1, chunks)};
}

}  // namespace snowsim
