#include "sim/parallel/row_binning.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace snowsim {

template <int D>
RowBinning<D>::RowBinning(const GridGeometry<D>& grid, int particles)
    : grid_(grid), particles_(particles) {
  order_.resize(particles);
  particle_block_.resize(particles);
  block_count_ = 1;
  for (int a = 0; a < D; ++a) {
    blocks_[a] = (grid.cells[a] + block_cells - 1) / block_cells;
    block_count_ *= blocks_[a];
  }
  row_start_.assign(block_count_ / blocks_[0] + 1, 0);
  block_start_.assign(block_count_, 0);
  node_blocks_ = blocks_ + IVec<D>::Constant(2);
  reached_.assign(node_blocks_.prod(), 0);
  staged_.assign(reached_.size(), 0);
}

template <int D>
void RowBinning<D>::setParts(int parts) {
  part_rows_.resize(parts + 1);
  range_count_.assign(static_cast<size_t>(parts) * block_count_, 0);
  range_cursor_.resize(static_cast<size_t>(parts) * block_count_);
  range_first_block_.assign(parts, blocks_);  // empty boxes: nothing counted yet
  range_last_block_.assign(parts, IVec<D>::Constant(-1));
}

template <int D>
template <class T>
void RowBinning<D>::bin(Team& team, const WorkShares& shares, const std::vector<Vec<D, T>>& x) {
  const int n = particles_;
  const int rows = this->rows();
  const T inv_h = T(1 / grid_.h);
  // Counting sort, each part on one contiguous range of particle indices: count per block, a
  // prefix sum over (block, range) gives each range its place in each block, each range places
  // its particles. A stable sort: its result does not depend on how the particles were split.
  // A range's counts are zero outside the box of blocks its particles were in, which is all
  // that is cleared and summed: the snow's blocks, not the domain's.
  team.forEachPart("bin: count", [&](int r) {
    int* count = &range_count_[rangeOffset(r)];
    for (int row = 0; row < rows; ++row)
      forBlocksOfRowInBox(
          row, range_first_block_[r], range_last_block_[r],
          [&](int first, int length, const IVec<D>&) { std::fill_n(count + first, length, 0); });
    IVec<D> first = blocks_, last = IVec<D>::Constant(-1);
    for (int p = shares.start(r, n), end = shares.start(r + 1, n); p < end; ++p) {
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
  team.forEachPart("bin: place", [&](int r) {
    const int ranges = parts();
    IVec<D> lo = blocks_, hi = IVec<D>::Constant(-1);  // the union of the ranges' boxes
    for (int range = 0; range < ranges; ++range) {
      lo = lo.cwiseMin(range_first_block_[range]);
      hi = hi.cwiseMax(range_last_block_[range]);
    }
    int* cursor = &range_cursor_[rangeOffset(r)];
    int placed = 0;
    for (int row = 0; row < rows; ++row) {
      if (r == 0) row_start_[row] = placed;
      forBlocksOfRowInBox(row, lo, hi, [&](int first, int length, IVec<D> block) {
        for (int b = first; b < first + length; ++b, ++block[0]) {
          if (r == 0) block_start_[b] = placed;
          for (int range = 0; range < ranges; ++range) {
            if (!inRangeBox(range, block)) continue;  // none of its particles
            if (range == r) cursor[b] = placed;
            placed += range_count_[rangeOffset(range) + b];
          }
        }
      });
    }
    for (int p = shares.start(r, n), end = shares.start(r + 1, n); p < end; ++p)
      order_[cursor[particle_block_[p]]++] = p;
    if (r == 0) {  // read after this stage only
      row_start_[rows] = placed;
      splitRows(shares);
      findActiveNodes();
      must_bin_ = false;
      ++binnings_;
    }
  });
}

template <int D>
template <class F>
void RowBinning<D>::forBlocksOfRowInBox(int row, const IVec<D>& lo, const IVec<D>& hi,
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

template <int D>
void RowBinning<D>::findActiveNodes() {
  IVec<D> first_block = blocks_, last_block = IVec<D>::Constant(-1);
  for (int r = 0; r < parts(); ++r) {
    first_block = first_block.cwiseMin(range_first_block_[r]);
    last_block = last_block.cwiseMax(range_last_block_[r]);
  }
  binned_first_block_ = first_block;
  binned_last_block_ = last_block;
  // What the grid holds: the last grid stage's box, or, with no grid stage since the last
  // binning, the box that stage was to update (which covers it).
  const NodeBox<D> previous = staged_is_reached_ ? active_ : updated_;
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
  findReachedNodeBlocks();
}

template <int D>
void RowBinning<D>::findReachedNodeBlocks() {
  // What the last grid stage reached stays to be zeroed by the next one.
  if (staged_is_reached_) reached_.swap(staged_);
  staged_is_reached_ = false;
  std::fill(reached_.begin(), reached_.end(), 0);
  const IVec<D> first = binned_first_block_, last = binned_last_block_;
  if ((last.array() < first.array()).any()) return;  // no particles
  IVec<D> stride;
  stride[0] = 1;
  for (int a = 1; a < D; ++a) stride[a] = stride[a - 1] * node_blocks_[a - 1];
  // Block b holding particles marks node block b + 1 ...
  for (int row = 0; row < rows(); ++row)
    forBlocksOfRowInBox(row, first, last, [&](int flat, int length, IVec<D> block) {
      for (int b = flat; b < flat + length; ++b, ++block[0]) {
        bool held = false;
        for (int range = 0; range < parts(); ++range)
          held = held || (inRangeBox(range, block) && range_count_[rangeOffset(range) + b] > 0);
        if (held) reached_[(block + IVec<D>::Ones()).dot(stride)] = 1;
      }
    });
  // ... then each mark spreads to its neighbours along each axis in turn, within the node blocks
  // first .. last + 2, whose lines along an axis start at lineStart(axis, line).
  const IVec<D> lo = first, extent = last - first + IVec<D>::Constant(3);
  const auto lineStart = [&](int axis, int line) {
    int start = lo[axis] * stride[axis];
    for (int a = 0, rest = line; a < D; ++a) {
      if (a == axis) continue;
      start += (lo[a] + rest % extent[a]) * stride[a];
      rest /= extent[a];
    }
    return start;
  };
  if constexpr (drift_cells > 0) {
    // Between binnings a row's particles may move anywhere along x within the binning's box
    // (rowCellsAt): the whole row along x.
    for (int line = 0; line < extent.prod() / extent[0]; ++line) {
      unsigned char* row = &reached_[lineStart(0, line)];
      if (std::find(row, row + extent[0], 1) != row + extent[0]) std::fill_n(row, extent[0], 1);
    }
  }
  for (int axis = 0; axis < D; ++axis) {
    const int lines = extent.prod() / extent[axis];
    for (int line = 0; line < lines; ++line) {
      const int start = lineStart(axis, line);
      unsigned char before = 0;
      for (int i = 0; i < extent[axis]; ++i) {
        unsigned char& here = reached_[start + i * stride[axis]];
        const unsigned char next =
            i + 1 < extent[axis] ? reached_[start + (i + 1) * stride[axis]] : 0;
        const unsigned char was = here;
        here = before | here | next;
        before = was;
      }
    }
  }
}

template <int D>
void RowBinning<D>::splitRows(const WorkShares& shares) {
  const int rows = this->rows();
  const int n = particles_;
  part_rows_[0] = 0;
  int row = 0;
  for (int t = 1; t < parts(); ++t) {
    const int target = shares.start(t, n);
    while (row < rows && rowStart(row) < target) ++row;
    // The row across the target goes to the part that holds more of it.
    if (row > part_rows_[t - 1] && target - rowStart(row - 1) < rowStart(row) - target) --row;
    part_rows_[t] = row;
  }
  part_rows_[parts()] = rows;
}

template <int D>
int RowBinning<D>::rowColour(int row) const {
  int colour = 0;
  for (int a = 1, weight = 1; a < D; ++a, weight *= colour_stride) {
    colour += row % blocks_[a] % colour_stride * weight;
    row /= blocks_[a];
  }
  return colour;
}

template <int D>
typename RowBinning<D>::RowCells RowBinning<D>::rowCellsAt(int o) const {
  const int rows = this->rows();
  // The last row whose first place is o or before (o = the particle count: an empty part's end).
  int row = std::min(rows - 1,
                     static_cast<int>(std::upper_bound(row_start_.begin(), row_start_.end(), o) -
                                      row_start_.begin()) -
                         1);
  RowCells cells;
  cells.end = rowStart(row + 1);
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

template <int D>
typename RowBinning<D>::State RowBinning<D>::state() const {
  return {order_,  row_start_, binned_first_block_, binned_last_block_, must_bin_, binnings_,
          active_, updated_};
}

template <int D>
std::string RowBinning<D>::restore(State state) {
  if (state.order.size() != order_.size() || state.row_start.size() != row_start_.size())
    return "a binning of another particle count or grid";
  for (const int p : state.order)
    if (p < 0 || p >= particles_) return "a binned particle " + std::to_string(p);
  const std::vector<int>& row_start = state.row_start;
  for (int r = 0; r < rows(); ++r)
    if (row_start[r] < 0 || row_start[r] > row_start[r + 1] || row_start[r + 1] > particles_)
      return "the rows' particles";
  for (const NodeBox<D>* box : {&state.active, &state.updated})
    for (int a = 0; a < D; ++a)
      if (box->lo[a] < 0 || box->hi[a] < 0 || box->lo[a] > grid_.nodes[a] ||
          box->hi[a] > grid_.nodes[a])
        return "the active grid nodes";
  order_ = std::move(state.order);
  row_start_ = std::move(state.row_start);
  binned_first_block_ = state.binned_first_block;
  binned_last_block_ = state.binned_last_block;
  must_bin_ = state.must_bin;
  binnings_ = state.binnings;
  active_ = state.active;
  updated_ = state.updated;
  // Where the particles reach is not stored: every node block of the box until the next binning.
  std::fill(reached_.begin(), reached_.end(), 1);
  staged_is_reached_ = true;
  return {};
}

template class RowBinning<2>;
template class RowBinning<3>;
template void RowBinning<2>::bin(Team&, const WorkShares&, const std::vector<Vec<2, double>>&);
template void RowBinning<3>::bin(Team&, const WorkShares&, const std::vector<Vec<3, double>>&);
template void RowBinning<2>::bin(Team&, const WorkShares&, const std::vector<Vec<2, float>>&);
template void RowBinning<3>::bin(Team&, const WorkShares&, const std::vector<Vec<3, float>>&);

}  // namespace snowsim
