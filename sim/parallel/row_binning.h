// Where each particle goes in a coloured scatter: particles binned into blocks of block_cells^D
// cells and sorted by block, in stored order within a block; a row of blocks along x is the unit
// of scatter work, and its colour, its y (and z) block index modulo colour_stride, names the
// partial grid it writes. A particle of cell c reaches nodes c-1 .. c+2, so rows of one colour
// write no common node as long as their particles stay within drift_cells of their rows' cells
// (Gao et al. 2018, "GPU Optimization of Material Point Methods", colour the blocks the same
// way). The parts of a team take consecutive rows.
#pragma once

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "sim/core/grid.h"
#include "sim/parallel/team.h"
#include "sim/parallel/work_shares.h"

namespace snowsim {

template <int D>
class RowBinning {
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

  RowBinning(const GridGeometry<D>& grid, int particles);

  // The counting sort's state for this many parts.
  void setParts(int parts);
  // Another count of particles (they moved between ranks): binned anew before the next scatter.
  void resize(int particles) {
    particles_ = particles;
    order_.resize(particles);
    particle_block_.resize(particles);
    must_bin_ = true;
  }
  // Bins the particles at x as two stages of the team, part r counting and placing the indices
  // shares.start(r) .. start(r + 1): a stable sort, whose result does not depend on the split.
  // Then rows are split among the parts by the shares, and the active nodes found. T: the
  // precision of the positions, in which the kernels find their cells.
  template <class T>
  void bin(Team& team, const WorkShares& shares, const std::vector<Vec<D, T>>& x);
  // The rows split among the parts anew by the shares, the binning kept.
  void splitRows(const WorkShares& shares);
  bool mustBin() const { return must_bin_ || drift_cells == 0; }
  // Set when a particle pass found a particle beyond its row's cells.
  void particlesLeftTheirRows() { must_bin_ = true; }
  long binnings() const { return binnings_; }
  // The binning as it stands, for a checkpoint, and back: plain data, which the checkpoint's
  // layer writes and reads.
  struct State {
    std::vector<int> order, row_start;
    IVec<D> binned_first_block = IVec<D>::Zero(), binned_last_block = IVec<D>::Constant(-1);
    bool must_bin = true;
    long binnings = 0;
    NodeBox<D> active, updated;
  };
  State state() const;
  // Restores a state of a binning of the same grid and particle count; returns what does not fit
  // (empty when it fits, else the binning is left as it was).
  std::string restore(State state);

  // The rows of part `part`, [first, last); row r's particles are sorted(o) for o in
  // [rowStart(r), rowStart(r + 1)); the colour of row r.
  std::pair<int, int> partRows(int part) const { return {part_rows_[part], part_rows_[part + 1]}; }
  int rowStart(int row) const { return row_start_[row]; }
  int sorted(int o) const { return order_[o]; }
  int rowColour(int row) const;
  // f(block, begin, end) for the blocks of row `row` that the last binning's box holds, along x:
  // the flat block index (first axis fastest) and its particles' sorted places [begin, end). Only
  // after bin() in this process (a checkpoint does not hold the blocks' places).
  template <class F>
  void forBlocksOfRow(int row, F&& f) const {
    const int row_end = row_start_[row + 1];
    if (row_start_[row] == row_end) return;  // a row with particles lies in the box
    const int first = row * blocks_[0] + binned_first_block_[0];
    const int last = row * blocks_[0] + binned_last_block_[0];
    for (int b = first; b <= last; ++b)
      f(b, block_start_[b], b < last ? block_start_[b + 1] : row_end);
  }
  const IVec<D>& blocks() const { return blocks_; }
  // After the particles were stored in the sorted order: place o holds particle o.
  void storedInOrder(int o) { order_[o] = o; }

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
  template <class T>
  bool withinRowCells(int o, const Vec<D, T>& x, RowCells& row) const {
    if (o >= row.end) row = rowCellsAt(o);
    // The cell as bin() computes it, floor(x / h), within [lo, hi): no branch per axis.
    bool within = true;
    for (int a = 0; a < D; ++a) {
      const T cell = x[a] * T(row.inv_h);
      within &= (cell >= row.lo[a]) & (cell < row.hi[a]);
    }
    return within;
  }

  // The nodes within the kernel's reach of the particles' blocks, widened by drift_cells: the
  // grid stages touch only these, so a small snowball in a large domain costs what the snowball
  // does. Nodes outside stay zero: the first grid stage after a binning updates this binning's
  // active box and the previous one's (updated()), which zeroes the nodes the active box no longer
  // covers; the grid stages after it, the active box alone (gridStageDone()).
  const NodeBox<D>& active() const { return active_; }
  const NodeBox<D>& updated() const { return updated_; }
  void gridStageDone() {
    updated_ = active_;
    staged_is_reached_ = true;
  }
  // Within the updated box, finer: f(k, count) for the runs of `count` consecutive nodes from flat
  // index k, along line `line` of the box (its lines along x in flatIndex order), that lie in a
  // block of nodes the particles' blocks reach now or reached at the last grid stage. The box's
  // other nodes are zero and stay so unvisited: a spreading snow's bounding box is mostly air.
  template <class F>
  void forUpdatedRuns(int line, F&& f) const;

 private:
  void findActiveNodes();
  // f(first, length, block): the blocks of row `row` within the box [lo, hi] of block coordinates,
  // a run of `length` along x from flat block index `first`, at coordinates `block`; nothing if
  // the row misses the box.
  template <class F>
  void forBlocksOfRowInBox(int row, const IVec<D>& lo, const IVec<D>& hi, F&& f) const;
  // The blocks of nodes within reach of the blocks holding particles (reached_).
  void findReachedNodeBlocks();
  // The block of nodes of storage coordinate s along an axis. Node blocks sit one block lower
  // than the particles' blocks, so that block b's particles reach node blocks b .. b + 2: nodes
  // c - 1 - drift_cells .. c + 2 + drift_cells of its cells c, and the ghost nodes at the edges
  // (along x with drift_cells > 0, the whole row: see findReachedNodeBlocks).
  int nodeBlockOf(int s) const { return (s - grid_.ghost + block_cells) / block_cells; }
  // Where range r's counts and cursors start in range_count_ and range_cursor_; whether block
  // coordinates `block` lie in the box of r's particles (outside it its counts are stale).
  size_t rangeOffset(int r) const { return static_cast<size_t>(r) * block_count_; }
  bool inRangeBox(int r, const IVec<D>& block) const {
    return (block.array() >= range_first_block_[r].array()).all() &&
           (block.array() <= range_last_block_[r].array()).all();
  }
  int parts() const { return static_cast<int>(part_rows_.size()) - 1; }
  int rows() const { return static_cast<int>(row_start_.size()) - 1; }

  GridGeometry<D> grid_;
  int particles_;
  IVec<D> blocks_;
  int block_count_ = 0;
  std::vector<int> row_start_;  // particles of row r: order_[row_start_[r] .. [r + 1])
  // Where each block's particles start in the sorted order; set for the blocks of the last
  // binning's box only.
  std::vector<int> block_start_;
  std::vector<int> order_;
  std::vector<int> particle_block_;  // per stored particle, bin()'s scratch
  std::vector<int> part_rows_;       // part t scatters rows part_rows_[t] .. [t + 1]
  // Counting-sort state per part r, each sorting one contiguous range of particle indices:
  // range_count_[r * block_count_ + b] counts its particles of block b, range_cursor_ places them;
  // range_first/last_block_[r] bound the blocks its particles are in.
  std::vector<int> range_count_, range_cursor_;
  std::vector<IVec<D>> range_first_block_, range_last_block_;
  // The last binning's box of blocks.
  IVec<D> binned_first_block_ = IVec<D>::Zero(), binned_last_block_ = IVec<D>::Constant(-1);
  bool must_bin_ = true;
  long binnings_ = 0;
  NodeBox<D> active_, updated_;
  // Per block of nodes (node_blocks_ along each axis, first axis fastest): 1 where the particles
  // of the last binning reach (reached_), where they reached at the last grid stage (staged_,
  // read only while !staged_is_reached_: a binning since that stage).
  IVec<D> node_blocks_;
  std::vector<unsigned char> reached_, staged_;
  bool staged_is_reached_ = true;
};

template <int D>
template <class F>
void RowBinning<D>::forUpdatedRuns(int line, F&& f) const {
  const NodeBox<D>& box = updated_;
  const int width = box.hi[0] - box.lo[0];
  int row = 0;  // the flat index of the line's first node block
  for (int a = 1, rest = line, weight = node_blocks_[0]; a < D; ++a) {
    const int extent = box.hi[a] - box.lo[a];
    row += nodeBlockOf(box.lo[a] + rest % extent) * weight;
    rest /= extent;
    weight *= node_blocks_[a];
  }
  const int k0 = box.flatIndex(grid_, line * width);
  const auto reached = [&](int s) {
    const int b = row + nodeBlockOf(s);
    return reached_[b] || (!staged_is_reached_ && staged_[b]);
  };
  int run = -1;  // the open run's first node, or -1
  for (int s = box.lo[0]; s < box.hi[0];) {
    // The nodes of s's block within the box, [s, end): the next block starts at node
    // nodeBlockOf(s) * block_cells (storage coordinate + ghost).
    const int end = std::min(box.hi[0], nodeBlockOf(s) * block_cells + grid_.ghost);
    if (reached(s)) {
      if (run < 0) run = s;
    } else if (run >= 0) {
      f(k0 + run - box.lo[0], s - run);
      run = -1;
    }
    s = end;
  }
  if (run >= 0) f(k0 + run - box.lo[0], box.hi[0] - run);
}

}  // namespace snowsim
