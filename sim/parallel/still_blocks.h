// What the blocks of still particles scattered, kept. A particle at rest (auto-sleep: no velocity,
// no affine velocity, a deformation that does not change) scatters the same mass and the same
// force every step; MLS puts that force into the momentum times the step. A block of particles
// that all stayed so since the last scatter adds what it scattered then, its momentum rescaled to
// the new step, instead of scattering again: copying a block's nodes costs a few additions per
// particle, its scatter hundreds.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

#include "sim/core/grid.h"
#include "sim/parallel/zero_page_allocator.h"

namespace snowsim {

// The still blocks of a physics with no fields of its own beside the partial grid's
// (ParticleGridSchedule::scatter with stillness).
struct NoOwnFields {
  template <class ForStill, class Region>
  void keep(int, int, ForStill&&, Region&&) const {}
  template <class ForStill>
  void reuse(int, ForStill&&) const {}
  template <class Scalar>
  void add(int, int, Scalar) const {}
};

// Grid: a partial grid (mass, momentum, and force unless empty), of scalar Scalar.
template <int D, class Grid, class Scalar>
class StillBlocks {
 public:
  StillBlocks(const GridGeometry<D>& grid, const IVec<D>& blocks, int block_cells, bool forces)
      : grid_(grid), blocks_(blocks), block_cells_(block_cells), extent_(block_cells + 3) {
    region_nodes_ = 1;
    for (int a = 0; a < D; ++a) {
      region_nodes_ *= extent_;
      // A particle on the domain's far face sits in cell `cells`, which the last block holds when
      // the cells fill its blocks: its nodes reach one beyond the region.
      last_kept_[a] = blocks[a] - 1 - (grid.cells[a] % block_cells == 0);
    }
    const size_t count = static_cast<size_t>(blocks.prod());
    kept_count_.assign(count, -1);
    // Grid-sized in address space (extent_^D / block_cells^D the grid's nodes); only the blocks
    // that ever rest take memory.
    mass_.resize(count * region_nodes_);
    momentum_.resize(count * region_nodes_);
    if (forces) force_.resize(count * region_nodes_);
  }

  // Whether block `block` may keep the scatter of `count` particles: within the region, and worth
  // it, the particles writing at least as many nodes (3^D each, the smallest stencil) as the
  // region holds.
  bool mayKeep(int block, int count) const {
    int stencil_writes = count;
    for (int a = 0, rest = block; a < D; ++a) {
      if (rest % blocks_[a] > last_kept_[a]) return false;
      rest /= blocks_[a];
      stencil_writes *= 3;
    }
    return stencil_writes >= region_nodes_;
  }
  // Whether block `block` kept what its `count` particles scattered: then, if they are the same
  // particles, unchanged since, add() gives this step's scatter.
  bool holds(int block, int count) const { return kept_count_[block] == count; }
  // Keeps what `count` particles of block `block` scattered into `scratch` at unit momentum
  // scale, and empties those nodes of the scratch grid for the next block.
  void keep(int block, int count, Grid& scratch) {
    const size_t c = static_cast<size_t>(block) * region_nodes_;
    forRegion(block, [&](int k, int local) {
      mass_[c + local] = scratch.mass[k];
      momentum_[c + local] = scratch.momentum[k];
      scratch.mass[k] = 0;
      scratch.momentum[k].setZero();
      if (!force_.empty()) {
        force_[c + local] = scratch.force[k];
        scratch.force[k].setZero();
      }
    });
    kept_count_[block] = count;
  }
  // Adds the kept scatter of block `block` to g, its momentum times `scale` (the step).
  void add(int block, Grid& g, Scalar scale) const {
    const size_t c = static_cast<size_t>(block) * region_nodes_;
    forRegion(block, [&](int k, int local) {
      g.mass[k] += mass_[c + local];
      g.momentum[k] += scale * momentum_[c + local];
      if (!force_.empty()) g.force[k] += force_[c + local];
    });
  }
  void forget(int block) { kept_count_[block] = -1; }
  void forgetAll() { std::fill(kept_count_.begin(), kept_count_.end(), -1); }

  // f(k, local) for the nodes of block `block`'s region, those its cells c reach (c - 1 .. c + 2
  // with either kernel): flat grid index k, and the node's place in the region's storage (first
  // axis fastest). In storage coordinates (ghost nodes first) the region lies within the grid.
  template <class F>
  void forRegion(int block, F&& f) const {
    IVec<D> lo, hi;  // storage coordinates, [lo, hi)
    for (int a = 0, rest = block; a < D; ++a) {
      lo[a] = (rest % blocks_[a]) * block_cells_ - 1 + GridGeometry<D>::ghost;
      hi[a] = std::min(lo[a] + extent_, grid_.nodes[a]);
      rest /= blocks_[a];
    }
    // Line by line along x, the grid's contiguous axis.
    const IVec<D> extent = hi - lo;
    const int lines = extent.prod() / extent[0];
    for (int line = 0; line < lines; ++line) {
      int k = lo[0], local = 0;
      for (int a = 1, rest = line, weight = extent_; a < D; ++a, weight *= extent_) {
        const int offset = rest % extent[a];
        rest /= extent[a];
        k += (lo[a] + offset) * grid_.stride[a];
        local += offset * weight;
      }
      for (int i = 0; i < extent[0]; ++i) f(k + i, local + i);
    }
  }

 private:
  template <class T>
  using ZeroPageVector = std::vector<T, ZeroPageAllocator<T>>;
  using Vector = Vec<D, Scalar>;  // momentum, force

  GridGeometry<D> grid_;
  IVec<D> blocks_;
  int block_cells_;
  int extent_;  // nodes of a region along each axis
  int region_nodes_;
  IVec<D> last_kept_;  // per axis, the last block coordinate whose region holds its scatter
  std::vector<int> kept_count_;  // per block: its particles when it kept its scatter, else -1
  ZeroPageVector<Scalar> mass_;
  ZeroPageVector<Vector> momentum_, force_;
};

}  // namespace snowsim
