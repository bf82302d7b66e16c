#include "sim/mpm/mpm_solver.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

#include "sim/core/errors.h"
#include "sim/core/pic_flip.h"
#include "sim/core/stencil.h"
#include "sim/mpm/transfer_scheme.h"
#include "sim/scene/scene_colliders.h"

namespace snowsim {

template <int D, class T>
MpmSolver<D, T>::MpmSolver(const Scene& scene, Particles<D> particles, int threads,
                           RankExchange& world)
    : params_(scene.mpm),
      material_(atCellSize(scene.material, scene.cell_size)),
      unhardened_lame_(unhardenedLame<T>(scene.material)),
      gravity_(sceneGravity<D>(scene).template cast<T>()),
      particles_(inPrecision<T>(std::move(particles)), scene.material),
      grid_(sceneGrid<D>(scene)),
      inv_h_(T(1 / grid_.h)),
      inertia_inverse_(T(withKernel(
          params_.kernel, [&]<class Kernel>() { return inertiaInverse<Kernel>(grid_.h); }))),
      colliders_(makeColliders<D>(scene)),
      schedule_(grid_, particles_.size(), params_.transfer != MpmTransfer::Mls, threads),
      ranks_(world, grid_) {
  if (!double_precision && params_.integrator == MpmIntegrator::SemiImplicit)
    throw InputError(scene.file +
                     ": mpm.precision \"float\" runs only mpm.integrator \"explicit\"");
  // Also checked where a scene file is read; a scene changed in code (the study) meets it here.
  if (material_.viscosity > 0 && semiImplicit())
    throw InputError(scene.file +
                     ": material.viscosity runs only mpm.integrator \"explicit\" (the "
                     "semi-implicit solve has no damper in its stress differential)");
  refuseWhatIsNotDistributed(scene, ranks_.ranks());  // as makeSimulation, for direct callers
  fields_.resize(grid_.nodeCount());
  for (const Body& body : scene.bodies) body_density_.push_back(body.density);
  continuePlasticity(scene);
  if (params_.open_cracks) {  // also checked where a scene file is read
    if (!(material_.fracture_strain > 0) || params_.transfer != MpmTransfer::Mls ||
        params_.integrator != MpmIntegrator::Explicit)
      throw InputError(scene.file +
                       ": mpm.open_cracks needs material.fracture_strain > 0, mpm.transfer "
                       "\"mls\" and mpm.integrator \"explicit\"");
    cracks_ = std::make_unique<CrackOpening<D, T>>(grid_.nodeCount(), Schedule::colours,
                                                   particles_.size(), schedule_.blockCount(),
                                                   T(params_.crack_friction));
  }
  for (int p = 0; p < particles_.size(); ++p) total_mass_ += particles_.mass[p];
  total_particles_ = particles_.size();
  collider_speed_ = fastestColliderSpeed(colliders_, grid_.extent().norm());
  screens_.place(colliders_, grid_.extent().norm());
  colliders_move_ = collider_speed_ > 0;
  if (params_.auto_sleep.enabled) {
    particles_.calm_steps.assign(particles_.size(), 0);
    if (cracks_) {  // what sleeping snow read of the damage field
      particles_.crack_gradient.assign(particles_.size(), V::Zero());
      particles_.crack_side_bits.assign(particles_.size(), 0);
      particles_.crack_flags.assign(particles_.size(), 0);
    }
    schedule_.keepStillBlocks();
    sleeper_ = std::make_unique<AutoSleeper>(params_.auto_sleep);
  }
  // Paper section 4 step 2, done once before the first step: densities and volumes from the grid.
  scatter(0);
  updateGridVelocities(0);  // the grid's mass, for the volumes
  withKernel(params_.kernel, [&]<class Kernel>() {
    parallelFor(&schedule_, particles_.size(), [&](int p) { estimateVolume<Kernel>(p); });
  });
  // The damper's grid-scale rate, about eta V_p^0 / (m_p h^2), needs dt <= rho h^2 / (4 eta) with
  // rho = m_p / V_p^0, the step of a signal speed 4 eta / (rho h), safely below the step measured
  // to blow up (docs/mpm.md). The lightest particle sets it, once for the run.
  if (material_.viscosity > 0) {
    Real lightest = std::numeric_limits<Real>::infinity();
    for (int p = 0; p < particles_.size(); ++p)
      if (particles_.volume[p] > 0)
        lightest = std::min(lightest, Real(particles_.mass[p]) / Real(particles_.volume[p]));
    if (std::isfinite(lightest)) viscous_speed_ = 4 * material_.viscosity / (lightest * grid_.h);
  }
  // Every rank has built the whole scene and its volumes alike; each keeps its slab's particles.
  if (ranks_.keepOwn(particles_)) schedule_.resize(particles_.x);
  measureParticles();
}

// One step, the paper's section 4 list; the stages run on the schedule's threads.
template <int D, class T>
void MpmSolver<D, T>::advance(Real dt) {
  placeColliders(colliders_, this->time());
  screens_.place(colliders_, grid_.extent().norm());
  const Real stable_dt = semiImplicit() ? advectionTimeStep() : cflTimeStep();
  if (dt > stable_dt && step_when_exceeded_ < 0) {
    limit_when_exceeded_ = stable_dt;
    step_when_exceeded_ = this->steps();
  }
  part_measures_.resize(schedule_.prepare());
  withTransferAndKernel(params_.transfer, params_.kernel, [&]<class Transfer, class Kernel>() {
    withParts<Transfer, Kernel>(
        [&](auto& opening, auto& sleep) { stepWith<Transfer, Kernel>(T(dt), opening, sleep); });
  });
  collectMeasures();
  if (sleeper_) {  // the whole snow's
    long asleep = 0;
    for (const PartMeasure& m : part_measures_) asleep += m.asleep;
    sleeper_->count(ranks_.sum(asleep), total_particles_);
  }
  migrate();
}

template <int D, class T>
void MpmSolver<D, T>::migrate() {
  const long step = this->steps() + 1;
  // With damage, each migrating particle brings the crack's fields it reads next step.
  const bool moved =
      cracks_ && cracks_->holdsDamage()
          ? withKernel(params_.kernel,
                       [&]<class Kernel>() {
                         return cracks_->template migrate<Kernel>(ranks_, particles_, grid_,
                                                                  schedule_.activeNodes(), step);
                       })
          : ranks_.migrate(particles_, step);
  if (moved) schedule_.resize(particles_.x);
}

template <int D, class T>
template <class Transfer, class Kernel, class F>
void MpmSolver<D, T>::withParts(F&& f) {
  const auto withSleep = [&](auto& opening) {
    if (sleeper_) {
      SleepStep<D, T> sleep = sleepStep();
      return f(opening, sleep);
    }
    NoSleep<D, T> sleep;
    f(opening, sleep);
  };
  if constexpr (Transfer::mls) {
    // Until some snow is stretched past J_P = 1 there is no damage, and one velocity a node does;
    // once it has healed, one more crack step clears the damage field.
    if (cracks_) {
      // Across ranks the whole snow's: the ranks share the nodes near their cuts.
      const bool damaged = ranks_.anyOverRanks(
          std::any_of(particles_.J_P.begin(), particles_.J_P.end(), [](T J_P) { return J_P > 1; }));
      if (damaged || cracks_->holdsDamage()) {
        OpenCracks<D, T, Kernel> opening(*cracks_, particles_, material_, grid_, fields_,
                                         inertia_inverse_, damaged,
                                         sleeper_ ? params_.auto_sleep.steps : -1);
        // What still blocks kept before a primed field, or for the step that clears the damage
        // (it takes no references), holds for neither.
        if (cracks_->mustPrime() || !damaged) schedule_.forgetStillBlocks();
        cracked_last_step_ = true;
        return withSleep(opening);
      }
      // What still blocks kept of a crack step holds only their side 0's share.
      if (cracked_last_step_) schedule_.forgetStillBlocks();
      cracked_last_step_ = false;
    }
  }
  OneVelocityPerNode<D, T> opening{fields_};
  withSleep(opening);
}

template <int D, class T>
template <class Transfer, class Kernel, class Opening, class Sleep>
void MpmSolver<D, T>::stepWith(T dt, Opening& opening, Sleep& sleep) {
  const bool semi_implicit = semiImplicit();
  const VectorIsa isa = vectorIsa();
  const auto plainScatter = [&](int p, PartialGrid& g, T scale) {
    scatterParticleOn<Transfer, Kernel>(isa, p, g, scale);
  };
  // The semi-implicit solve may throw and runs serial code between its parallel loops, so its
  // stages each meet on their own; the explicit stages share the team's threads, but for the
  // exchanges between ranks, which only the calling thread makes.
  schedule_.step(particles_, !semi_implicit && !ranks_.distributed(), [&] {
    // Open cracks, at the first step with damage: its damage field and references.
    opening.prime(schedule_, ranks_);
    // 1, 3: mass, momentum and forces to the grid (with open cracks, into each node's side);
    // resting snow's momentum is dt times its stress's share, kept by still blocks.
    const auto scatterAt = [&](T scale) {
      return [&, scale](int p, PartialGrid& g) {
        opening.scatter(p, g, scale, [&](int q, PartialGrid& h) { plainScatter(q, h, scale); });
      };
    };
    sleep.scatter(schedule_, opening.scatter_stage, scatterAt(dt), scatterAt(T(1)),
                  opening.stillFields(), dt);
    // 4 (+ 5 explicit): grid velocities, forces, gravity (and the grid collisions).
    ranks_.updateNodes(
        schedule_, fields_,
        [&](int k) {
          velocityFromMomentum<Transfer>(k);
          accelerate<Transfer>(k, dt);
          if (!semi_implicit)
            opening.collide(k, fields_.mass[k], fields_.velocity[k], dt, gravity_,
                            [&](V& v) { collideAtNode(k, v); });
        },
        !Transfer::mls, [&] { opening.sumShares(ranks_, schedule_.activeNodes()); });
    if (semi_implicit)  // 5 + 6: collided v*, then the solve
      schedule_.timed("implicit solve", [&] { solveImplicitVelocities(dt); });
    // 8, 7, 9, 10 in one pass: each particle's arrays are loaded once for all four.
    schedule_.passOverParticles("move particles", particles_.x, part_measures_,
                                [&](std::span<const int> batch, PartMeasure& m, Real* shares) {
                                  moveParticles<Transfer, Kernel>(batch, m, shares, dt, isa,
                                                                  opening, sleep);
                                });
  });
}

template <int D, class T>
template <class Transfer, class Kernel, class Opening, class Sleep>
void MpmSolver<D, T>::moveParticles(std::span<const int> batch, PartMeasure& m, Real* shares, T dt,
                                    VectorIsa isa, Opening& opening, Sleep& sleep) {
  // 8 and the trial F_E one particle at a time, the return mapping for the batch's awake ones at
  // once, then 9 and 10 one at a time. Nothing a particle's steps read is written by another's.
  constexpr int most = Schedule::pass_batch;
  int awake[most];
  typename Sleep::template Batch<most> moved;
  int count = 0;
  for (const int p : batch) {
    if (sleep.template sleepsThrough<Kernel>(p, particles_.x[p], opening.velocitiesOf(p))) continue;
    moved.remember(count, particles_.x[p]);
    awake[count++] = p;
    // 8 (gathered first: 7 needs grad v)
    opening.gather(p, [&](int q) { gatherVelocityOn<Transfer, Kernel>(isa, q); });
    trialDeformation(p, dt);  // 7
  }
  returnMapping<Transfer>(std::span<const int>(awake, count), isa);
  BatchMaxima maxima;
  for (int i = 0, a = 0; i < int(batch.size()); ++i) {
    const int p = batch[i];
    if (a < count && awake[a] == p) {
      collideParticle(p);  // 9
      advect(p, dt);       // 10
      sleep.template restOrStir<Kernel>(p, particles_.v[p], moved, a, opening.velocitiesOf(p),
                                        [&] { fallAsleep(p); });
      ++a;
    } else {
      ++m.asleep;
    }
    shares[i] = measure(p, maxima);
  }
  maxima.foldInto(m);
}

template <int D, class T>
void MpmSolver<D, T>::fallAsleep(int p) {
  if (material_.viscosity > 0) addDamperStress(p, -1);
  particles_.v[p].setZero();
  particles_.C[p].setZero();
}

template <int D, class T>
template <class Transfer, class Kernel>
void MpmSolver<D, T>::scatterParticle(int p, PartialGrid& g, T dt) const {
  const T inv_h = inv_h_;
  const V& x = particles_.x[p];
  const T m = particles_.mass[p];
  const V mv = m * particles_.v[p];
  // Grid force f_i = -sum_p V_p^0 P_p F_E^T grad w_ip (eq. 7), with the Kirchhoff stress
  // tau = P F_E^T; MLS replaces grad w by w D^-1 (x_i - x_p) (Hu et al. 2018, eq. 18).
  const Stencil<D, Kernel, T> s(x, inv_h);
  if constexpr (Transfer::mls) {
    // MLS-MPM puts dt f_i straight into the momentum (Hu et al. 2018, section 5.1): node i
    // receives w (m v_p + A_p (x_i - x_p)), the mass and momentum of eq. 1 with the affine part
    // of APIC and the force of eq. 8 in one scatter.
    const M A = mlsAffineMomentum(particles_, p, dt, inertia_inverse_);
    TensorStencil<D, Kernel, T>(grid_, s, x)
        .scatterAffine(m, mv, A, g.mass.data(), g.momentum.data());
  } else {
    const T V0 = particles_.volume[p];
    const M stress = V0 > 0 ? M(-V0 * particles_.tau[p].matrix()) : M::Zero();
    const M mC = m * particles_.C[p];
    visitStencil(grid_, s, x, [&](const StencilVisit<D, T>& node) {
      const int k = node.index;
      const T w = s.weightAt(node.offset);
      g.mass[k] += w * m;
      // Momentum, eq. 1; APIC adds the affine part m C (x_i - x_p) (Jiang et al. 2015).
      V momentum = mv;
      if constexpr (Transfer::affine) momentum.noalias() += mC * node.dx;
      g.momentum[k] += w * momentum;
      g.force[k].noalias() += stress * s.gradientAt(node.offset, inv_h);
    });
  }
}

template <int D, class T>
void MpmSolver<D, T>::continuePlasticity(const Scene& scene) {
  // Particles are still in creation order: a body's are consecutive, from its first one on.
  std::vector<int> first(scene.bodies.size(), -1);
  for (int p = 0; p < particles_.size(); ++p) {
    const int b = particles_.body[p];
    if (first[b] < 0) first[b] = p;
    const Snapshot* points = scene.bodies[b].points.get();
    if (!points || points->plastic_j.empty()) continue;
    particles_.J_P[p] = T(points->plastic_j[p - first[b]]);
    particles_.hardening[p] = hardeningFactor<T>(material_, particles_.J_P[p]);
  }
}

template <int D, class T>
template <class Kernel>
void MpmSolver<D, T>::estimateVolume(int p) {
  if (params_.initial_volume == InitialVolume::Lattice) {
    // Each particle carries its share of its body: V_p^0 = m_p / rho_body = spacing^D.
    particles_.volume[p] = particles_.mass[p] / T(body_density_[particles_.body[p]]);
    return;
  }
  // rho_p^0 = sum_i m_i w_ip / h^D, V_p^0 = m_p / rho_p^0 (paper section 4 step 2).
  T rho = 0;
  forEachStencilNode<D, Kernel>(grid_, particles_.x[p],
                                [&](int k, T w, const V&) { rho += fields_.mass[k] * w; });
  rho /= T(std::pow(grid_.h, D));
  particles_.volume[p] = particles_.mass[p] / rho;
}

template <int D, class T>
template <class Transfer>
void MpmSolver<D, T>::velocityFromMomentum(int k) {
  // Keeps the rasterised velocity for the FLIP increment.
  const T m = fields_.mass[k];
  fields_.velocity[k] = m > 0 ? V(fields_.velocity[k] / m) : V::Zero();
  if constexpr (!Transfer::affine) fields_.velocity_old[k] = fields_.velocity[k];
}

template <int D, class T>
template <class Transfer>
void MpmSolver<D, T>::accelerate(int k, T dt) {
  const T m = fields_.mass[k];
  if (m <= 0) return;
  fields_.velocity[k] += dt * gravity_;
  // MLS scattered dt f_i with the momentum: only gravity remains.
  if constexpr (!Transfer::mls) fields_.velocity[k] += (dt / m) * fields_.force[k];  // eq. 8
}

template <int D, class T>
void MpmSolver<D, T>::collideAtNode(int k, V& velocity) const {
  const Vec<D> x = grid_.position(grid_.coords(k));
  const std::vector<int>& near = screens_.near(x);
  if (near.empty()) return;
  if constexpr (double_precision) {
    for (const int c : near)
      if (screens_.mayTouch(c, x)) colliders_[c].collideNode(x, velocity);
  } else {  // the colliders work in double
    Vec<D> v = velocity.template cast<Real>();
    for (const int c : near)
      if (screens_.mayTouch(c, x)) colliders_[c].collideNode(x, v);
    velocity = v.template cast<T>();
  }
}

template <int D, class T>
void MpmSolver<D, T>::solveImplicitVelocities(Real dt) {
  // Section 9: grid collisions act on v* before the solve, which then holds what they fixed.
  // Double only (the constructor turns a float semi-implicit scene away).
  if constexpr (double_precision) {
    node_free_.resize(grid_.nodeCount());
    schedule_.forActiveNodes(grid_, [&](int k) {
      if (fields_.mass[k] > 0)
        node_free_[k] =
            collideAndConstrain(colliders_, grid_.position(grid_.coords(k)), fields_.velocity[k]);
    });
    implicit_.prepare(grid_, fields_, particles_, particles_.F_E, material_, particles_.hardening,
                      params_, dt, &schedule_);
    last_solve_ = implicit_.solve(fields_, node_free_, params_.implicit_beta,
                                  params_.implicit_tolerance, params_.implicit_max_iterations);
    solves_.add(last_solve_);
    if (!std::isfinite(last_solve_.residual)) {
      std::ostringstream s;
      s << "semi-implicit MPM solve failed at step " << this->steps() << " (t = " << this->time()
        << " s): non-finite residual after " << last_solve_.iterations << " iterations; dt = " << dt
        << " s";
      throw SimulationError(s.str());
    }
  }
}

template <int D, class T>
template <class Transfer, class Kernel>
void MpmSolver<D, T>::gatherVelocity(int p) {
  const T inv_h = inv_h_;
  const V x = particles_.x[p];
  const Stencil<D, Kernel, T> s(x, inv_h);
  if constexpr (Transfer::affine) {
    // v_p = sum_i w v_i, B_p = sum_i w v_i (x_i - x_p)^T (Jiang et al. 2015, eq. 10),
    // C_p = B_p D_p^-1, also grad v_p for MLS (Hu et al. 2018).
    M B;
    particles_.v[p] =
        TensorStencil<D, Kernel, T>(grid_, s, x).gatherAffine(fields_.velocity.data(), B);
    particles_.C[p] = inertia_inverse_ * B;
  } else {
    V v_pic = V::Zero(), dv = V::Zero();
    M grad_v = M::Zero();
    visitStencil(grid_, s, x, [&](const StencilVisit<D, T>& node) {
      const T w = s.weightAt(node.offset);
      const V& vi = fields_.velocity[node.index];
      v_pic += w * vi;
      dv += w * (vi - fields_.velocity_old[node.index]);
      grad_v += vi * s.gradientAt(node.offset, inv_h).transpose();  // grad v_p, eq. 10
    });
    particles_.v[p] = picFlipBlend<D, T>(particles_.v[p], v_pic, dv, T(params_.flip_alpha));
    particles_.C[p] = grad_v;
  }
}

template <int D, class T>
void MpmSolver<D, T>::trialDeformation(int p, T dt) {
  // For PIC/FLIP C holds grad v; for APIC/MLS the affine C, equal to grad v for these kernels.
  M& F_E = particles_.F_E[p];
  // eq. 10, F_E^trial = (I + dt C) F_E, written out: GCC does not inline Eigen's product of small
  // matrices, whose call is a visible share of the 2D step. Each entry is summed as Eigen's
  // unrolled sum is, a + (b + c) in 3D, so the results are Eigen's bit for bit.
  const M G = M::Identity() + dt * particles_.C[p];
  M trial;
#pragma GCC unroll 3  // GCC keeps these loops of three otherwise
  for (int j = 0; j < D; ++j)
#pragma GCC unroll 3
    for (int i = 0; i < D; ++i) {
      if constexpr (D == 2)
        trial(i, j) = G(i, 0) * F_E(0, j) + G(i, 1) * F_E(1, j);
      else
        trial(i, j) = G(i, 0) * F_E(0, j) + (G(i, 1) * F_E(1, j) + G(i, 2) * F_E(2, j));
    }
  F_E = trial;
}

template <int D, class T>
template <class Transfer>
void MpmSolver<D, T>::returnMapping(std::span<const int> ps, VectorIsa isa) {
  // Eqs. 11-12, the Lamé parameters and tau as well; the rotations are not kept.
  if constexpr (D == 2)
    plasticReturnMappingJ<T>(material_, ps, particles_.F_E.data(), particles_.J_P.data(),
                             particles_.hardening.data(), particles_.tau.data(), isa);
  else
    plasticReturnMappingJ<T>(material_, ps, particles_.F_E.data(), particles_.J_P.data(), nullptr,
                             particles_.hardening.data(), particles_.tau.data(), isa);
  // The damper's stress from this step's velocity gradient, which C holds in every transfer.
  if (material_.viscosity > 0)
    for (const int p : ps) addDamperStress(p, 1);
  // PIC/FLIP keeps no affine velocity: C must not feed the next scatter.
  if constexpr (!Transfer::affine)
    for (const int p : ps) particles_.C[p].setZero();
}

template <int D, class T>
void MpmSolver<D, T>::addDamperStress(int p, T sign) {
  // Failing snow loses its damper with its elastic strength (SnowMaterial::fracture_strain).
  T eta = T(material_.viscosity);
  if (material_.fracture_strain > 0) eta *= strengthLeft<T>(material_, particles_.J_P[p]);
  const Symmetric<D, T> damper = viscousKirchhoffUpper<D, T>(particles_.C[p], eta);
  for (int k = 0; k < Symmetric<D, T>::entries; ++k)
    particles_.tau[p].upper[k] += sign * damper.upper[k];
}

template <int D, class T>
void MpmSolver<D, T>::collideParticle(int p) {
  // The colliders work in double (a float position converts exactly).
  const Vec<D> x = particles_.x[p].template cast<Real>();
  const std::vector<int>& near = screens_.near(x);
  if (near.empty()) return;
  if constexpr (double_precision) {
    for (const int c : near)
      if (screens_.mayTouch(c, x)) colliders_[c].collide(x, particles_.v[p]);
  } else {
    Vec<D> v = particles_.v[p].template cast<Real>();
    bool touched = false;
    for (const int c : near)
      if (screens_.mayTouch(c, x)) {
        colliders_[c].collide(x, v);
        touched = true;
      }
    if (touched) particles_.v[p] = v.template cast<T>();
  }
}

template <int D, class T>
void MpmSolver<D, T>::advect(int p, T dt) {
  V& x = particles_.x[p];
  x += dt * particles_.v[p];
  Vec<D> x_double = x.template cast<Real>();
  const std::vector<int>& near = screens_.near(x_double);
  if constexpr (double_precision) {
    for (const int c : near)
      if (screens_.mayTouch(c, x)) colliders_[c].pushOut(x);
  } else {
    bool touched = false;
    for (const int c : near)
      if (screens_.mayTouch(c, x_double)) {
        colliders_[c].pushOut(x_double);
        touched = true;
      }
    if (touched) x = x_double.template cast<T>();
  }
  x = x.cwiseMax(V::Zero()).cwiseMin(grid_.extent().template cast<T>());  // never leave the domain
}

template <int D, class T>
void MpmSolver<D, T>::scatter(Real dt) {
  const VectorIsa isa = vectorIsa();
  withTransferAndKernel(params_.transfer, params_.kernel, [&]<class Transfer, class Kernel>() {
    schedule_.scatterAlone(particles_.x, [&](int p, PartialGrid& g) {
      scatterParticleOn<Transfer, Kernel>(isa, p, g, T(dt));
    });
  });
}

template <int D, class T>
void MpmSolver<D, T>::updateGridVelocities(Real dt) {
  withTransferAndKernel(params_.transfer, params_.kernel, [&]<class Transfer, class>() {
    schedule_.updateNodes(fields_, [&](int k) {
      velocityFromMomentum<Transfer>(k);
      accelerate<Transfer>(k, dt);
    });
  });
  schedule_.gridStageDone();
}

template <int D, class T>
void MpmSolver<D, T>::updateParticles(Real dt) {
  part_measures_.resize(schedule_.prepare());
  schedule_.forgetStillBlocks();  // a pass no scatter with stillness sees
  const VectorIsa isa = vectorIsa();
  withTransferAndKernel(params_.transfer, params_.kernel, [&]<class Transfer, class Kernel>() {
    OneVelocityPerNode<D, T> opening{fields_};  // a pass alone takes the plain gather
    const auto pass = [&](auto&& sleep) {
      schedule_.passOverParticles("move particles", particles_.x, part_measures_,
                                  [&](std::span<const int> batch, PartMeasure& m, Real* shares) {
                                    moveParticles<Transfer, Kernel>(batch, m, shares, T(dt), isa,
                                                                    opening, sleep);
                                  });
    };
    if (sleeper_) {
      SleepStep<D, T> sleep = sleepStep();
      pass(sleep);
    } else {
      NoSleep<D, T> sleep;
      pass(sleep);
    }
  });
  collectMeasures();
}

template class MpmSolver<2, double>;
template class MpmSolver<3, double>;
template class MpmSolver<2, float>;
template class MpmSolver<3, float>;

}  // namespace snowsim
