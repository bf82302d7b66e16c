// Visiting the grid nodes of one particle's B-spline stencil, shared by every solver.
#pragma once

#include <type_traits>
#include <utility>

#include "sim/core/bspline.h"
#include "sim/core/grid.h"

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

// Sanitized builds leave it out: instrumented, the flattened transfers take GCC over 11 minutes
// to compile (CMakeLists.txt). Inlining changes no result.
#ifdef SNOWSIM_SANITIZED
#define SNOWSIM_FLATTEN
#else
#define SNOWSIM_FLATTEN [[gnu::flatten]]
#endif

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
// factor axis by axis: a scatter builds v + A (x_i - x_p) = v + sum_a A.col(a) dx_a(o_a) one axis
// at a time, and a gather sums a row of the innermost axis before weighting it by the outer axes.
// Per node this costs a few additions where the node-by-node visit above costs a D x D
// matrix-vector product.
template <int D, class Kernel, class T = Real>
class TensorStencil {
 public:
  static constexpr int S = Kernel::support;
  using V = Vec<D, T>;
  using M = Mat<D, T>;

  TensorStencil(const GridGeometry<D>& grid, const Stencil<D, Kernel, T>& s, const V& x)
      : s_(s), base_(grid.index(s.base)) {
    for (int a = 0; a < D; ++a) {
      stride_[a] = grid.stride[a];
      for (int o = 0; o < S; ++o) dx_[a][o] = T(s.base[a] + o) * T(grid.h) - x[a];
    }
  }

  // Calls scatter(node_index, w_ip, v + A (x_i - x_p)) for every node of the stencil.
  template <class Scatter>
  void scatterAffine(const V& v, const M& A, Scatter&& scatter) const {
    V term[D][S];  // A.col(a) dx_a(o)
    for (int a = 0; a < D; ++a)
      for (int o = 0; o < S; ++o) term[a][o] = A.col(a) * dx_[a][o];
    scatterAxis<D - 1>(base_, T(1), v, term, scatter);
  }

  // Returns sum_i w_ip v_i and sets moment = sum_i w_ip v_i (x_i - x_p)^T (APIC's B_p, Jiang et
  // al. 2015, eq. 10), v_i = field[i].
  V gatherAffine(const V* field, M& moment) const {
    V sum;
    gatherAxis<D - 1>(base_, field, sum, moment);
    return sum;
  }

 private:
  template <int a, class Scatter>
  void scatterAxis(int index, T w, const V& value, const V (&term)[D][S], Scatter& scatter) const {
#pragma GCC unroll 4
    for (int o = 0; o < S; ++o) {
      const int k = index + o * stride_[a];
      const T wo = w * s_.w[a][o];
      const V vo = value + term[a][o];
      if constexpr (a == 0)
        scatter(k, wo, vo);
      else
        scatterAxis<a - 1>(k, wo, vo, term, scatter);
    }
  }

  // sum = sum_o w_a(o) (the sum of the axes below), moment's first a + 1 columns likewise, column a
  // taking the factor dx_a(o).
  template <int a>
  void gatherAxis(int index, const V* field, V& sum, M& moment) const {
    sum.setZero();
    moment.setZero();
#pragma GCC unroll 4
    for (int o = 0; o < S; ++o) {
      const int k = index + o * stride_[a];
      const T w = s_.w[a][o];
      if constexpr (a == 0) {
        const V& v = field[k];
        sum += w * v;
        moment.col(0) += (w * dx_[0][o]) * v;
      } else {
        V inner_sum;
        M inner_moment;
        gatherAxis<a - 1>(k, field, inner_sum, inner_moment);
        sum += w * inner_sum;
        moment.template leftCols<a>() += w * inner_moment.template leftCols<a>();
        moment.col(a) += (w * dx_[a][o]) * inner_sum;
      }
    }
  }

  const Stencil<D, Kernel, T>& s_;
  int base_;
  int stride_[D];
  T dx_[D][S];  // x_i - x_p along each axis
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
