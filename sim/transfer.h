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

// Flat index of node n of a particle's stencil (base: the flat index of the stencil's first
// node), and the node's offset x_i - x_p from the particle, as APIC/MLS need it.
template <int D, class Kernel>
inline int stencilNode(const GridGeometry<D>& grid, const Stencil<D, Kernel>& s, int base, int n,
                       const Vec<D>& x, Vec<D>& dx) {
  int k = base;
  for (int a = 0; a < D; ++a) {
    const int off = s.offset(n, a);
    k += off * grid.stride[a];
    dx[a] = (s.base[a] + off) * grid.h - x[a];
  }
  return k;
}

// Runs f.template operator()<Kernel>() for the kernel type chosen at run time.
template <class F>
decltype(auto) withKernel(KernelType kernel, F&& f) {
  if (kernel == KernelType::Quadratic) return f.template operator()<QuadraticBSpline>();
  return f.template operator()<CubicBSpline>();
}

}  // namespace snowsim
