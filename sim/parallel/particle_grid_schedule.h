// How the stages of a particle-grid step run over threads, apart from what they compute: the
// physics hands each stage a per-particle or per-node function, and this schedule decides which
// thread runs it on which particles and nodes, in an order that gives the same sums on any
// thread count.
//
// Particles are binned into blocks of block_cells^D cells and sorted by block, in stored order
// within a block. A row of blocks along x is the unit of scatter work: each row scatters into the
// partial grid of its colour, its y (and z) block index modulo colour_stride. A particle of cell c
// reaches nodes c-1 .. c+2, so rows of one colour write no common node as long as their particles
// stay within drift_cells of their rows' cells. A node of a partial grid sums one row's particles
// in sorted order, and the grid sums the partial grids in colour order: the rows need no order
// among them, and the results are bit-identical on any thread count. The same idea as the
// coloured P2G of Gao et al. 2018 ("GPU Optimization of Material Point Methods").
#pragma once

#include <omp.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <limits>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "sim/core/grid.h"
#include "sim/parallel/team.h"
#include "sim/parallel/work_shares.h"
#include "sim/parallel/zero_page_allocator.h"

namespace snowsim {

// The index of type T among the tuple's element types.
template <class T, class... Ts>
constexpr int tupleIndex(std::tuple<Ts...>*) {
  int index = 0, found = -1;
  ((std::is_same_v<T, Ts> ? found = index : 0, ++index), ...);
  return found;
}

// P: the particle container, with positions x, forEachArray(f) over every per-particle array,
// and SpareArrays, a tuple of one std::vector of each element type those arrays have.
template <int D, class P>
class ParticleGridSchedule {
 public:
  // 2D: rows 3 cells tall, three colours. 3D: blocks of 4^3 cells, four colours (two along y, two
  // along z); it has rows enough, and its larger blocks sort faster.
  static constexpr int block_cells = D == 2 ? 3 : 4;
  static constexpr int colour_stride = D == 2 ? 3 : 2;  // per axis
  static constexpr int colours = D == 2 ? colour_stride : colour_stride * colour_stride;
  // The nodes reached by rows colour_stride blocks apart leave block_cells * (colour_stride - 1)
  // - 3 nodes between them; half of that, rounded down, is how many cells a particle may move
  // beyond its row's on either side and still write only nodes no other row of its colour can.
  // 2D: one cell, so the particles are binned anew only when one has moved farther. 3D: none, so
  // they are binned every step (docs/performance.md weighs the alternatives).
  static constexpr int drift_cells = (block_cells * (colour_stride - 1) - 3) / 2;

  // Grid-sized, but only the nodes near the snow are ever touched, and only they take memory.
  template <class T>
  using ZeroPageVector = std::vector<T, ZeroPageAllocator<T>>;
  struct PartialGrid {
    ZeroPageVector<Real> mass;
    ZeroPageVector<Vec<D>> momentum, force;  // force stays empty when the physics has none
  };

  // particles: how many the step moves; force_field: whether the scatter writes a force per node
  // besides mass and momentum; threads: how many threads a step may use, 0 for the OpenMP default
  // (OMP_NUM_THREADS, else every core).
  ParticleGridSchedule(const GridGeometry<D>& grid, int particles, bool force_field, int threads);

  void setThreads(int threads) { threads_ = threads > 0 ? threads : omp_get_max_threads(); }
  int threads() const { return threads_; }
  // The parts of the next step for the thread count now (step() calls it too); returns how many.
  int prepare();
  int parts() const { return team_.parts(); }

  // One step: body() runs the step's stages (scatter, updateNodes, passOverParticles), on every
  // thread of the team at once if `shared` (then nothing in it may throw), else on this thread
  // with each stage meeting on its own. Before them the particles are binned anew if one left its
  // row's cells, and now and then stored in the sorted order (particles.forEachArray).
  template <class Body>
  void step(P& particles, bool shared, Body&& body);

  // The stages. scatter: f(p, partial grid) for every particle, each row into the partial grid
  // of its colour. updateNodes: the grid's mass, momentum (into fields.velocity) and force are the
  // sums of the partial grids, which it empties; then f(k) for each of those nodes.
  // passOverParticles: f(p, measure) for every particle in sorted order, with the measure of its
  // part (measures[part], which starts from Measure() each pass), returning the particle's share
  // of a total that orderedSum() adds up chunk by chunk, the same on any thread count; each part
  // then also checks that its particles stayed within their rows' cells.
  template <class F>
  void scatter(F&& f);
  template <class F>
  void updateNodes(GridFields<D>& fields, F&& f);
  template <class Measure, class F>
  void passOverParticles(std::string_view stage, const std::vector<Vec<D>>& x,
                         std::vector<Measure>& measures, F&& f);
  Real orderedSum() const;
  // After each particle pass: the next cut of the work, and whether the next step must bin.
  void passDone();

  // The stages run alone, outside step(): a scatter binned anew, which drops any scatter no grid
  // stage summed, and the end of a grid stage.
  template <class F>
  void scatterAlone(const std::vector<Vec<D>>& x, F&& f);
  void gridStageDone();

  // f(k) for every node of the active box, f(p) for p < count: independent items, in parallel for
  // large scenes.
  template <class F>
  void forActiveNodes(const GridGeometry<D>& grid, F&& f) const;
  template <class F>
  void parallelFor(int count, F&& f) const;

  // How many times the particles were binned into rows. 2D: again whenever one had moved more
  // than drift_cells beyond its row's cells; 3D: every step.
  long binnings() const { return binnings_; }
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

  void binParticles(const std::vector<Vec<D>>& x);
  void findActiveNodes();  // active_ and updated_ from the blocks the particles are in
  // Every per-particle array permuted into the sorted order of the last binning, each gathered
  // into the spare array of its type, which then swap: the arrays' data pointers change.
  void storeInSortedOrder(P& particles);
  void splitRows();  // part_rows_ from the sorted particles
  int rowColour(int row) const;
  int rowFirstParticle(int row) const { return row_start_[row]; }
  // f(first, length, block): the blocks of row `row` within the box [lo, hi] of block coordinates,
  // a run of `length` along x from flat block index `first`, at coordinates `block`; nothing if
  // the row misses the box.
  template <class F>
  void forBlocksOfRowInBox(int row, const IVec<D>& lo, const IVec<D>& hi, F&& f) const;
  void emptyPartialGrids();  // zero over updated_: only a scatter no grid stage followed needs it
  void sumPartialGrids(int k, GridFields<D>& fields);
  // Where the particles of the row at sorted place o may be, in cells (x / h), for the nodes they
  // reach to stay the row's: [lo, hi) on each axis, unbounded at the domain's edges; and where the
  // row ends in the sorted order.
  struct RowCells {
    int end = 0;
    Vec<D> lo = Vec<D>::Zero(), hi = Vec<D>::Zero();
    Real inv_h = 0;
  };
  RowCells rowCellsAt(int o) const;
  // Whether the particle at sorted place o, now at x, is within its row's cells; `row` follows a
  // pass in sorted order from row to row.
  bool withinRowCells(int o, const Vec<D>& x, RowCells& row) const;
  // The chunks of the sorted order that part `part`'s particle pass takes, [first, last).
  std::pair<int, int> passChunks(int part) const;
  int chunkStart(int c) const { return std::min(particles_, c * chunk); }

  GridGeometry<D> grid_;
  int particles_;
  bool parallel_;
  int threads_;
  std::vector<PartialGrid> partial_;  // one per colour
  IVec<D> blocks_;
  int block_count_ = 0;
  std::vector<int> row_start_;  // particles of row r: order_[row_start_[r] .. [r + 1])
  std::vector<int> order_;
  std::vector<int> particle_block_;  // per stored particle, binParticles' scratch
  // The work is cut into parts, one per thread. In the scatter part t has the rows
  // part_rows_[t] .. part_rows_[t + 1]; the particle pass cuts the sorted order at the same
  // shares, so the particles a thread writes in one stage are mostly the ones it reads in the
  // next, from its own cache. Each part's share follows its measured speed (work_shares.h): the
  // particles by the particle pass's speeds, the grid stage's lines of nodes by its own.
  Team team_;
  std::vector<int> part_rows_;
  WorkShares particle_shares_, line_shares_;
  std::vector<char> part_in_rows_;  // per part: its particles stayed within their rows' cells
  // Counting-sort state per part r, each sorting one contiguous range of particle indices:
  // range_count_[r * block_count_ + b] counts its particles of block b, range_cursor_ places them;
  // range_first/last_block_[r] bound the blocks its particles are in.
  std::vector<int> range_count_, range_cursor_;
  std::vector<IVec<D>> range_first_block_, range_last_block_;
  IVec<D> binned_first_block_, binned_last_block_;  // the last binning's box of blocks
  bool must_bin_ = true;
  bool unsummed_scatter_ = false;  // a scatterAlone that no grid stage has summed
  long binnings_ = 0;
  bool binned_since_stored_ = true;
  long steps_ = 0;
  long stored_step_ = -sorted_storage_interval;
  typename P::SpareArrays spare_;  // one array of each element type: the sort's target
  std::vector<Real> chunk_sums_;
  // The nodes within the kernel's reach of the particles' blocks, widened by drift_cells: the
  // grid stages touch only these, so a small snowball in a large domain costs what the snowball
  // does. Nodes outside stay zero: the first grid stage after a binning sums the partial grids
  // over updated_, this binning's active_ and the previous one's, which zeroes the nodes active_
  // no longer covers; the grid stages after it, over active_ alone.
  NodeBox<D> active_;
  NodeBox<D> updated_;
};

template <int D, class P>
template <class Body>
void ParticleGridSchedule<D, P>::step(P& particles, bool shared, Body&& body) {
  prepare();
  // The rows hold until a particle has moved more than drift_cells beyond its row's cells; their
  // split between the parts follows the shares.
  const bool bin = must_bin_ || drift_cells == 0;
  if (!bin) splitRows();
  if (unsummed_scatter_) emptyPartialGrids();
  binned_since_stored_ = binned_since_stored_ || bin;
  const bool store = binned_since_stored_ && steps_ - stored_step_ >= sorted_storage_interval;
  if (store) {
    binned_since_stored_ = false;
    stored_step_ = steps_;
  }
  team_.together(shared, [&] {
    if (bin) binParticles(particles.x);
    if (store) storeInSortedOrder(particles);
    body();
  });
  gridStageDone();
  ++steps_;
}

template <int D, class P>
template <class F>
void ParticleGridSchedule<D, P>::scatter(F&& f) {
  team_.forEachPart("rasterise", [&](int part) {
    for (int row = part_rows_[part]; row < part_rows_[part + 1]; ++row) {
      PartialGrid& g = partial_[rowColour(row)];
      for (int o = rowFirstParticle(row); o < rowFirstParticle(row + 1); ++o) f(order_[o], g);
    }
  });
}

template <int D, class P>
template <class F>
void ParticleGridSchedule<D, P>::scatterAlone(const std::vector<Vec<D>>& x, F&& f) {
  binParticles(x);
  if (unsummed_scatter_) emptyPartialGrids();
  scatter(f);
  unsummed_scatter_ = true;
}

template <int D, class P>
template <class F>
void ParticleGridSchedule<D, P>::updateNodes(GridFields<D>& fields, F&& f) {
  const NodeBox<D>& box = updated_;
  // A part takes a run of consecutive lines of nodes along x, about those its thread scattered
  // to, still in its cache. The lines are cut by this stage's own measured speeds, not at the
  // rows of the scatter: a line whose partial grids the other thread wrote costs more.
  const int width = box.hi[0] - box.lo[0];
  const int lines = width > 0 ? box.count() / width : 0;
  team_.forEachPart("grid update", [&](int part) {
    const auto start = parallel_ ? Clock::now() : Clock::time_point();
    const int first = line_shares_.start(part, lines), last = line_shares_.start(part + 1, lines);
    for (int line = first; line < last; ++line) {
      const int k = box.flatIndex(grid_, line * width);
      for (int i = 0; i < width; ++i) {  // x is the grid's contiguous axis
        sumPartialGrids(k + i, fields);
        f(k + i);
      }
    }
    if (parallel_) line_shares_.record(part, last - first, secondsSince(start));
  });
}

template <int D, class P>
template <class Measure, class F>
void ParticleGridSchedule<D, P>::passOverParticles(std::string_view stage,
                                                   const std::vector<Vec<D>>& x,
                                                   std::vector<Measure>& measures, F&& f) {
  // The particles in the scatter's order, cut at the parts' shares: a thread moves the particles
  // it scattered and stored, still in its cache.
  team_.forEachPart(stage, [&](int part) {
    const auto start = parallel_ ? Clock::now() : Clock::time_point();
    Measure m{};
    bool in_rows = true;
    const auto [first, last] = passChunks(part);
    RowCells row;
    if constexpr (drift_cells > 0) row = rowCellsAt(chunkStart(first));
    for (int c = first; c < last; ++c) {
      Real sum = 0;
      for (int o = chunkStart(c); o < chunkStart(c + 1); ++o) {
        const int p = order_[o];
        sum += f(p, m);
        if constexpr (drift_cells > 0) in_rows &= withinRowCells(o, x[p], row);
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
void ParticleGridSchedule<D, P>::forActiveNodes(const GridGeometry<D>& grid, F&& f) const {
  const int count = active_.count();
#pragma omp parallel for schedule(static) if (parallel_) num_threads(threads_)
  for (int n = 0; n < count; ++n) f(active_.flatIndex(grid, n));
}

template <int D, class P>
template <class F>
void ParticleGridSchedule<D, P>::parallelFor(int count, F&& f) const {
#pragma omp parallel for schedule(static) if (parallel_) num_threads(threads_)
  for (int i = 0; i < count; ++i) f(i);
}

template <int D, class P>
void ParticleGridSchedule<D, P>::storeInSortedOrder(P& particles) {
  // Each part gathers the places its particle pass will read, so a part's particles end up in its
  // own thread's cache. Round r takes the r-th array of each element type at once, so the threads
  // meet twice a round rather than twice an array. Arrays left empty (unused) are skipped.
  using Spare = typename P::SpareArrays;
  constexpr int types = std::tuple_size_v<Spare>;
  const auto spareOf = [&]<class T>(std::vector<T>&) -> std::vector<T>& {
    return std::get<std::vector<T>>(spare_);
  };
  const auto typeOf = [&]<class T>(const std::vector<T>&) {
    return tupleIndex<std::vector<T>>(static_cast<Spare*>(nullptr));
  };
  const auto forArraysOfRound = [&](int round, auto&& f) {
    std::array<int, types> met{};  // per type, the arrays met so far
    particles.forEachArray([&](auto& array) {
      if (!array.empty() && met[typeOf(array)]++ == round) f(array);
    });
  };
  const auto places = [&](int part, auto&& f) {  // the places of the part's particle pass
    const auto [first, last] = passChunks(part);
    for (int o = chunkStart(first); o < chunkStart(last); ++o) f(o);
  };
  std::array<int, types> arrays{};
  particles.forEachArray([&](auto& array) { arrays[typeOf(array)] += !array.empty(); });
  const int rounds = *std::max_element(arrays.begin(), arrays.end());
  for (int round = 0; round < rounds; ++round) {
    team_.forEachPart("sort: gather", [&](int part) {
      forArraysOfRound(round, [&](auto& array) {
        auto& spare = spareOf(array);
        places(part, [&](int o) { spare[o] = array[order_[o]]; });
      });
      // A part reads order_ at its own places only: it may reset them once it has gathered.
      if (round == rounds - 1) places(part, [&](int o) { order_[o] = o; });
    });
    team_.serially("sort: swap", [&] {
      forArraysOfRound(round, [&](auto& array) { array.swap(spareOf(array)); });
    });
  }
}

template <int D, class P>
ParticleGridSchedule<D, P>::ParticleGridSchedule(const GridGeometry<D>& grid, int particles,
                                                 bool force_field, int threads)
    : grid_(grid),
      particles_(particles),
      parallel_(particles >= parallel_min_particles),
      threads_(threads > 0 ? threads : omp_get_max_threads()) {
  order_.resize(particles);
  particle_block_.resize(particles);
  std::apply([&](auto&... spare) { (spare.resize(particles), ...); }, spare_);
  block_count_ = 1;
  for (int a = 0; a < D; ++a) {
    blocks_[a] = (grid.cells[a] + block_cells - 1) / block_cells;
    block_count_ *= blocks_[a];
  }
  row_start_.assign(block_count_ / blocks_[0] + 1, 0);
  chunk_sums_.resize((particles + chunk - 1) / chunk);
  partial_.resize(colours);
  for (PartialGrid& g : partial_) {
    g.mass.resize(grid.nodeCount());  // zero, untouched
    g.momentum.resize(grid.nodeCount());
    if (force_field) g.force.resize(grid.nodeCount());
  }
  prepare();
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
  for (int part = 0; part < parts(); ++part) must_bin_ = must_bin_ || !part_in_rows_[part];
}

template <int D, class P>
inline int ParticleGridSchedule<D, P>::prepare() {
  team_.configure(parallel_ ? threads_ : 1, parallel_);
  const int parts = this->parts();
  if (particle_shares_.parts() == parts) return parts;
  // The first step, or another thread count.
  part_rows_.resize(parts + 1);
  part_in_rows_.assign(parts, true);
  particle_shares_.reset(parts);
  line_shares_.reset(parts);
  range_count_.assign(static_cast<size_t>(parts) * block_count_, 0);
  range_cursor_.resize(static_cast<size_t>(parts) * block_count_);
  range_first_block_.assign(parts, blocks_);  // empty boxes: nothing counted yet
  range_last_block_.assign(parts, IVec<D>::Constant(-1));
  return parts;
}

template <int D, class P>
inline void ParticleGridSchedule<D, P>::binParticles(const std::vector<Vec<D>>& x) {
  const int n = particles_;
  const int rows = static_cast<int>(row_start_.size()) - 1;
  const Real inv_h = 1 / grid_.h;
  const auto countsOf = [&](int range) {
    return &range_count_[static_cast<size_t>(range) * block_count_];
  };
  // Counting sort, each part on one contiguous range of particle indices: count per block, a
  // prefix sum over (block, range) gives each range its place in each block, each range places
  // its particles. A stable sort: its result does not depend on how the particles were split.
  // A range's counts are zero outside the box of blocks its particles were in, which is all
  // that is cleared and summed: the snow's blocks, not the domain's.
  team_.forEachPart("bin: count", [&](int r) {
    int* count = countsOf(r);
    for (int row = 0; row < rows; ++row)
      forBlocksOfRowInBox(
          row, range_first_block_[r], range_last_block_[r],
          [&](int first, int length, const IVec<D>&) { std::fill_n(count + first, length, 0); });
    IVec<D> first = blocks_, last = IVec<D>::Constant(-1);
    for (int p = particle_shares_.start(r, n), end = particle_shares_.start(r + 1, n); p < end;
         ++p) {
      int b = 0, s = 1;
      for (int a = 0; a < D; ++a) {
        // The cell as the kernels compute it (sim/core/bspline.h), so that a particle never reaches
        // beyond its row's nodes (withinRowCells).
        const int cell = static_cast<int>(std::floor(x[p][a] * inv_h));
        const int k = std::min(std::max(cell, 0) / block_cells, blocks_[a] - 1);
        first[a] = std::min(first[a], k);
        last[a] = std::max(last[a], k);
        b += k * s;
        s *= blocks_[a];
      }
      particle_block_[p] = b;
      ++count[b];
    }
    range_first_block_[r] = first;
    range_last_block_[r] = last;
  });
  // Each part sums the prefix itself rather than waiting for one thread to sum it: a barrier
  // and, on two threads, the cursors crossing between caches twice.
  team_.forEachPart("bin: place", [&](int r) {
    const int ranges = parts();
    IVec<D> lo = blocks_, hi = IVec<D>::Constant(-1);  // the union of the ranges' boxes
    for (int range = 0; range < ranges; ++range) {
      lo = lo.cwiseMin(range_first_block_[range]);
      hi = hi.cwiseMax(range_last_block_[range]);
    }
    int* cursor = &range_cursor_[static_cast<size_t>(r) * block_count_];
    int placed = 0;
    for (int row = 0; row < rows; ++row) {
      if (r == 0) row_start_[row] = placed;
      forBlocksOfRowInBox(row, lo, hi, [&](int first, int length, IVec<D> block) {
        for (int b = first; b < first + length; ++b, ++block[0])
          for (int range = 0; range < ranges; ++range) {
            if ((block.array() < range_first_block_[range].array()).any() ||
                (block.array() > range_last_block_[range].array()).any())
              continue;  // outside its box: none of its particles
            if (range == r) cursor[b] = placed;
            placed += countsOf(range)[b];
          }
      });
    }
    for (int p = particle_shares_.start(r, n), end = particle_shares_.start(r + 1, n); p < end; ++p)
      order_[cursor[particle_block_[p]]++] = p;
    if (r == 0) {  // read after this stage only
      row_start_[rows] = placed;
      splitRows();
      findActiveNodes();
      must_bin_ = false;
      ++binnings_;
    }
  });
}

template <int D, class P>
template <class F>
void ParticleGridSchedule<D, P>::forBlocksOfRowInBox(int row, const IVec<D>& lo, const IVec<D>& hi,
                                                     F&& f) const {
  if (lo[0] > hi[0]) return;
  IVec<D> block;
  block[0] = lo[0];
  for (int a = 1, rest = row; a < D; ++a) {
    block[a] = rest % blocks_[a];
    rest /= blocks_[a];
    if (block[a] < lo[a] || block[a] > hi[a]) return;
  }
  f(row * blocks_[0] + lo[0], hi[0] - lo[0] + 1, block);
}

template <int D, class P>
inline void ParticleGridSchedule<D, P>::findActiveNodes() {
  IVec<D> first_block = blocks_, last_block = IVec<D>::Constant(-1);
  for (int r = 0; r < parts(); ++r) {
    first_block = first_block.cwiseMin(range_first_block_[r]);
    last_block = last_block.cwiseMax(range_last_block_[r]);
  }
  binned_first_block_ = first_block;
  binned_last_block_ = last_block;
  const NodeBox<D> previous = active_;
  // A particle of cell c reaches nodes c-1 .. c+2 with either kernel, and may move drift_cells
  // before the next binning; two more on each side hold particles just outside the domain, which
  // the edge blocks keep.
  constexpr int margin = 2 + drift_cells;
  for (int a = 0; a < D; ++a) {
    active_.lo[a] = std::max(0, first_block[a] * block_cells - margin + grid_.ghost);
    active_.hi[a] =
        std::min(grid_.nodes[a], (last_block[a] + 1) * block_cells + 1 + margin + grid_.ghost);
  }
  // The partial grids hold mass in this binning's active_, the grid still holds the last grid
  // stage's, in the previous binning's: the grid stage updates both.
  updated_ = active_;
  if (previous.count() > 0) {
    updated_.lo = updated_.lo.cwiseMin(previous.lo);
    updated_.hi = updated_.hi.cwiseMax(previous.hi);
  }
}

template <int D, class P>
inline void ParticleGridSchedule<D, P>::splitRows() {
  const int rows = static_cast<int>(row_start_.size()) - 1;
  const int n = particles_;
  part_rows_[0] = 0;
  int row = 0;
  for (int t = 1; t < parts(); ++t) {
    const int target = particle_shares_.start(t, n);
    while (row < rows && rowFirstParticle(row) < target) ++row;
    // The row across the target goes to the part that holds more of it.
    if (row > part_rows_[t - 1] &&
        target - rowFirstParticle(row - 1) < rowFirstParticle(row) - target)
      --row;
    part_rows_[t] = row;
  }
  part_rows_[parts()] = rows;
}

template <int D, class P>
inline int ParticleGridSchedule<D, P>::rowColour(int row) const {
  int colour = 0;
  for (int a = 1, weight = 1; a < D; ++a, weight *= colour_stride) {
    colour += row % blocks_[a] % colour_stride * weight;
    row /= blocks_[a];
  }
  return colour;
}

template <int D, class P>
inline typename ParticleGridSchedule<D, P>::RowCells ParticleGridSchedule<D, P>::rowCellsAt(
    int o) const {
  const int rows = static_cast<int>(row_start_.size()) - 1;
  // The last row whose first place is o or before (o = the particle count: an empty part's end).
  int row = std::min(rows - 1,
                     static_cast<int>(std::upper_bound(row_start_.begin(), row_start_.end(), o) -
                                      row_start_.begin()) -
                         1);
  RowCells cells;
  cells.end = rowFirstParticle(row + 1);
  cells.inv_h = 1 / grid_.h;
  constexpr Real unbounded = std::numeric_limits<Real>::infinity();
  const auto allow = [&](int a, int first_block, int last_block) {
    cells.lo[a] = first_block == 0 ? -unbounded : first_block * block_cells - drift_cells;
    cells.hi[a] =
        last_block == blocks_[a] - 1 ? unbounded : (last_block + 1) * block_cells + drift_cells;
  };
  allow(0, binned_first_block_[0], binned_last_block_[0]);  // a row spans the binning's box
  for (int a = 1; a < D; ++a) {
    allow(a, row % blocks_[a], row % blocks_[a]);
    row /= blocks_[a];
  }
  return cells;
}

template <int D, class P>
inline bool ParticleGridSchedule<D, P>::withinRowCells(int o, const Vec<D>& x,
                                                       RowCells& row) const {
  if (o >= row.end) row = rowCellsAt(o);
  // The cell as binParticles computes it, floor(x / h), within [lo, hi): no branch per axis.
  bool within = true;
  for (int a = 0; a < D; ++a) {
    const Real cell = x[a] * row.inv_h;
    within &= (cell >= row.lo[a]) & (cell < row.hi[a]);
  }
  return within;
}

template <int D, class P>
inline void ParticleGridSchedule<D, P>::emptyPartialGrids() {
  unsummed_scatter_ = false;
  const NodeBox<D>& box = updated_;
  const int width = box.hi[0] - box.lo[0];
  if (width <= 0) return;
  for (int line = 0, lines = box.count() / width; line < lines; ++line) {
    const int first = box.flatIndex(grid_, line * width);
    for (PartialGrid& g : partial_) {
      std::fill_n(g.mass.begin() + first, width, Real(0));
      std::fill_n(g.momentum.begin() + first, width, Vec<D>::Zero());
      if (!g.force.empty()) std::fill_n(g.force.begin() + first, width, Vec<D>::Zero());
    }
  }
}

template <int D, class P>
inline void ParticleGridSchedule<D, P>::sumPartialGrids(int k, GridFields<D>& fields) {
  const bool forces = !partial_[0].force.empty();
  Real mass = 0;
  Vec<D> momentum = Vec<D>::Zero(), force = Vec<D>::Zero();
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
  // The grid stage zeroed the nodes the binning before left outside active_.
  updated_ = active_;
}

template <int D, class P>
inline std::pair<int, int> ParticleGridSchedule<D, P>::passChunks(int part) const {
  const int chunks = static_cast<int>(chunk_sums_.size());
  return {particle_shares_.start(part, chunks), particle_shares_.start(part + 1, chunks)};
}

}  // namespace snowsim
