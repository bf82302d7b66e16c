// Small fixed-size linear algebra shared by every solver, templated on dimension.
#pragma once

#include <Eigen/Dense>

namespace snowsim {

using Real = double;

template <int D>
using Vec = Eigen::Matrix<Real, D, 1>;
template <int D>
using Mat = Eigen::Matrix<Real, D, D>;
template <int D>
using IVec = Eigen::Matrix<int, D, 1>;

}  // namespace snowsim
