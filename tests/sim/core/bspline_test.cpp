// B-spline weights: partition of unity, zero-sum gradients, linear reproduction, and gradients
// that match finite differences.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "sim/core/bspline.h"
#include "sim/core/stencil.h"

namespace snowsim {
namespace {

template <class Kernel>
void checkAxisWeights() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<Real> position(-3.0, 13.0);
  for (int trial = 0; trial < 1000; ++trial) {
    const Real X = position(rng);
    Real w[Kernel::support], dw[Kernel::support];
    const int base = Kernel::weights(X, w, dw);
    Real sum = 0, gradient_sum = 0, first_moment = 0;
    for (int k = 0; k < Kernel::support; ++k) {
      EXPECT_GE(w[k], 0);
      sum += w[k];
      gradient_sum += dw[k];
      first_moment += w[k] * (base + k);
    }
    EXPECT_NEAR(sum, 1, 1e-14);
    EXPECT_NEAR(gradient_sum, 0, 1e-13);
    EXPECT_NEAR(first_moment, X, 1e-12) << "B-splines reproduce linear functions";

    // dN/dX against a central difference of the weights at the same base node.
    const Real e = 1e-6;
    Real wp[Kernel::support], wm[Kernel::support], unused[Kernel::support];
    if (Kernel::weights(X + e, wp, unused) != base || Kernel::weights(X - e, wm, unused) != base)
      continue;
    for (int k = 0; k < Kernel::support; ++k) EXPECT_NEAR(dw[k], (wp[k] - wm[k]) / (2 * e), 1e-6);
  }
}

TEST(BSpline, QuadraticWeightsSumToOneGradientsToZero) {
  checkAxisWeights<QuadraticBSpline>();
}
TEST(BSpline, CubicWeightsSumToOneGradientsToZero) {
  checkAxisWeights<CubicBSpline>();
}

TEST(BSpline, CubicMatchesThePaperFormula) {
  // Stomakhin et al. 2013, eq. 5, at a few hand-checked points.
  EXPECT_DOUBLE_EQ(CubicBSpline::value(0.0), 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(CubicBSpline::value(1.0), 1.0 / 6.0);
  EXPECT_NEAR(CubicBSpline::value(-1.5), 1.0 / 48.0, 1e-15);
  EXPECT_DOUBLE_EQ(CubicBSpline::value(2.0), 0);
}

// Over a stencil visit (sim/core/stencil.h): the weights sum to one, their gradients to zero, the
// first moment sum w_i (x_i - x_p) vanishes, and each visited node is where dx says it is.
// The nodes are collected first: visitStencil flattens its callback, and a callback full of
// EXPECT machinery takes the compiler minutes and gigabytes with debug information.
template <int D, class Kernel>
std::vector<StencilVisit<D>> visitedNodes(const GridGeometry<D>& grid, const Stencil<D, Kernel>& s,
                                          const Vec<D>& x) {
  std::vector<StencilVisit<D>> nodes;
  nodes.reserve(s.nodes);
  visitStencil(grid, s, x, [&](const StencilVisit<D>& node) { nodes.push_back(node); });
  return nodes;
}

template <int D, class Kernel>
void checkStencil() {
  std::mt19937 rng(11);
  std::uniform_real_distribution<Real> position(0.0, 0.1);
  const Real h = 0.01;
  const GridGeometry<D> grid(IVec<D>::Constant(10), h);
  for (int trial = 0; trial < 200; ++trial) {
    Vec<D> x;
    for (int a = 0; a < D; ++a) x[a] = position(rng);
    const Stencil<D, Kernel> s(x, 1 / h);
    Real sum = 0;
    Vec<D> gradient_sum = Vec<D>::Zero(), first_moment = Vec<D>::Zero();
    const std::vector<StencilVisit<D>> nodes = visitedNodes(grid, s, x);
    for (const StencilVisit<D>& node : nodes) {
      const Real w = s.weightAt(node.offset);
      sum += w;
      gradient_sum += s.gradientAt(node.offset, 1 / h);
      first_moment += w * node.dx;
      EXPECT_LT((grid.position(grid.coords(node.index)) - x - node.dx).norm(), 1e-15);
    }
    EXPECT_EQ(static_cast<int>(nodes.size()), s.nodes);
    EXPECT_NEAR(sum, 1, 1e-13);
    EXPECT_LT(gradient_sum.norm(), 1e-10);
    EXPECT_LT(first_moment.norm(), 1e-12);
  }
}

TEST(BSpline, StencilPartitionOfUnity2DQuadratic) {
  checkStencil<2, QuadraticBSpline>();
}
TEST(BSpline, StencilPartitionOfUnity2DCubic) {
  checkStencil<2, CubicBSpline>();
}
TEST(BSpline, StencilPartitionOfUnity3DQuadratic) {
  checkStencil<3, QuadraticBSpline>();
}
TEST(BSpline, StencilPartitionOfUnity3DCubic) {
  checkStencil<3, CubicBSpline>();
}

// The crack opening's transfers of TensorStencil against the node-by-node definitions, node n
// being the n-th visited (axis 0 fastest, as rows): the nodes with their weights; a scatter of
// scalars; the moment and the largest of a scalar field (the first components of field); the
// affine scatter and gather split between two fields, node n in field n % 2.
template <int D, class Kernel>
void checkTensorStencilByField(const GridGeometry<D>& grid, const Stencil<D, Kernel>& s,
                               const Vec<D>& x, const TensorStencil<D, Kernel>& tensor,
                               const std::vector<Vec<D>>& field, Real m, const Vec<D>& v,
                               const Mat<D>& A) {
  const std::vector<StencilVisit<D>> nodes = visitedNodes(grid, s, x);
  std::vector<Real> scalar(grid.nodeCount()), first(grid.nodeCount(), 0), second = first;
  for (int k = 0; k < grid.nodeCount(); ++k) scalar[k] = field[k][0];
  std::vector<Real> mass[2] = {first, first};
  std::vector<Vec<D>> momentum[2] = {std::vector<Vec<D>>(grid.nodeCount(), Vec<D>::Zero()),
                                     std::vector<Vec<D>>(grid.nodeCount(), Vec<D>::Zero())};
  const std::vector<Vec<D>> other(grid.nodeCount(), Vec<D>::Constant(2));
  int n = 0;
  tensor.forEachNode([&](int k, Real w, const Vec<D>& dx) {
    EXPECT_EQ(k, nodes[n].index);
    EXPECT_NEAR(w, s.weightAt(nodes[n].offset), 1e-15);
    EXPECT_LT((dx - nodes[n].dx).norm(), 1e-15);
    ++n;
  });
  EXPECT_EQ(n, s.nodes);
  tensor.scatterScalars({m, 2 * m}, {first.data(), second.data()});
  const auto split = [](int node) { return node % 2; };
  tensor.scatterAffineSplit(m, v, A, {mass[0].data(), mass[1].data()},
                            {momentum[0].data(), momentum[1].data()}, split);
  Mat<D> moment;
  const Vec<D> gathered = tensor.gatherAffineSplit({field.data(), other.data()}, split, moment);
  Vec<D> scalar_moment = Vec<D>::Zero(), sum = Vec<D>::Zero();
  Mat<D> expected_moment = Mat<D>::Zero();
  Real largest = scalar[nodes[0].index];
  for (int i = 0; i < s.nodes; ++i) {
    const int k = nodes[i].index, f = i % 2;
    const Real w = s.weightAt(nodes[i].offset);
    EXPECT_NEAR(first[k], w * m, 1e-15);
    EXPECT_NEAR(second[k], 2 * w * m, 1e-15);
    EXPECT_NEAR(mass[f][k], w * m, 1e-15);
    EXPECT_EQ(mass[1 - f][k], 0);
    EXPECT_LT((momentum[f][k] - w * (v + A * nodes[i].dx)).norm(), 1e-14);
    EXPECT_EQ(momentum[1 - f][k], Vec<D>::Zero());
    scalar_moment += w * scalar[k] * nodes[i].dx;
    largest = std::max(largest, scalar[k]);
    const Vec<D>& v_i = f == 0 ? field[k] : other[k];
    sum += w * v_i;
    expected_moment += w * v_i * nodes[i].dx.transpose();
  }
  EXPECT_LT((tensor.gatherScalarMoment(scalar.data()) - scalar_moment).norm(), 1e-16);
  EXPECT_EQ(tensor.largest(scalar.data()), largest);
  EXPECT_LT((gathered - sum).norm(), 1e-14);
  EXPECT_LT((moment - expected_moment).norm(), 1e-16);
}

// The tensor-product scatter and gather (TensorStencil) against the node-by-node definitions:
// scatter adds w_ip m to each node's mass and w_ip (v + A (x_i - x_p)) to its momentum, and to no
// other node; gather gives sum_i w_ip v_i and sum_i w_ip v_i (x_i - x_p)^T, for a random grid
// field.
template <int D, class Kernel>
void checkTensorStencil() {
  std::mt19937 rng(13);
  std::uniform_real_distribution<Real> position(0.0, 0.1), value(-1.0, 1.0);
  const Real h = 0.01;
  const GridGeometry<D> grid(IVec<D>::Constant(10), h);
  std::vector<Vec<D>> field(grid.nodeCount());
  for (Vec<D>& f : field)
    for (int a = 0; a < D; ++a) f[a] = value(rng);
  for (int trial = 0; trial < 100; ++trial) {
    Vec<D> x, v;
    Mat<D> A;
    for (int a = 0; a < D; ++a) {
      x[a] = position(rng);
      v[a] = value(rng);
      for (int b = 0; b < D; ++b) A(a, b) = value(rng);
    }
    const Real m = 1 + value(rng);
    const Stencil<D, Kernel> s(x, 1 / h);
    const TensorStencil<D, Kernel> tensor(grid, s, x);

    std::vector<Real> mass(grid.nodeCount(), 0);
    std::vector<Vec<D>> momentum(grid.nodeCount(), Vec<D>::Zero());
    tensor.scatterAffine(m, v, A, mass.data(), momentum.data());

    Vec<D> sum = Vec<D>::Zero();
    Mat<D> moment = Mat<D>::Zero();
    int n = 0;
    for (const StencilVisit<D>& node : visitedNodes(grid, s, x)) {
      const Real w = s.weightAt(node.offset);
      EXPECT_NEAR(mass[node.index], w * m, 1e-15);
      EXPECT_LT((momentum[node.index] - w * (v + A * node.dx)).norm(), 1e-14);
      mass[node.index] = 0;
      momentum[node.index].setZero();
      sum += w * field[node.index];
      moment += w * field[node.index] * node.dx.transpose();
      ++n;
    }
    EXPECT_EQ(n, s.nodes);
    for (int k = 0; k < grid.nodeCount(); ++k) {  // no node outside the stencil written
      ASSERT_EQ(mass[k], 0);
      ASSERT_EQ(momentum[k], Vec<D>::Zero());
    }
    Mat<D> gathered_moment;
    const Vec<D> gathered_sum = tensor.gatherAffine(field.data(), gathered_moment);
    EXPECT_LT((gathered_sum - sum).norm(), 1e-14);
    EXPECT_LT((gathered_moment - moment).norm(), 1e-16);  // moments scale with h ~ 1e-2
    checkTensorStencilByField(grid, s, x, tensor, field, m, v, A);
  }
}

TEST(BSpline, TensorStencilMatchesNodeByNode2DQuadratic) {
  checkTensorStencil<2, QuadraticBSpline>();
}
TEST(BSpline, TensorStencilMatchesNodeByNode2DCubic) {
  checkTensorStencil<2, CubicBSpline>();
}
TEST(BSpline, TensorStencilMatchesNodeByNode3DQuadratic) {
  checkTensorStencil<3, QuadraticBSpline>();
}
TEST(BSpline, TensorStencilMatchesNodeByNode3DCubic) {
  checkTensorStencil<3, CubicBSpline>();
}

}  // namespace
}  // namespace snowsim
