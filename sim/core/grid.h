// A regular background grid over the domain box [0, cells*h]. Nodes sit at i*h; a ghost layer
// beyond the walls holds the kernel support of particles that touch a wall. All fields are flat
// arrays indexed by GridGeometry::index.
#pragma once

#include <algorithm>
#include <vector>

#include "sim/core/math.h"

namespace snowsim {

template <int D>
struct GridGeometry {
  static constexpr int ghost = 2;  // enough for the cubic B-spline stencil of a particle on a wall

  IVec<D> cells;   // cells along each axis; the domain is [0, cells[a] * h]
  Real h = 0;      // cell size
  IVec<D> nodes;   // stored nodes along each axis, ghosts included
  IVec<D> stride;  // flat index step along each axis

  GridGeometry() = default;
  GridGeometry(const IVec<D>& cells_, Real h_) : cells(cells_), h(h_) {
    int s = 1;
    for (int a = 0; a < D; ++a) {
      nodes[a] = cells[a] + 1 + 2 * ghost;
      stride[a] = s;
      s *= nodes[a];
    }
  }

  int nodeCount() const { return stride[D - 1] * nodes[D - 1]; }
  Vec<D> extent() const { return cells.template cast<Real>() * h; }

  // Flat index of node i, where i counts from the node at the origin (ghosts are negative).
  int index(const IVec<D>& i) const {
    int k = 0;
    for (int a = 0; a < D; ++a) k += (i[a] + ghost) * stride[a];
    return k;
  }

  // Integer coordinates of the node with flat index k.
  IVec<D> coords(int k) const {
    IVec<D> i;
    for (int a = 0; a < D; ++a) i[a] = (k / stride[a]) % nodes[a] - ghost;
    return i;
  }

  Vec<D> position(const IVec<D>& i) const { return i.template cast<Real>() * h; }
};

// A box of stored nodes, [lo, hi) in storage coordinates (0 is the first ghost node): the part
// of the grid that a step of a sparse scene touches.
template <int D>
struct NodeBox {
  IVec<D> lo = IVec<D>::Zero(), hi = IVec<D>::Zero();

  int count() const {
    int c = 1;
    for (int a = 0; a < D; ++a) c *= std::max(0, hi[a] - lo[a]);
    return c;
  }
  // Flat grid index of the n-th node of the box, first axis fastest like the grid's own order.
  int flatIndex(const GridGeometry<D>& grid, int n) const {
    int k = 0;
    for (int a = 0; a < D; ++a) {
      const int extent = hi[a] - lo[a];
      k += (lo[a] + n % extent) * grid.stride[a];
      n /= extent;
    }
    return k;
  }
};

// Per-node mass, velocity and force: the fields every grid solver here rasterises into, in the
// precision T of the solver's state.
template <int D, class T = Real>
struct GridFields {
  std::vector<T> mass;
  std::vector<Vec<D, T>> velocity;      // after rasterisation, then updated in place
  std::vector<Vec<D, T>> velocity_old;  // velocity as rasterised, for the FLIP increment
  std::vector<Vec<D, T>> force;

  void resize(int n) {
    mass.assign(n, 0);
    velocity.assign(n, Vec<D, T>::Zero());
    velocity_old.assign(n, Vec<D, T>::Zero());
    force.assign(n, Vec<D, T>::Zero());
  }
  void clear() {
    std::fill(mass.begin(), mass.end(), T(0));
    std::fill(velocity.begin(), velocity.end(), Vec<D, T>::Zero());
    std::fill(force.begin(), force.end(), Vec<D, T>::Zero());
  }
};

// The values a 2D snapshot shows at the nodes of the domain ((cells[0] + 1) x (cells[1] + 1), x
// fastest): value(k) for each, by flat index k. None in 3D.
template <int D, class F>
void domainNodeValues(const GridGeometry<D>& grid, F&& value, std::vector<float>& out) {
  out.clear();
  if constexpr (D == 2)
    for (int j = 0; j <= grid.cells[1]; ++j)
      for (int i = 0; i <= grid.cells[0]; ++i)
        out.push_back(static_cast<float>(value(grid.index(IVec<2>(i, j)))));
}

}  // namespace snowsim
