#include "tests/support/reference_step.h"

#include <algorithm>

#include "sim/core/errors.h"
#include "sim/scene/scene_colliders.h"
#include "sim/solver.h"

namespace snowsim {

template <int D>
ReferenceState<D> makeReferenceState(const Scene& scene, const Particles<D>& particles) {
  const MpmParams& mpm = scene.mpm;
  if (mpm.transfer != MpmTransfer::Mls || mpm.kernel != KernelType::Quadratic ||
      mpm.integrator != MpmIntegrator::Explicit || mpm.initial_volume != InitialVolume::Lattice)
    throw InputError(scene.file +
                     ": the reference MPM step is explicit MLS-MPM with quadratic B-splines and "
                     "lattice volumes only");
  ReferenceState<D> s;
  const int n = particles.size();
  s.x = particles.x;
  s.v = particles.v;
  s.m = particles.mass;
  for (int p = 0; p < n; ++p)  // V_p^0 = m_p / rho_body: the particle's share of its body
    s.V0.push_back(particles.mass[p] / scene.bodies[particles.body[p]].density);
  s.F_E.assign(n, Mat<D>::Identity());
  s.C.assign(n, Mat<D>::Zero());
  s.J_P.assign(n, 1);
  s.g = sceneGravity<D>(scene);
  s.grid = sceneGrid<D>(scene);
  s.grid_m.assign(s.grid.nodeCount(), 0);
  s.grid_v.assign(s.grid.nodeCount(), Vec<D>::Zero());
  s.material = scene.material;
  s.colliders = makeColliders<D>(scene);
  return s;
}

template <int D>
void referenceStep(ReferenceState<D>& s, Real dt) {
  const Real h = s.grid.h;
  const Real D_inv = 4 / (h * h);  // D_p^-1, quadratic B-splines (Jiang et al. 2015, after eq. 11)
  const Mat<D> I = Mat<D>::Identity();

  // P2G (Stomakhin et al. 2013, section 4 steps 1, 3, 4): mass, and momentum with the affine term
  // and dt times the force f_i = -sum_p V_p^0 tau_p grad w_ip (eq. 7) folded in, MLS taking
  // grad w_ip = w_ip D^-1 (x_i - x_p) (Hu et al. 2018, eq. 18): node i receives
  // w_ip (m_p v_p + (m_p C_p + dt D^-1 (-V_p^0 tau_p)) (x_i - x_p)).
  placeColliders(s.colliders, s.time);
  std::fill(s.grid_m.begin(), s.grid_m.end(), Real(0));
  std::fill(s.grid_v.begin(), s.grid_v.end(), Vec<D>::Zero());
  for (int p = 0; p < static_cast<int>(s.x.size()); ++p) {
    const Lame lame = hardenedLame(s.material, s.J_P[p]);  // mu = mu0 e^{xi (1 - J_P)}, section 5
    // Kirchhoff stress tau = P F_E^T = 2 mu (F_E - R_E) F_E^T + lambda (J_E - 1) J_E I (section 5),
    // R_E the polar rotation of F_E.
    const Mat<D> tau = fixedCorotatedKirchhoff<D>(s.F_E[p], polarRotation<D>(s.F_E[p]), lame);
    const Mat<D> A = s.m[p] * s.C[p] + dt * D_inv * (-s.V0[p] * tau);
    forEachReferenceNode<D>(s.grid, s.x[p], [&](int i, Real w, const Vec<D>& dx) {
      s.grid_m[i] += w * s.m[p];
      s.grid_v[i] += w * (s.m[p] * s.v[p] + A * dx);
    });
  }

  // Grid: v_i = momentum / m_i + dt g (section 4 step 4), then the collisions with the domain
  // walls and the scene's colliders (section 4 step 5, section 8).
  for (int i = 0; i < s.grid.nodeCount(); ++i) {
    if (s.grid_m[i] <= 0) {
      s.grid_v[i].setZero();
      continue;
    }
    s.grid_v[i] = s.grid_v[i] / s.grid_m[i] + dt * s.g;
    const Vec<D> x_i = s.grid.position(s.grid.coords(i));
    for (const Collider<D>& c : s.colliders) c.collideNode(x_i, s.grid_v[i]);
  }

  // G2P, deformation, plasticity, particle collisions, advection (section 4 steps 7-10).
  for (int p = 0; p < static_cast<int>(s.x.size()); ++p) {
    Vec<D> v = Vec<D>::Zero();
    Mat<D> B = Mat<D>::Zero();
    forEachReferenceNode<D>(s.grid, s.x[p], [&](int i, Real w, const Vec<D>& dx) {
      v += w * s.grid_v[i];                   // v_p = sum_i w_ip v_i
      B += w * s.grid_v[i] * dx.transpose();  // B_p = sum_i w_ip v_i (x_i - x_p)^T
    });
    s.v[p] = v;
    s.C[p] = D_inv * B;  // C_p = B_p D_p^-1 (Jiang et al. 2015, eq. 10), grad v_p for MLS
    s.F_E[p] = (I + dt * s.C[p]) * s.F_E[p];  // F_E^trial = (I + dt grad v_p) F_E (step 7)
    // Clamp the singular values of F_E to [1 - theta_c, 1 + theta_s], the rest into J_P (section
    // 5); the rotation it returns is not kept, P2G computes it anew.
    Mat<D> R_E;
    s.J_P[p] = plasticReturnMappingJ(s.material, s.F_E[p], s.J_P[p], R_E);
    for (const Collider<D>& c : s.colliders) c.collide(s.x[p], s.v[p]);  // step 9, section 8
    s.x[p] += dt * s.v[p];                                               // step 10
    for (const Collider<D>& c : s.colliders) c.pushOut(s.x[p]);
    s.x[p] = s.x[p].cwiseMax(Vec<D>::Zero()).cwiseMin(s.grid.extent());  // stays in the domain
  }
  s.time += dt;
}

template ReferenceState<2> makeReferenceState<2>(const Scene&, const Particles<2>&);
template ReferenceState<3> makeReferenceState<3>(const Scene&, const Particles<3>&);
template void referenceStep<2>(ReferenceState<2>&, Real);
template void referenceStep<3>(ReferenceState<3>&, Real);

}  // namespace snowsim
