// Visiting the grid nodes of one particle's B-spline stencil, shared by every solver.
#pragma once

#include <algorithm>
#include <type_traits>
#include <utility>

#include "sim/core/bspline.h"
#include "sim/core/grid.h"
#include "sim/core/lanes.h"

namespace snowsim {

// The node of a particle's stencil being visited: flat grid index, per-axis offsets into the
// stencil (for Stencil::weightAt / gradientAt) and x_i - x_p, which APIC/MLS need.
template <int D, class T = Real>
struct StencilVisit {
  int index;
  int offset[D];
  Vec<D, T> dx;
};

// Calls f(const StencilVisit<D>&) for every node of the particle's stencil, axis 0 fastest. The
// nodes are unrolled at compile time (a fold over the node numbers), so each node's offsets are
// constants: no integer division and no loop in the transfer hot loops.
template <int D, class Kernel, class T, class F, int... Node>
inline void visitStencilNodes(const GridGeometry<D>& grid, const Stencil<D, Kernel, T>& s,
                              const Vec<D, T>& x, F&& f, std::integer_sequence<int, Node...>) {
  constexpr int S = Kernel::support;
  T dx[D][S];
  for (int a = 0; a < D; ++a)
    for (int o = 0; o < S; ++o) dx[a][o] = T(s.base[a] + o) * T(grid.h) - x[a];
  const int base = grid.index(s.base);
  auto visit = [&]<int n>(std::integral_constant<int, n>) {
    StencilVisit<D, T> v;
    v.index = base;
    for (int a = 0, place = 1; a < D; ++a, place *= S) {
      v.offset[a] = n / place % S;
      v.dx[a] = dx[a][v.offset[a]];
      v.index += v.offset[a] * grid.stride[a];
    }
    f(static_cast<const StencilVisit<D, T>&>(v));
  };
  (visit(std::integral_constant<int, Node>{}), ...);
}

// Flattened: the per-node lambda and everything it calls are inlined into each unrolled node, which
// keeps the transfers' values in registers (bench/mpm_bench measures it). A callback that calls
// much (a test's assertions) makes this slow to compile: collect the nodes first there.
template <int D, class Kernel, class T, class F>
SNOWSIM_FLATTEN inline void visitStencilFlattened(const GridGeometry<D>& grid,
                                                  const Stencil<D, Kernel, T>& s,
                                                  const Vec<D, T>& x, F&& f) {
  visitStencilNodes(grid, s, x, std::forward<F>(f),
                    std::make_integer_sequence<int, Stencil<D, Kernel, T>::nodes>{});
}

template <int D, class Kernel, class T, class F>
inline void visitStencil(const GridGeometry<D>& grid, const Stencil<D, Kernel, T>& s,
                         const Vec<D, T>& x, F&& f) {
  visitStencilFlattened(grid, s, x, std::forward<F>(f));
}

// Tensor-product transfers for APIC and MLS-MPM. A weight is a product over axes,
// w_ip = prod_a N(o_a), and x_i - x_p has one component per axis, so the sums over the stencil
// factor axis by axis. The stencil is walked as rows: the nodes of a row lie next to each other
// along axis 0, the grid's contiguous axis, so a row of a vector field is consecutive scalars,
// which the loops below take four at a time. A row is taken as four nodes (a quadratic stencil's
// fourth node gets weight 0: it is read but takes no part in a sum, and receives zeros); it
// stays inside the grid, whose ghost layer reaches past a particle on the far wall.
template <int D, class Kernel, class T = Real>
class TensorStencil {
 public:
  static constexpr int S = Kernel::support;
  static constexpr int rows = D == 2 ? S : S * S;  // rows of nodes along axis 0
  static constexpr int row_nodes = 4;              // S, padded
  static constexpr int row_values = row_nodes * D;
  static constexpr int chunks = row_values / 4;
  using V = Vec<D, T>;
  using M = Mat<D, T>;
  using Lanes = typename Lanes4<T>::type;
  static_assert(S <= row_nodes && sizeof(V) == D * sizeof(T),
                "a row's nodes must lie back to back");

  TensorStencil(const GridGeometry<D>& grid, const Stencil<D, Kernel, T>& s, const V& x) : s_(s) {
#pragma GCC unroll 16
    for (int a = 0; a < D; ++a)
#pragma GCC unroll 16
      for (int o = 0; o < S; ++o) dx_[a][o] = T(s.base[a] + o) * T(grid.h) - x[a];
    const int base = grid.index(s.base);
#pragma GCC unroll 16
    for (int r = 0; r < rows; ++r) {
      const int o1 = r % S, o2 = r / S;
      row_index_[r] = base + o1 * grid.stride[1];
      row_weight_[r] = s.w[1][o1];
      if constexpr (D == 3) {
        row_index_[r] += o2 * grid.stride[2];
        row_weight_[r] *= s.w[2][o2];
      }
    }
  }

  // Adds w_ip m to mass[i] and w_ip (v + A (x_i - x_p)) to momentum[i] for every node i of the
  // stencil.
  [[gnu::always_inline]] void scatterAffine(T m, const V& v, const M& A, T* mass,
                                            V* momentum) const {
    T inner_mass[row_nodes] = {}, along[D - 1][S][row_values] = {};
    affineParts(m, v, A, inner_mass, along);
    // The grid is read and written a scalar at a time: the next particle's rows start a node or
    // two from this one's, and a load that straddles two earlier vector stores waits for both to
    // reach the cache, where one the width of the store it reads takes the value on the way.
    const Lanes lanes_mass = load(inner_mass);
#pragma GCC unroll 16
    for (int r = 0; r < rows; ++r) {
      const T w = row_weight_[r];
      const Lanes row_mass = w * lanes_mass;
      T* grid_mass = mass + row_index_[r];
#pragma GCC unroll 16
      for (int o = 0; o < S; ++o) grid_mass[o] += row_mass[o];
      T* row = momentum[row_index_[r]].data();
#pragma GCC unroll 16
      for (int j = 0; j < chunks; ++j) {
        Lanes value = load(along[0][r % S] + 4 * j);
        if constexpr (D == 3) value += load(along[1][r / S] + 4 * j);
        value *= w;
#pragma GCC unroll 16
        for (int i = 0; i < 4; ++i)
          if (4 * j + i < S * D) row[4 * j + i] += value[i];
      }
    }
  }

  // Adds w_ip values[f] to fields[f][i] for every node i of the stencil and each of the n fields
  // (the mass of scatterAffine, rounded alike).
  template <int n>
  [[gnu::always_inline]] void scatterScalars(const T (&values)[n], T* const (&fields)[n]) const {
    T inner[n][row_nodes] = {};
#pragma GCC unroll 16
    for (int f = 0; f < n; ++f)
#pragma GCC unroll 16
      for (int o = 0; o < S; ++o) inner[f][o] = s_.w[0][o] * values[f];
#pragma GCC unroll 16
    for (int r = 0; r < rows; ++r) {
      const T w = row_weight_[r];
#pragma GCC unroll 16
      for (int f = 0; f < n; ++f) {
        T* row = fields[f] + row_index_[r];
#pragma GCC unroll 16
        for (int o = 0; o < S; ++o) row[o] += w * inner[f][o];
      }
    }
  }

  // Returns sum_i w_ip f_i (x_i - x_p) of the scalar field f (gatherAffine's moment, one channel).
  [[gnu::always_inline]] V gatherScalarMoment(const T* field) const {
    T across[D][row_nodes] = {};  // [0]: sum_r w_r f; [a]: sum_r w_r dx_a f
#pragma GCC unroll 16
    for (int r = 0; r < rows; ++r) {
      const T* row = field + row_index_[r];
      const T w = row_weight_[r];
      const T w1 = w * dx_[1][r % S], w2 = D == 3 ? w * dx_[D - 1][r / S] : T(0);
#pragma GCC unroll 16
      for (int o = 0; o < S; ++o) {
        across[0][o] += w * row[o];
        across[1][o] += w1 * row[o];
        if constexpr (D == 3) across[2][o] += w2 * row[o];
      }
    }
    V moment = V::Zero();
#pragma GCC unroll 16
    for (int o = 0; o < S; ++o) {
      const T w0 = s_.w[0][o];
      moment[0] += w0 * dx_[0][o] * across[0][o];
#pragma GCC unroll 16
      for (int a = 1; a < D; ++a) moment[a] += w0 * across[a][o];
    }
    return moment;
  }

  // The largest f_i over the nodes of the stencil.
  [[gnu::always_inline]] T largest(const T* field) const {
    T most = field[row_index_[0]];
#pragma GCC unroll 16
    for (int r = 0; r < rows; ++r)
#pragma GCC unroll 16
      for (int o = 0; o < S; ++o) most = std::max(most, field[row_index_[r] + o]);
    return most;
  }

  // The largest |v_i|^2 over the nodes of the stencil, v_i = field[i].
  [[gnu::always_inline]] T largestSquaredNorm(const V* field) const {
    T most = 0;
#pragma GCC unroll 16
    for (int r = 0; r < rows; ++r) {
      const T* row = field[row_index_[r]].data();
      T squares[row_values];
#pragma GCC unroll 16
      for (int j = 0; j < chunks; ++j) {
        const Lanes values = load(row + 4 * j);
        store(squares + 4 * j, values * values);
      }
#pragma GCC unroll 16
      for (int o = 0; o < S; ++o) {
        T norm = 0;
#pragma GCC unroll 16
        for (int c = 0; c < D; ++c) norm += squares[o * D + c];
        most = std::max(most, norm);
      }
    }
    return most;
  }

  // f(i, w_ip, x_i - x_p) for every node i of the stencil, row by row.
  template <class F>
  [[gnu::always_inline]] void forEachNode(F&& f) const {
#pragma GCC unroll 16
    for (int r = 0; r < rows; ++r)
#pragma GCC unroll 16
      for (int o = 0; o < S; ++o) {
        V dx;
        dx[0] = dx_[0][o];
        dx[1] = dx_[1][r % S];
        if constexpr (D == 3) dx[2] = dx_[2][r / S];
        f(row_index_[r] + o, row_weight_[r] * s_.w[0][o], static_cast<const V&>(dx));
      }
  }

  // Returns sum_i w_ip v_i and sets moment = sum_i w_ip v_i (x_i - x_p)^T (APIC's B_p, Jiang et
  // al. 2015, eq. 10), v_i = field[i].
  [[gnu::always_inline]] V gatherAffine(const V* field, M& moment) const {
    return gatherRows([&](int r) { return field[row_index_[r]].data(); }, moment);
  }

  // scatterAffine with each node's share into one of n fields: node i of the stencil (numbered
  // row by row, node o of row r being r S + o) adds to mass[f][i] and momentum[f][i], f =
  // field(node).
  template <int n, class Field>
  [[gnu::always_inline]] void scatterAffineSplit(T m, const V& v, const M& A, T* const (&mass)[n],
                                                 V* const (&momentum)[n], Field&& field) const {
    T inner_mass[row_nodes] = {}, along[D - 1][S][row_values] = {};
    affineParts(m, v, A, inner_mass, along);
#pragma GCC unroll 16
    for (int r = 0; r < rows; ++r) {
      const T w = row_weight_[r];
      T values[row_values];
#pragma GCC unroll 16
      for (int j = 0; j < chunks; ++j) {
        Lanes value = load(along[0][r % S] + 4 * j);
        if constexpr (D == 3) value += load(along[1][r / S] + 4 * j);
        store(values + 4 * j, w * value);
      }
#pragma GCC unroll 16
      for (int o = 0; o < S; ++o) {
        const int f = field(r * S + o), k = row_index_[r] + o;
        mass[f][k] += w * inner_mass[o];
#pragma GCC unroll 16
        for (int c = 0; c < D; ++c) momentum[f][k][c] += values[o * D + c];
      }
    }
  }

  // gatherAffine with each node's v_i from one of n fields: fields[field(node)][i].
  template <int n, class Field>
  [[gnu::always_inline]] V gatherAffineSplit(const V* const (&fields)[n], Field&& field,
                                             M& moment) const {
    T row_values_of[row_values] = {};
    return gatherRows(
        [&](int r) {
#pragma GCC unroll 16
          for (int o = 0; o < S; ++o) {
            const V& v = fields[field(r * S + o)][row_index_[r] + o];
#pragma GCC unroll 16
            for (int c = 0; c < D; ++c) row_values_of[o * D + c] = v[c];
          }
          return static_cast<const T*>(row_values_of);
        },
        moment);
  }

  // Returns sum_i w_ip v_i and sets moment = sum_i w_ip v_i (x_i - x_p)^T, row r's values
  // (row_values scalars, node by node) at rowValues(r).
  template <class RowValues>
  [[gnu::always_inline]] V gatherRows(RowValues&& rowValues, M& moment) const {
    // Across the rows first, node by node of a row: the sums weighted by the rows' weights, and
    // by those times dx_a for each outer axis a; then along the row.
    Lanes across[D][chunks] = {};  // [0]: sum_r w_r v; [a]: sum_r w_r dx_a v
#pragma GCC unroll 16
    for (int r = 0; r < rows; ++r) {
      const T* row = rowValues(r);
      const T w = row_weight_[r];
      const T w1 = w * dx_[1][r % S], w2 = D == 3 ? w * dx_[D - 1][r / S] : T(0);
#pragma GCC unroll 16
      for (int j = 0; j < chunks; ++j) {
        const Lanes values = load(row + 4 * j);
        across[0][j] += w * values;
        across[1][j] += w1 * values;
        if constexpr (D == 3) across[2][j] += w2 * values;
      }
    }
    T sums[D][row_values];
#pragma GCC unroll 16
    for (int a = 0; a < D; ++a)
#pragma GCC unroll 16
      for (int j = 0; j < chunks; ++j) store(sums[a] + 4 * j, across[a][j]);
    V sum = V::Zero();
    moment.setZero();
#pragma GCC unroll 16
    for (int o = 0; o < S; ++o) {
      const T w0 = s_.w[0][o], w0dx = w0 * dx_[0][o];
#pragma GCC unroll 16
      for (int c = 0; c < D; ++c) {
        sum[c] += w0 * sums[0][o * D + c];
        moment(c, 0) += w0dx * sums[0][o * D + c];
#pragma GCC unroll 16
        for (int a = 1; a < D; ++a) moment(c, a) += w0 * sums[a][o * D + c];
      }
    }
    return sum;
  }

 private:
  // The value node o of row (o1, o2) takes is w_0(o) (v + A.col(0) dx_0(o)) plus w_0(o) times
  // A.col(1) dx_1(o1) and A.col(2) dx_2(o2): a row's values are along[0][o1] + along[1][o2].
  [[gnu::always_inline]] void affineParts(T m, const V& v, const M& A, T (&inner_mass)[row_nodes],
                                          T (&along)[D - 1][S][row_values]) const {
#pragma GCC unroll 16
    for (int o = 0; o < S; ++o) {
      const T w0 = s_.w[0][o];
      inner_mass[o] = w0 * m;
#pragma GCC unroll 16
      for (int c = 0; c < D; ++c) {
#pragma GCC unroll 16
        for (int o1 = 0; o1 < S; ++o1)
          along[0][o1][o * D + c] = w0 * (v[c] + A(c, 0) * dx_[0][o] + A(c, 1) * dx_[1][o1]);
        if constexpr (D == 3)
#pragma GCC unroll 16
          for (int o2 = 0; o2 < S; ++o2) along[1][o2][o * D + c] = w0 * (A(c, 2) * dx_[2][o2]);
      }
    }
  }
  static const Lanes& load(const T* p) {
    return *reinterpret_cast<const Lanes*>(p);
  }
  static void store(T* p, const Lanes& l) {
    *reinterpret_cast<Lanes*>(p) = l;
  }

  const Stencil<D, Kernel, T>& s_;
  T dx_[D][S];           // x_i - x_p along each axis
  int row_index_[rows];  // flat index of each row's first node
  T row_weight_[rows];   // prod_{a>0} w_a(o_a) of each row
};

// Calls f(node_index, weight, weight_gradient) for every node of the particle's stencil.
template <int D, class Kernel, class T, class F>
inline void forEachStencilNode(const GridGeometry<D>& grid, const Vec<D, T>& x, F&& f) {
  const T inv_h = T(1 / grid.h);
  const Stencil<D, Kernel, T> s(x, inv_h);
  visitStencil(grid, s, x, [&](const StencilVisit<D, T>& v) {
    f(v.index, s.weightAt(v.offset), s.gradientAt(v.offset, inv_h));
  });
}

// Runs f.template operator()<Kernel>() for the kernel type chosen at run time.
template <class F>
decltype(auto) withKernel(KernelType kernel, F&& f) {
  if (kernel == KernelType::Quadratic) return f.template operator()<QuadraticBSpline>();
  return f.template operator()<CubicBSpline>();
}

}  // namespace snowsim
