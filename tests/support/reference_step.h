// A plain, single-threaded explicit MLS-MPM snow step, in the spirit of the 88-line MLS-MPM
// programs: one loop over the particles, one over the grid nodes, one over the particles again. It
// computes what MpmSolver does with its defaults (MLS transfers, quadratic B-splines, explicit
// integration, lattice initial volumes), only slower, and serves as its test oracle
// (tests/sim/mpm/reference_step_test.cpp). Names are the papers' symbols: Stomakhin et al. 2013, "A
// Material Point Method for Snow Simulation" (section 4's steps, section 5's model); Jiang et al.
// 2015, "The Affine Particle-In-Cell Method" (APIC); Hu et al. 2018, "A Moving Least Squares
// Material Point Method" (MLS-MPM).
#pragma once

#include <vector>

#include "sim/core/bspline.h"
#include "sim/core/collider.h"
#include "sim/core/grid.h"
#include "sim/core/particles.h"
#include "sim/mpm/snow_material.h"
#include "sim/scene/scene.h"

namespace snowsim {

template <int D>
struct ReferenceState {
  // Per particle, in the order of the particles it was made from.
  std::vector<Vec<D>> x;    // position, m
  std::vector<Vec<D>> v;    // velocity, m/s
  std::vector<Real> m;      // mass, kg
  std::vector<Real> V0;     // initial volume V_p^0, m^D
  std::vector<Mat<D>> F_E;  // elastic deformation gradient
  std::vector<Mat<D>> C;    // affine velocity, also grad v (MLS)
  std::vector<Real> J_P;    // det F_P, plastic volume ratio
  // Per grid node (GridGeometry's nodes, ghosts included): mass, then momentum, then velocity.
  GridGeometry<D> grid;
  std::vector<Real> grid_m;
  std::vector<Vec<D>> grid_v;
  SnowMaterial material;
  Vec<D> g;                            // gravity, m/s^2
  std::vector<Collider<D>> colliders;  // the domain walls first (makeColliders), placed at `time`
  Real time = 0;                       // s
};

// The state of `particles` at rest in `scene`'s grid, V_p^0 = m_p / rho_body (the lattice volume).
// Throws InputError unless scene.mpm asks for MLS, quadratic, explicit and lattice volumes.
template <int D>
ReferenceState<D> makeReferenceState(const Scene& scene, const Particles<D>& particles);

// f(k, w_ip, x_i - x_p) for the 3^D nodes i of the quadratic B-spline stencil of a particle at x,
// written plainly so that it checks the solver's stencil code rather than sharing it:
// w_ip = prod_a N(x_a / h - i_a) (Stomakhin et al. 2013, eqs. 5-6, with quadratic N).
template <int D, class F>
inline void forEachReferenceNode(const GridGeometry<D>& grid, const Vec<D>& x, F&& f) {
  Real w[D][3], dw[D][3];
  IVec<D> base;
  for (int a = 0; a < D; ++a) base[a] = QuadraticBSpline::weights(x[a] / grid.h, w[a], dw[a]);
  const int nodes = D == 2 ? 9 : 27;
  for (int n = 0; n < nodes; ++n) {
    IVec<D> i;
    Real w_ip = 1;
    for (int a = 0, rest = n; a < D; ++a, rest /= 3) {
      i[a] = base[a] + rest % 3;
      w_ip *= w[a][rest % 3];
    }
    f(grid.index(i), w_ip, Vec<D>(grid.position(i) - x));
  }
}

// One explicit MLS-MPM step of dt seconds.
template <int D>
void referenceStep(ReferenceState<D>& s, Real dt);

}  // namespace snowsim
