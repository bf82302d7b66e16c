// Visiting the grid nodes of one particle's B-spline stencil, shared by every solver.
#pragma once

#include <type_traits>
#include <utility>

#include "sim/bspline.h"
#include "sim/grid.h"

namespace snowsim {

// The node of a particle's stencil being visited: flat grid index, per-axis offsets into the
// stencil (for Stencil::weightAt / gradientAt) and x_i - x_p, which APIC/MLS need.
template <int D>
struct StencilVisit {
  int index;
  int offset[D];
  Vec<D> dx;
};

// Calls f(const StencilVisit<D>&) for every node of the particle's stencil, axis 0 fastest. The
// nodes are unrolled at compile time (a fold over the node numbers), so each node's offsets are
// constants: no integer division and no loop in the transfer hot loops.
template <int D, class Kernel, class F, int... Node>
inline void visitStencilNodes(const GridGeometry<D>& grid, const Stencil<D, Kernel>& s,
                              const Vec<D>& x, F&& f, std::integer_sequence<int, Node...>) {
  constexpr int S = Kernel::support;
  Real dx[D][S];
  for (int a = 0; a < D; ++a)
    for (int o = 0; o < S; ++o) dx[a][o] = (s.base[a] + o) * grid.h - x[a];
  const int base = grid.index(s.base);
  auto visit = [&]<int n>(std::integral_constant<int, n>) {
    StencilVisit<D> v;
    v.index = base;
    for (int a = 0, place = 1; a < D; ++a, place *= S) {
      v.offset[a] = n / place % S;
      v.dx[a] = dx[a][v.offset[a]];
      v.index += v.offset[a] * grid.stride[a];
    }
    f(static_cast<const StencilVisit<D>&>(v));
  };
  (visit(std::integral_constant<int, Node>{}), ...);
}

// Flattened: the per-node lambda and everything it calls are inlined into each unrolled node.
// bench/mpm_bench, one core, medians of 5 interleaved runs: 2D 5.3 -> 5.6-6.1 M particle-steps/s,
// 3D 0.93 -> 1.02 M; results bit-identical.
template <int D, class Kernel, class F>
[[gnu::flatten]] inline void visitStencilFlattened(const GridGeometry<D>& grid,
                                                   const Stencil<D, Kernel>& s, const Vec<D>& x,
                                                   F&& f) {
  visitStencilNodes(grid, s, x, std::forward<F>(f),
                    std::make_integer_sequence<int, Stencil<D, Kernel>::nodes>{});
}

template <int D, class Kernel, class F>
inline void visitStencil(const GridGeometry<D>& grid, const Stencil<D, Kernel>& s, const Vec<D>& x,
                         F&& f) {
  visitStencilFlattened(grid, s, x, std::forward<F>(f));
}

// Calls f(node_index, weight, weight_gradient) for every node of the particle's stencil.
template <int D, class Kernel, class F>
inline void forEachStencilNode(const GridGeometry<D>& grid, const Vec<D>& x, F&& f) {
  const Real inv_h = 1 / grid.h;
  const Stencil<D, Kernel> s(x, inv_h);
  visitStencil(grid, s, x, [&](const StencilVisit<D>& v) {
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
