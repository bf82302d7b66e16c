// B-spline interpolation weights of MPM (Stomakhin et al. 2013, eq. 5-6), one axis at a time.
// Nodes sit at i*h. A kernel gives, for a particle at X = x/h, the first node of its stencil and
// the weight N(X - i) and its derivative dN/dX for each node of the stencil.
#pragma once

#include <cmath>

#include "sim/core/math.h"

namespace snowsim {

enum class KernelType { Quadratic, Cubic };

struct QuadraticBSpline {
  static constexpr int support = 3;
  // N(x) = 3/4 - x^2 for |x| < 1/2; (3/2 - |x|)^2 / 2 for 1/2 <= |x| < 3/2.
  template <class T>
  static int weights(T X, T w[3], T dw[3]) {
    const int base = static_cast<int>(std::floor(X - T(0.5)));
    const T fx = X - T(base);  // in [0.5, 1.5)
    w[0] = T(0.5) * (T(1.5) - fx) * (T(1.5) - fx);
    w[1] = T(0.75) - (fx - 1) * (fx - 1);
    w[2] = T(0.5) * (fx - T(0.5)) * (fx - T(0.5));
    dw[0] = fx - T(1.5);
    dw[1] = -2 * (fx - 1);
    dw[2] = fx - T(0.5);
    return base;
  }
};

struct CubicBSpline {
  static constexpr int support = 4;
  // N(x) = |x|^3/2 - x^2 + 2/3 for |x| < 1; -|x|^3/6 + x^2 - 2|x| + 4/3 for 1 <= |x| < 2.
  template <class T>
  static T value(T x) {
    const T a = std::abs(x);
    if (a < 1) return T(0.5) * a * a * a - a * a + T(2) / 3;
    if (a < 2) return -a * a * a / 6 + a * a - 2 * a + T(4) / 3;
    return 0;
  }
  template <class T>
  static T derivative(T x) {
    const T a = std::abs(x);
    const T s = x < 0 ? T(-1) : T(1);
    if (a < 1) return T(1.5) * x * a - 2 * x;
    if (a < 2) return T(-0.5) * x * a + 2 * x - 2 * s;
    return 0;
  }
  template <class T>
  static int weights(T X, T w[4], T dw[4]) {
    const int base = static_cast<int>(std::floor(X)) - 1;
    for (int k = 0; k < 4; ++k) {
      const T d = X - T(base + k);
      w[k] = value(d);
      dw[k] = derivative(d);
    }
    return base;
  }
};

// The weights of one particle over its whole D-dimensional stencil, kept per axis, in the
// precision T of the particle's state.
template <int D, class Kernel, class T = Real>
struct Stencil {
  using Scalar = T;
  static constexpr int support = Kernel::support;
  static constexpr int nodes = D == 2 ? support * support : support * support * support;
  IVec<D> base;
  T w[D][support];
  T dw[D][support];  // dN/dX, in units of 1/h

  Stencil(const Vec<D, T>& x, T inv_h) {
    for (int a = 0; a < D; ++a) base[a] = Kernel::weights(x[a] * inv_h, w[a], dw[a]);
  }

  // The weight and its gradient (eq. 6, in 1/m) at the node with per-axis offsets o.
  T weightAt(const int (&o)[D]) const {
    T r = 1;
    for (int a = 0; a < D; ++a) r *= w[a][o[a]];
    return r;
  }
  Vec<D, T> gradientAt(const int (&o)[D], T inv_h) const {
    Vec<D, T> g;
    for (int a = 0; a < D; ++a) {
      T r = dw[a][o[a]] * inv_h;
      for (int b = 0; b < D; ++b)
        if (b != a) r *= w[b][o[b]];
      g[a] = r;
    }
    return g;
  }
};

// Calls f(i, j, k, w) for each node (i h, j h, k h) of the 3D quadratic stencil of a point x (m),
// w = N(x/h - i) N(y/h - j) N(z/h - k): the weights w_ip a particle's mass is transferred with,
// for rasterising particles outside the solver (the VDB export, the renderer's snow volume).
template <class Point, class F>
void forEachQuadraticNode(const Point& x, double h, F&& f) {
  double w[3][3], dw[3][3];
  int base[3];
  for (int a = 0; a < 3; ++a) base[a] = QuadraticBSpline::weights(x[a] / h, w[a], dw[a]);
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i)
        f(base[0] + i, base[1] + j, base[2] + k, w[0][i] * w[1][j] * w[2][k]);
}

}  // namespace snowsim
