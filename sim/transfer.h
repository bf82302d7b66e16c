// Visiting the grid nodes of one particle's B-spline stencil, shared by every solver.
#pragma once

#include "sim/bspline.h"
#include "sim/grid.h"

namespace snowsim {

// Calls f(node_index, weight, weight_gradient) for every node of the particle's stencil.
template <int D, class Kernel, class F>
inline void forEachStencilNode(const GridGeometry<D>& grid, const Vec<D>& x, F&& f) {
  const Real inv_h = 1 / grid.h;
  const Stencil<D, Kernel> s(x, inv_h);
  const int base = grid.index(s.base);
  for (int n = 0; n < s.nodes; ++n) {
    int k = base;
    for (int a = 0; a < D; ++a) k += s.offset(n, a) * grid.stride[a];
    f(k, s.weight(n), s.gradient(n, inv_h));
  }
}

// Runs f.template operator()<Kernel>() for the kernel type chosen at run time.
template <class F>
decltype(auto) withKernel(KernelType kernel, F&& f) {
  if (kernel == KernelType::Quadratic) return f.template operator()<QuadraticBSpline>();
  return f.template operator()<CubicBSpline>();
}

}  // namespace snowsim
