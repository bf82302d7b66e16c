// Small fixed-size linear algebra shared by every solver, templated on dimension.
#pragma once

#include <array>

#include <Eigen/Dense>

namespace snowsim {

using Real = double;

// A point or vector as a scene describes it: x, y and z whatever the dimension (z unused in 2D).
using Vec3 = std::array<double, 3>;

// T: the scalar of a state kept in single precision (MPM's mpm.precision), double elsewhere.
template <int D, class T = Real>
using Vec = Eigen::Matrix<T, D, 1>;
template <int D, class T = Real>
using Mat = Eigen::Matrix<T, D, D>;
template <int D>
using IVec = Eigen::Matrix<int, D, 1>;

// A symmetric D x D matrix kept by its entries on and above the diagonal, row by row: two thirds
// of a full one in 3D, for the per-particle arrays that hold a stress.
template <int D, class T = Real>
struct Symmetric {
  static constexpr int entries = D * (D + 1) / 2;
  std::array<T, entries> upper{};

  Mat<D, T> matrix() const {
    Mat<D, T> A;
    for (int i = 0, k = 0; i < D; ++i)
      for (int j = i; j < D; ++j) A(i, j) = A(j, i) = upper[k++];
    return A;
  }
};

}  // namespace snowsim
