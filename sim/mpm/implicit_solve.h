// The semi-implicit grid velocity solve of MPM snow (Stomakhin et al. 2013, section 4 step 6 and
// eq. 9): (I + beta dt^2 M^-1 d2Phi/dx2) v^{n+1} = v*, matrix-free, by conjugate residual on the
// mass-weighted (hence symmetric) form M A v = M v*. beta = 1 backward Euler, 1/2 trapezoidal,
// 0 explicit. The hardening (J_P, so mu and lambda) is frozen within the step.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "sim/core/grid.h"
#include "sim/core/krylov.h"
#include "sim/core/particles.h"
#include "sim/mpm/snow_material.h"
#include "sim/mpm/stress_differential.h"
#include "sim/parallel/loop_runner.h"
#include "sim/scene/scene.h"

namespace snowsim {

// What the Krylov solve is preconditioned by: the node masses, or per node the D x D diagonal block
// of the constrained operator (mass plus the stiffness that couples the node's own components).
enum class ImplicitPreconditioner { NodeMass, NodeBlock };

template <int D>
class ImplicitVelocitySolve {
 public:
  // Per-step setup: active nodes (mass > 0), each particle's stencil nodes and weight gradients,
  // its linearised stress response (from F_E and the Lamé parameters its hardening gives) and the
  // stiffness's diagonal blocks. Gradients are grad w_ip for PIC/FLIP and w_ip D^-1 (x_i - x_p) for
  // APIC/MLS, the same ones the explicit force and the F_E update use. The per-particle loops of
  // this step run on `loops` (none: on the calling thread).
  void prepare(const GridGeometry<D>& grid, const GridFields<D>& fields,
               const Particles<D>& particles, const std::vector<Mat<D>>& F_E,
               const SnowMaterial& material, const std::vector<Real>& hardening,
               const MpmParams& params, Real dt, LoopRunner* loops = nullptr);

  // Replaces fields.velocity (v*, already collided) of the active nodes by the solution v^{n+1}.
  // node_free (per grid node) projects onto the velocity components the collisions left free
  // (collideAndConstrain); the others keep their collided value: the solve runs on
  // P M A P u + (I - P) M u = P (M v* - M A (I - P) v*) + (I - P) M v*, still symmetric.
  KrylovResult solve(GridFields<D>& fields, const std::vector<Mat<D>>& node_free, Real beta,
                     Real tolerance, int max_iterations,
                     ImplicitPreconditioner preconditioner = ImplicitPreconditioner::NodeBlock);

  // y = M A u = M u - beta dt df(u) over the active nodes (flat, D entries per node), with
  // df_i = -sum_p V_p^0 dP(F_E,p; dF_p) F_E,p^T g_ip and dF_p = dt (sum_i u_i g_ip^T) F_E,p.
  void applyMassWeighted(const Eigen::VectorXd& u, Eigen::VectorXd& y, Real beta) const;

  int activeNodes() const { return static_cast<int>(active_.size()); }
  // Flat vector of the active nodes' velocities, and the reverse.
  void gather(const GridFields<D>& fields, Eigen::VectorXd& u) const;
  void scatter(const Eigen::VectorXd& u, GridFields<D>& fields) const;

 private:
  // y = P M A P u + (I - P) M u, the operator with the collided components held.
  void applyConstrained(const Eigen::VectorXd& u, Eigen::VectorXd& y, Real beta) const;
  template <class Kernel>
  void prepareWith(const GridGeometry<D>& grid, const Particles<D>& particles,
                   const MpmParams& params);
  // Each active node's D x D diagonal block of the operator's stiffness part, over beta dt.
  void assembleStiffnessBlocks();
  // z = B^-1 r with B per node: P (m I + beta K_aa) P + (I - P) m, or m I where that is not
  // positive definite (compressed snow can make K_aa indefinite; the Krylov method needs an SPD
  // preconditioner).
  void invertNodeBlocks(Real beta);

  Real dt_ = 0;
  LoopRunner* loops_ = nullptr;
  int stencil_nodes_ = 0;
  std::vector<int> active_;       // grid node index of each active node
  std::vector<int> active_of_;    // grid node -> active index, or -1
  std::vector<Real> mass_;        // mass of each active node
  std::vector<int> stencil_;      // per particle, stencil_nodes_ active indices (-1: massless)
  std::vector<Vec<D>> gradient_;  // per particle, stencil_nodes_ weight gradients
  // Per particle, vec(V_p^0 dP(dF) F_E^T) as a matrix on vec(grad u), dF = dt grad u F_E: the
  // stress differential linearised once a step (hardening frozen) instead of an SVD an iteration.
  std::vector<Tangent<D>> response_;
  mutable std::vector<Mat<D>> stress_differential_;  // V_p^0 dP F_E^T per particle
  std::vector<Mat<D>> stiffness_block_;  // per active node, d(M A u)_a / du_a - m I, over beta dt
  std::vector<Mat<D>> block_inverse_;    // per active node, the preconditioner's inverse block
  std::vector<Mat<D>> free_;             // per active node: projection onto the free components
  ConjugateResidualWork work_;
  Eigen::VectorXd rhs_, x_;
  mutable Eigen::VectorXd projected_;  // P u inside applyConstrained
};

}  // namespace snowsim
