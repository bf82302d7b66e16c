// Small fixed-size linear algebra shared by every solver, templated on dimension.
#pragma once

#include <Eigen/Dense>

namespace snowsim {

using Real = double;

// T: the scalar of a state kept in single precision (MPM's mpm.precision), double elsewhere.
template <int D, class T = Real>
using Vec = Eigen::Matrix<T, D, 1>;
template <int D, class T = Real>
using Mat = Eigen::Matrix<T, D, D>;
template <int D>
using IVec = Eigen::Matrix<int, D, 1>;

}  // namespace snowsim
