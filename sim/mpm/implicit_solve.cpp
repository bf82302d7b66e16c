#include "sim/mpm/implicit_solve.h"

#include <Eigen/Cholesky>
#include <algorithm>

#include "sim/core/stencil.h"
#include "sim/mpm/stress_differential.h"
#include "sim/mpm/transfer_scheme.h"

namespace snowsim {

template <int D>
void ImplicitVelocitySolve<D>::prepare(const GridGeometry<D>& grid, const GridFields<D>& fields,
                                       const Particles<D>& particles,
                                       const std::vector<Mat<D>>& F_E, const SnowMaterial& material,
                                       const std::vector<Real>& hardening, const MpmParams& params,
                                       Real dt, LoopRunner* loops) {
  dt_ = dt;
  loops_ = loops;
  const int nodes = grid.nodeCount();
  active_of_.assign(nodes, -1);
  active_.clear();
  mass_.clear();
  for (int k = 0; k < nodes; ++k)
    if (fields.mass[k] > 0) {
      active_of_[k] = static_cast<int>(active_.size());
      active_.push_back(k);
      mass_.push_back(fields.mass[k]);
    }
  stress_differential_.resize(particles.size());
  response_.resize(particles.size());
  parallelFor(loops_, particles.size(), [&](int p) {
    // Column j: G = e_j (a unit grad u), dF = dt G F_E, vec(V_p^0 dP(dF) F_E^T).
    const Mat<D>& F = F_E[p];
    const Tangent<D> C = fixedCorotatedPiolaTangent<D>(F, lameOf(material, hardening[p]));
    for (int j = 0; j < D * D; ++j) {
      Mat<D> G = Mat<D>::Zero();
      G(j % D, j / D) = 1;
      const Mat<D> dF = dt * G * F;
      Mat<D> dP;
      Eigen::Map<Eigen::Matrix<Real, D * D, 1>>(dP.data()) =
          C * Eigen::Map<const Eigen::Matrix<Real, D * D, 1>>(dF.data());
      const Mat<D> S = particles.volume[p] * dP * F.transpose();
      response_[p].col(j) = Eigen::Map<const Eigen::Matrix<Real, D * D, 1>>(S.data());
    }
  });
  withKernel(params.kernel, [&]<class Kernel>() { prepareWith<Kernel>(grid, particles, params); });
  assembleStiffnessBlocks();
  const Eigen::Index n = static_cast<Eigen::Index>(active_.size()) * D;
  rhs_.resize(n);
  x_.resize(n);
  projected_.resize(n);
  work_.resize(n);
}

template <int D>
template <class Kernel>
void ImplicitVelocitySolve<D>::prepareWith(const GridGeometry<D>& grid,
                                           const Particles<D>& particles, const MpmParams& params) {
  const Real h = grid.h, inv_h = 1 / h;
  const Real D_inv = inertiaInverse<Kernel>(h);
  const bool affine = params.transfer != MpmTransfer::PicFlip;
  const int n = particles.size();
  stencil_nodes_ = Stencil<D, Kernel>::nodes;
  stencil_.resize(static_cast<size_t>(n) * stencil_nodes_);
  gradient_.resize(stencil_.size());
  parallelFor(loops_, n, [&](int p) {
    const Vec<D>& x = particles.x[p];
    const Stencil<D, Kernel> s(x, inv_h);
    size_t e = static_cast<size_t>(p) * stencil_nodes_;
    visitStencil(grid, s, x, [&](const StencilVisit<D>& node) {
      stencil_[e] = active_of_[node.index];
      gradient_[e] = affine ? Vec<D>(s.weightAt(node.offset) * D_inv * node.dx)
                            : Vec<D>(s.gradientAt(node.offset, inv_h));
      ++e;
    });
  });
}

template <int D>
void ImplicitVelocitySolve<D>::assembleStiffnessBlocks() {
  // u = e_c at node a alone: grad u = e_c g^T, and the particle adds S g to (M A u)_a / (beta dt)
  // with vec(S) = R vec(grad u), so block(r, c) += sum_{k,l} R[r + D k, c + D l] g_k g_l. Serial,
  // in particle order, so the sums are the same for any thread count.
  // resize, not assign: grows by doubling like the other per-node buffers, so a step allocates
  // nothing once the contact area has stopped growing.
  stiffness_block_.resize(active_.size());
  std::fill(stiffness_block_.begin(), stiffness_block_.end(), Mat<D>::Zero());
  const int S = stencil_nodes_;
  for (size_t p = 0; p < response_.size(); ++p) {
    const Tangent<D>& R = response_[p];
    for (int nd = 0; nd < S; ++nd) {
      const size_t e = p * S + nd;
      if (stencil_[e] < 0) continue;
      const Vec<D>& g = gradient_[e];
      Mat<D>& block = stiffness_block_[stencil_[e]];
      for (int c = 0; c < D; ++c)
        for (int l = 0; l < D; ++l)
          for (int k = 0; k < D; ++k)
            block.col(c) += (g[k] * g[l]) * R.col(c + D * l).template segment<D>(D * k);
    }
  }
}

template <int D>
void ImplicitVelocitySolve<D>::invertNodeBlocks(Real beta) {
  const int active = activeNodes();
  block_inverse_.resize(active);
  for (int a = 0; a < active; ++a) {
    const Mat<D>& P = free_[a];
    const Mat<D> I = Mat<D>::Identity();
    const Mat<D> block =
        P * (mass_[a] * I + beta * dt_ * stiffness_block_[a]) * P + mass_[a] * (I - P);
    // Symmetrised: the block of a symmetric operator, up to round-off.
    const Eigen::LLT<Mat<D>> llt(Real(0.5) * (block + block.transpose()));
    block_inverse_[a] = llt.info() == Eigen::Success ? Mat<D>(llt.solve(I)) : Mat<D>(I / mass_[a]);
  }
}

template <int D>
void ImplicitVelocitySolve<D>::applyMassWeighted(const Eigen::VectorXd& u, Eigen::VectorXd& y,
                                                 Real beta) const {
  const int n = static_cast<int>(response_.size());
  const int S = stencil_nodes_;
  // Per particle (parallel, independent): grad u = sum_i u_i g_ip^T, then V_p^0 dP F^T from the
  // particle's response to it.
  parallelFor(loops_, n, [&](int p) {
    Mat<D> grad_u = Mat<D>::Zero();
    for (int nd = 0; nd < S; ++nd) {
      const size_t e = static_cast<size_t>(p) * S + nd;
      if (stencil_[e] < 0) continue;
      grad_u += u.template segment<D>(static_cast<Eigen::Index>(stencil_[e]) * D) *
                gradient_[e].transpose();
    }
    Eigen::Map<Eigen::Matrix<Real, D * D, 1>>(stress_differential_[p].data()).noalias() =
        response_[p] * Eigen::Map<const Eigen::Matrix<Real, D * D, 1>>(grad_u.data());
  });
  // y = M u - beta dt df, df_i = -sum_p (V dP F^T)_p g_ip; serial scatter keeps the sum order
  // fixed.
  const int active = activeNodes();
  for (int a = 0; a < active; ++a)
    y.template segment<D>(static_cast<Eigen::Index>(a) * D) =
        mass_[a] * u.template segment<D>(static_cast<Eigen::Index>(a) * D);
  for (int p = 0; p < n; ++p)
    for (int nd = 0; nd < S; ++nd) {
      const size_t e = static_cast<size_t>(p) * S + nd;
      if (stencil_[e] < 0) continue;
      y.template segment<D>(static_cast<Eigen::Index>(stencil_[e]) * D) +=
          beta * dt_ * (stress_differential_[p] * gradient_[e]);
    }
}

template <int D>
void ImplicitVelocitySolve<D>::gather(const GridFields<D>& fields, Eigen::VectorXd& u) const {
  for (size_t a = 0; a < active_.size(); ++a)
    u.template segment<D>(static_cast<Eigen::Index>(a) * D) = fields.velocity[active_[a]];
}

template <int D>
void ImplicitVelocitySolve<D>::scatter(const Eigen::VectorXd& u, GridFields<D>& fields) const {
  for (size_t a = 0; a < active_.size(); ++a)
    fields.velocity[active_[a]] = u.template segment<D>(static_cast<Eigen::Index>(a) * D);
}

template <int D>
void ImplicitVelocitySolve<D>::applyConstrained(const Eigen::VectorXd& u, Eigen::VectorXd& y,
                                                Real beta) const {
  const int active = activeNodes();
  for (int a = 0; a < active; ++a) {
    const Eigen::Index i = static_cast<Eigen::Index>(a) * D;
    projected_.template segment<D>(i) = free_[a] * u.template segment<D>(i);
  }
  applyMassWeighted(projected_, y, beta);
  for (int a = 0; a < active; ++a) {
    const Eigen::Index i = static_cast<Eigen::Index>(a) * D;
    const Vec<D> held = u.template segment<D>(i) - projected_.template segment<D>(i);
    y.template segment<D>(i) = free_[a] * y.template segment<D>(i) + mass_[a] * held;
  }
}

template <int D>
KrylovResult ImplicitVelocitySolve<D>::solve(GridFields<D>& fields,
                                             const std::vector<Mat<D>>& node_free, Real beta,
                                             Real tolerance, int max_iterations,
                                             ImplicitPreconditioner preconditioner) {
  const int active = activeNodes();
  free_.resize(active);
  for (int a = 0; a < active; ++a) free_[a] = node_free[active_[a]];
  // Right-hand side P (M v* - M A (I - P) v*) + (I - P) M v*, with v* (collided) as the start:
  // it already holds the collided components (paper section 9: conjugate residual).
  gather(fields, x_);
  for (int a = 0; a < active; ++a) {
    const Eigen::Index i = static_cast<Eigen::Index>(a) * D;
    projected_.template segment<D>(i) =
        x_.template segment<D>(i) - free_[a] * x_.template segment<D>(i);
  }
  applyMassWeighted(projected_, rhs_, beta);  // M A (I - P) v*
  for (int a = 0; a < active; ++a) {
    const Eigen::Index i = static_cast<Eigen::Index>(a) * D;
    const Vec<D> Mv = mass_[a] * x_.template segment<D>(i);
    rhs_.template segment<D>(i) =
        free_[a] * (Mv - rhs_.template segment<D>(i)) + (Mv - free_[a] * Mv);
  }
  // Preconditioned per node: the masses span orders of magnitude between the snow's inside and
  // its surface, and where the snow is stiff the stiffness's diagonal block outweighs the mass
  // (docs/mpm.md has the iteration counts of each).
  const bool by_block = preconditioner == ImplicitPreconditioner::NodeBlock;
  if (by_block) invertNodeBlocks(beta);
  const auto precondition = [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) {
    for (int a = 0; a < active; ++a) {
      const Eigen::Index i = static_cast<Eigen::Index>(a) * D;
      if (by_block)
        z.template segment<D>(i).noalias() = block_inverse_[a] * r.template segment<D>(i);
      else
        z.template segment<D>(i) = r.template segment<D>(i) / mass_[a];
    }
  };
  const KrylovResult result = conjugateResidual(
      [&](const Eigen::VectorXd& u, Eigen::VectorXd& y) { applyConstrained(u, y, beta); },
      precondition, rhs_, x_, tolerance, max_iterations, work_);
  scatter(x_, fields);
  return result;
}

template class ImplicitVelocitySolve<2>;
template class ImplicitVelocitySolve<3>;

}  // namespace snowsim
