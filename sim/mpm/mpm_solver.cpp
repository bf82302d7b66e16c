#include "sim/mpm/mpm_solver.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

#include "sim/core/errors.h"
#include "sim/core/pic_flip.h"
#include "sim/core/stencil.h"
#include "sim/io/schedule_state.h"
#include "sim/mpm/transfer_scheme.h"
#include "sim/scene/scene_colliders.h"

namespace snowsim {

namespace {

// The vectors of `from` in the scalar of `to`.
template <class From, class To>
void castEach(const std::vector<From>& from, std::vector<To>& to) {
  to.resize(from.size());
  for (size_t i = 0; i < from.size(); ++i) to[i] = from[i].template cast<typename To::Scalar>();
}

// The particles in the precision T of the solver's state.
template <int D, class T>
Particles<D, T> inPrecision(Particles<D> particles) {
  if constexpr (std::is_same_v<T, Real>) {
    return particles;
  } else {
    Particles<D, T> converted;
    castEach(particles.x, converted.x);
    castEach(particles.v, converted.v);
    converted.mass.assign(particles.mass.begin(), particles.mass.end());
    converted.volume.assign(particles.volume.begin(), particles.volume.end());
    converted.body = std::move(particles.body);
    converted.id = std::move(particles.id);
    return converted;
  }
}

}  // namespace

template <int D, class T>
MpmSolver<D, T>::MpmSolver(const Scene& scene, Particles<D> particles, int threads,
                           RankExchange& world)
    : params_(scene.mpm),
      material_(scene.material),
      unhardened_lame_(unhardenedLame<T>(scene.material)),
      gravity_(sceneGravity<D>(scene).template cast<T>()),
      particles_(inPrecision<D, T>(std::move(particles)), scene.material),
      grid_(sceneGrid<D>(scene)),
      inv_h_(T(1 / grid_.h)),
      inertia_inverse_(T(withKernel(
          params_.kernel, [&]<class Kernel>() { return inertiaInverse<Kernel>(grid_.h); }))),
      colliders_(makeColliders<D>(scene)),
      schedule_(grid_, particles_.size(), params_.transfer != MpmTransfer::Mls, threads),
      slabs_(world, grid_) {
  if (!double_precision && params_.integrator == MpmIntegrator::SemiImplicit)
    throw InputError(scene.file +
                     ": mpm.precision \"float\" runs only mpm.integrator \"explicit\"");
  // Also checked where a scene file is read; a scene changed in code (the study) meets it here.
  if (material_.viscosity > 0 && semiImplicit())
    throw InputError(scene.file +
                     ": material.viscosity runs only mpm.integrator \"explicit\" (the "
                     "semi-implicit solve has no damper in its stress differential)");
  refuseWhatIsNotDistributed(scene, slabs_.ranks());  // as makeSimulation, for direct callers
  fields_.resize(grid_.nodeCount());
  for (const Body& body : scene.bodies) body_density_.push_back(body.density);
  continuePlasticity(scene);
  if (params_.auto_sleep.enabled) {
    particles_.calm_steps.assign(particles_.size(), 0);
    schedule_.keepStillBlocks();
  }
  if (params_.open_cracks) {  // also checked where a scene file is read
    if (!(material_.fracture_strain > 0) || params_.transfer != MpmTransfer::Mls ||
        params_.integrator != MpmIntegrator::Explicit || params_.auto_sleep.enabled)
      throw InputError(scene.file +
                       ": mpm.open_cracks needs material.fracture_strain > 0, mpm.transfer "
                       "\"mls\", mpm.integrator \"explicit\" and no mpm.auto_sleep");
    cracks_ = std::make_unique<CrackOpening<D, T>>(grid_.nodeCount(), Schedule::colours,
                                                   particles_.size(), T(params_.crack_friction));
  }
  for (int p = 0; p < particles_.size(); ++p) total_mass_ += particles_.mass[p];
  total_particles_ = particles_.size();
  collider_speed_ = fastestColliderSpeed(colliders_, grid_.extent().norm());
  placeScreens();
  colliders_move_ = collider_speed_ > 0;
  // Paper section 4 step 2, done once before the first step: densities and volumes from the grid.
  scatter(0);
  updateGridVelocities(0);  // the grid's mass, for the volumes
  withKernel(params_.kernel, [&]<class Kernel>() {
    parallelFor(&schedule_, particles_.size(), [&](int p) { estimateVolume<Kernel>(p); });
  });
  // The damper's grid-scale rate, about eta V_p^0 / (m_p h^2), needs dt <= rho h^2 / (4 eta) with
  // rho = m_p / V_p^0, the step of a signal speed 4 eta / (rho h): 0.4-0.65 of the step measured
  // to blow up in 2D and 3D (docs/mpm.md). The lightest particle sets it, once for the run.
  if (material_.viscosity > 0) {
    Real lightest = std::numeric_limits<Real>::infinity();
    for (int p = 0; p < particles_.size(); ++p)
      if (particles_.volume[p] > 0)
        lightest = std::min(lightest, Real(particles_.mass[p]) / Real(particles_.volume[p]));
    if (std::isfinite(lightest)) viscous_speed_ = 4 * material_.viscosity / (lightest * grid_.h);
  }
  // Every rank has built the whole scene and its volumes alike; each keeps its slab's particles.
  if (slabs_.distributed()) {
    slabs_.keepOwn(particles_);
    schedule_.resize(particles_.x);
  }
  measureParticles();
}

// One step, the paper's section 4 list; the stages run on the schedule's threads.
template <int D, class T>
void MpmSolver<D, T>::advance(Real dt) {
  placeColliders(colliders_, this->time());
  placeScreens();
  const Real stable_dt = semiImplicit() ? advectionTimeStep() : cflTimeStep();
  if (dt > stable_dt && step_when_exceeded_ < 0) {
    limit_when_exceeded_ = stable_dt;
    step_when_exceeded_ = this->steps();
  }
  part_measures_.resize(schedule_.prepare());
  withTransferAndKernel(params_.transfer, params_.kernel,
                        [&]<class Transfer, class Kernel>() { stepWith<Transfer, Kernel>(T(dt)); });
  collectMeasures();
  if (params_.auto_sleep.enabled) countSleepers();
  if (slabs_.migrate(particles_, this->steps() + 1)) schedule_.resize(particles_.x);
}

template <int D, class T>
void MpmSolver<D, T>::countSleepers() {
  long asleep = 0;
  for (const PartMeasure& m : part_measures_) asleep += m.asleep;
  if (slabs_.distributed()) {  // the whole snow's: one more exchange, with auto-sleep only
    std::vector<double> none;
    asleep = std::lround(slabs_.maxAndSum(none, double(asleep)));
  }
  sleep_tally_.asleep_now = asleep;
  sleep_tally_.asleep_steps += asleep;
  sleep_tally_.particle_steps += total_particles_;
  sleep_tally_.particles = total_particles_;
}

template <int D, class T>
template <class Transfer, class Kernel>
void MpmSolver<D, T>::stepWith(T dt) {
  // Until some snow is stretched past J_P = 1 there is no damage, and the plain step is the one
  // with cracks.
  crack_step_ =
      Transfer::mls && cracks_ &&
      std::any_of(particles_.J_P.begin(), particles_.J_P.end(), [](T J_P) { return J_P > 1; });
  if (crack_step_) return stepWithCracks<Kernel>(dt);
  const bool semi_implicit = semiImplicit();
  const VectorIsa isa = vectorIsa();
  // The semi-implicit solve may throw and runs serial code between its parallel loops, so its
  // stages each meet on their own; the explicit stages share the team's threads, but for the
  // exchanges between ranks, which only the calling thread makes.
  schedule_.step(particles_, !semi_implicit && !slabs_.distributed(), [&] {
    // 1, 3: mass, momentum and forces to the grid.
    const auto scatterOne = [&](int p, PartialGrid& g) {
      scatterParticleOn<Transfer, Kernel>(isa, p, g, dt);
    };
    if (params_.auto_sleep.enabled)  // resting snow's momentum is dt times its stress's share
      schedule_.scatter(
          scatterOne, [&](int p) { return stillness(p); },
          [&](int p, PartialGrid& g) { scatterParticleOn<Transfer, Kernel>(isa, p, g, T(1)); }, dt);
    else
      schedule_.scatter(scatterOne);
    // 4 (+ 5 explicit): grid velocities, forces, gravity (and the grid collisions).
    const auto updateNode = [&](int k) {
      velocityFromMomentum<Transfer>(k);
      accelerate<Transfer>(k, dt);
      if (!semi_implicit) collideNode(k);
    };
    if (slabs_.distributed())  // the nodes shared with the neighbour ranks summed first
      schedule_.updateNodes(fields_, updateNode, [&] {
        slabs_.sumHalo(fields_, schedule_.activeNodes(), !Transfer::mls);
      });
    else
      schedule_.updateNodes(fields_, updateNode);
    if (semi_implicit)  // 5 + 6: collided v*, then the solve
      schedule_.timed("implicit solve", [&] { solveImplicitVelocities(dt); });
    // 8, 7, 9, 10 in one pass: each particle's arrays are loaded once for all four.
    schedule_.passOverParticles("move particles", particles_.x, part_measures_,
                                [&](std::span<const int> batch, PartMeasure& m, Real* shares) {
                                  moveParticles<Transfer, Kernel>(batch, m, shares, dt, isa);
                                });
  });
}

template <int D, class T>
template <class Kernel>
void MpmSolver<D, T>::stepWithCracks(T dt) {
  const VectorIsa isa = vectorIsa();
  CrackOpening<D, T>& cracks = *cracks_;
  schedule_.step(particles_, true, [&] {
    // The damage field, then each particle's damage gradient and each node's reference
    // direction, which decide the sides of the scatter and the gather. The stages named
    // "crack: ..." tell the cost estimate (app/cost_estimate.cpp) that these passes ran.
    schedule_.scatter(
        [&](int p, PartialGrid& g) {
          cracks.template scatterDamage<Kernel>(grid_, particles_.x[p], particles_.mass[p],
                                                damage(p), g.colour);
        },
        "crack: damage");
    schedule_.forScatteredNodes("crack: damage field", [&](int k) { cracks.sumDamage(k); });
    schedule_.scatter(
        [&](int p, PartialGrid& g) {
          cracks.template findGradient<Kernel>(grid_, particles_.x[p], inertia_inverse_, p,
                                               g.colour);
        },
        "crack: gradients");
    schedule_.forScatteredNodes("crack: sides", [&](int k) { cracks.sumReference(k); });
    // 1, 3: mass, momentum and forces to the grid, each into its side.
    schedule_.scatter([&](int p, PartialGrid& g) {
      if (cracks.nearDamage(p))
        scatterParticleWithCracks<Kernel>(p, g, dt);
      else
        scatterParticleOn<MlsTransfer, Kernel>(isa, p, g, dt);
    });
    // 4, 5: each field's velocity and gravity, the fields' contact where they approach, then
    // the collisions.
    schedule_.updateNodes(fields_, [&](int k) {
      velocityFromMomentum<MlsTransfer>(k);
      accelerate<MlsTransfer>(k, dt);
      cracks.updateNode(k, fields_.mass[k], fields_.velocity[k], dt, gravity_,
                        [&](V& v) { collideAtNode(k, v); });
    });
    // 8, 7, 9, 10.
    schedule_.passOverParticles("move particles", particles_.x, part_measures_,
                                [&](std::span<const int> batch, PartMeasure& m, Real* shares) {
                                  moveParticles<MlsTransfer, Kernel>(batch, m, shares, dt, isa);
                                });
  });
  crack_step_ = false;  // a particle pass run alone (updateParticles) takes the plain gather
}

template <int D, class T>
template <class Kernel>
void MpmSolver<D, T>::scatterParticleWithCracks(int p, PartialGrid& g, T dt) const {
  // As scatterParticle's MLS branch, node by node into each node's side.
  const T m = particles_.mass[p];
  const T V0 = particles_.volume[p];
  const M stress = V0 > 0 ? M(-V0 * particles_.tau[p].matrix()) : M::Zero();
  const M A = m * particles_.C[p] + (dt * inertia_inverse_) * stress;
  cracks_->template scatter<Kernel>(grid_, particles_.x[p], p, failed(p), m, V(m * particles_.v[p]),
                                    A, g.mass.data(), g.momentum.data(), g.colour);
}

template <int D, class T>
template <class Kernel>
void MpmSolver<D, T>::gatherVelocityWithCracks(int p) {
  M B;
  particles_.v[p] = cracks_->template gather<Kernel>(grid_, particles_.x[p], p, failed(p),
                                                     fields_.velocity.data(), B);
  particles_.C[p] = inertia_inverse_ * B;
}

template <int D, class T>
template <class Transfer, class Kernel>
void MpmSolver<D, T>::moveParticles(std::span<const int> batch, PartMeasure& m, Real* shares, T dt,
                                    VectorIsa isa) {
  // 8 and the trial F_E one particle at a time, the return mapping for the batch's awake ones at
  // once, then 9 and 10 one at a time. Nothing a particle's steps read is written by another's.
  constexpr int most = Schedule::pass_batch;
  int awake[most];
  V x_before[most];
  int count = 0;
  for (const int p : batch) {
    if (params_.auto_sleep.enabled) {
      if (sleepsThrough<Kernel>(p)) continue;
      x_before[count] = particles_.x[p];  // read only by restOrStir
    }
    awake[count++] = p;
    // 8 (gathered first: 7 needs grad v)
    if (crack_step_ && cracks_->nearDamage(p))
      gatherVelocityWithCracks<Kernel>(p);
    else
      gatherVelocityOn<Transfer, Kernel>(isa, p);
    trialDeformation(p, dt);  // 7
  }
  returnMapping<Transfer>(std::span<const int>(awake, count), isa);
  BatchMaxima maxima;
  for (int i = 0, a = 0; i < int(batch.size()); ++i) {
    const int p = batch[i];
    if (a < count && awake[a] == p) {
      collideParticle(p);  // 9
      advect(p, dt);       // 10
      if (params_.auto_sleep.enabled) restOrStir<Kernel>(p, x_before[a]);
      ++a;
    } else {
      ++m.asleep;
    }
    shares[i] = measure(p, maxima);
  }
  maxima.foldInto(m);
}

template <int D, class T>
template <class Kernel>
bool MpmSolver<D, T>::sleepsThrough(int p) {
  int& calm = particles_.calm_steps[p];
  if (calm < params_.auto_sleep.steps) return false;
  // Asleep: it scattered its mass and its stress, both unchanged while it sleeps; it has no
  // velocity to gather and no deformation to update while its stencil rests.
  const V& x = particles_.x[p];
  if (!stencilMoves<Kernel>(x) && !touchedByMovingCollider(x)) {
    calm = params_.auto_sleep.steps + 1;  // slept through a step: see stillness()
    return true;
  }
  calm = 0;  // wakes, and moves this very step
  return false;
}

template <int D, class T>
template <class Kernel>
void MpmSolver<D, T>::restOrStir(int p, const V& x_before) {
  int& calm = particles_.calm_steps[p];
  const T speed = T(params_.auto_sleep.speed);
  const bool resting =
      particles_.v[p].squaredNorm() < speed * speed && !stencilMoves<Kernel>(x_before);
  calm = resting ? calm + 1 : 0;
  if (calm >= params_.auto_sleep.steps) {
    // Falls asleep at rest: its slow drift and its affine velocity stop feeding the grid's
    // momentum, and the damper's stress of that velocity gradient stops feeding its forces.
    if (material_.viscosity > 0) addDamperStress(p, -1);
    particles_.v[p].setZero();
    particles_.C[p].setZero();
  }
}

template <int D, class T>
template <class Kernel>
bool MpmSolver<D, T>::stencilMoves(const V& x) const {
  const T speed = T(params_.auto_sleep.speed);
  const T limit = speed * speed;
  const Stencil<D, Kernel, T> s(x, inv_h_);
  const int base = grid_.index(s.base);
  constexpr int S = Kernel::support;
  bool moves = false;  // every node read, no early exit: the loop stays branch-free
  if constexpr (D == 2) {
    for (int j = 0; j < S; ++j)
      for (int i = 0; i < S; ++i)
        moves |= fields_.velocity[base + j * grid_.stride[1] + i].squaredNorm() > limit;
  } else {
    for (int k = 0; k < S; ++k)
      for (int j = 0; j < S; ++j)
        for (int i = 0; i < S; ++i)
          moves |=
              fields_.velocity[base + k * grid_.stride[2] + j * grid_.stride[1] + i].squaredNorm() >
              limit;
  }
  return moves;
}

template <int D, class T>
bool MpmSolver<D, T>::touchedByMovingCollider(const V& x) const {
  if (!colliders_move_) return false;
  const Vec<D> at = x.template cast<Real>();
  for (size_t c = 0; c < colliders_.size(); ++c) {
    const Collider<D>& collider = colliders_[c];
    const bool moves = !collider.velocity.isZero(0) || !collider.spin.isZero(0);
    if (moves && collider.phi(at) < grid_.h) return true;  // no screen: it clears only contact
  }
  return false;
}

template <int D, class T>
template <class Transfer, class Kernel>
SNOWSIM_FLATTEN void MpmSolver<D, T>::scatterParticleAvx2(int p, PartialGrid& g, T dt) const {
  scatterParticle<Transfer, Kernel>(p, g, dt);
}

template <int D, class T>
template <class Transfer, class Kernel>
SNOWSIM_FLATTEN void MpmSolver<D, T>::scatterParticleAvx512(int p, PartialGrid& g, T dt) const {
  scatterParticle<Transfer, Kernel>(p, g, dt);
}

template <int D, class T>
template <class Transfer, class Kernel>
void MpmSolver<D, T>::scatterParticleOn(VectorIsa isa, int p, PartialGrid& g, T dt) const {
  switch (isa) {
    case VectorIsa::avx512:
      return scatterParticleAvx512<Transfer, Kernel>(p, g, dt);
    case VectorIsa::avx2:
      return scatterParticleAvx2<Transfer, Kernel>(p, g, dt);
    case VectorIsa::baseline:
      break;
  }
  scatterParticle<Transfer, Kernel>(p, g, dt);
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
  const T V0 = particles_.volume[p];
  const M stress = V0 > 0 ? M(-V0 * particles_.tau[p].matrix()) : M::Zero();
  const Stencil<D, Kernel, T> s(x, inv_h);
  if constexpr (Transfer::mls) {
    // MLS-MPM puts dt f_i straight into the momentum (Hu et al. 2018, section 5.1): node i
    // receives w (m v_p + (m C_p + dt D^-1 (-V_p^0 tau_p)) (x_i - x_p)), the mass and momentum
    // of eq. 1 with the affine part of APIC and the force of eq. 8 in one scatter.
    const M A = m * particles_.C[p] + (dt * inertia_inverse_) * stress;
    TensorStencil<D, Kernel, T>(grid_, s, x)
        .scatterAffine(m, mv, A, g.mass.data(), g.momentum.data());
  } else {
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
void MpmSolver<D, T>::placeScreens() {
  screens_.resize(colliders_.size());
  // Relative round-off of phi is about 1e-16 of the coordinates' size: 1e-9 leaves room.
  const Real margin = 1e-9 * (1 + grid_.extent().norm());
  for (size_t c = 0; c < colliders_.size(); ++c) {
    const Collider<D>& collider = colliders_[c];
    ColliderScreen& screen = screens_[c];
    screen.half_space = collider.shape == ColliderShape::HalfSpace;
    screen.normal = collider.rotation * collider.normal;
    screen.offset = screen.normal.dot(collider.position);
    screen.margin = margin * (1 + collider.position.norm());
    const Eigen::AlignedBox<Real, D> bounds = boundingBox(collider, screen.margin);
    screen.lo = bounds.min();
    screen.hi = bounds.max();
  }
  clear_lo_.setConstant(-std::numeric_limits<Real>::infinity());
  clear_hi_.setConstant(std::numeric_limits<Real>::infinity());
  every_collider_.clear();
  uncovered_colliders_.clear();
  for (int c = 0; c < static_cast<int>(colliders_.size()); ++c) {
    every_collider_.push_back(c);
    const ColliderScreen& screen = screens_[c];
    int axis = -1;  // the axis of an axis-aligned half space's normal
    for (int a = 0; a < D; ++a)
      if (screen.half_space && std::abs(screen.normal[a]) == 1) axis = a;
    if (axis < 0 || screen.normal.squaredNorm() != 1) {
      uncovered_colliders_.push_back(c);
      continue;
    }
    // Clear of it: normal[axis] x[axis] > offset + margin, where mayTouch is false.
    const Real bound = screen.offset + screen.margin;
    if (screen.normal[axis] > 0)
      clear_lo_[axis] = std::max(clear_lo_[axis], bound);
    else
      clear_hi_[axis] = std::min(clear_hi_[axis], -bound);
  }
}

template <int D, class T>
void MpmSolver<D, T>::collideNode(int k) {
  if (fields_.mass[k] > 0) collideAtNode(k, fields_.velocity[k]);
}

template <int D, class T>
void MpmSolver<D, T>::collideAtNode(int k, V& velocity) const {
  const Vec<D> x = grid_.position(grid_.coords(k));
  const std::vector<int>& near = collidersNear(x);
  if (near.empty()) return;
  if constexpr (double_precision) {
    for (const int c : near)
      if (mayTouch(c, x)) colliders_[c].collide(x, velocity);
  } else {  // the colliders work in double
    Vec<D> v = velocity.template cast<Real>();
    for (const int c : near)
      if (mayTouch(c, x)) colliders_[c].collide(x, v);
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
SNOWSIM_FLATTEN void MpmSolver<D, T>::gatherVelocityAvx2(int p) {
  gatherVelocity<Transfer, Kernel>(p);
}

template <int D, class T>
template <class Transfer, class Kernel>
SNOWSIM_FLATTEN void MpmSolver<D, T>::gatherVelocityAvx512(int p) {
  gatherVelocity<Transfer, Kernel>(p);
}

template <int D, class T>
template <class Transfer, class Kernel>
void MpmSolver<D, T>::gatherVelocityOn(VectorIsa isa, int p) {
  switch (isa) {
    case VectorIsa::avx512:
      return gatherVelocityAvx512<Transfer, Kernel>(p);
    case VectorIsa::avx2:
      return gatherVelocityAvx2<Transfer, Kernel>(p);
    case VectorIsa::baseline:
      break;
  }
  gatherVelocity<Transfer, Kernel>(p);
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
  // matrices (in 2D the call cost a twentieth of the step). Each entry is summed as Eigen's
  // unrolled sum is, a + (b + c) in 3D, so the results are Eigen's bit for bit.
  const M G = M::Identity() + dt * particles_.C[p];
  M trial;
#pragma GCC unroll 3  // GCC keeps these loops of three otherwise: twice the instructions
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
  const std::vector<int>& near = collidersNear(x);
  if (near.empty()) return;
  if constexpr (double_precision) {
    for (const int c : near)
      if (mayTouch(c, x)) colliders_[c].collide(x, particles_.v[p]);
  } else {
    Vec<D> v = particles_.v[p].template cast<Real>();
    bool touched = false;
    for (const int c : near)
      if (mayTouch(c, x)) {
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
  const std::vector<int>& near = collidersNear(x_double);
  if constexpr (double_precision) {
    for (const int c : near)
      if (mayTouch(c, x)) colliders_[c].pushOut(x);
  } else {
    bool touched = false;
    for (const int c : near)
      if (mayTouch(c, x_double)) {
        colliders_[c].pushOut(x_double);
        touched = true;
      }
    if (touched) x = x_double.template cast<T>();
  }
  x = x.cwiseMax(V::Zero()).cwiseMin(grid_.extent().template cast<T>());  // never leave the domain
}

template <int D, class T>
Real MpmSolver<D, T>::measure(int p, BatchMaxima& m) const {
  const T v = particles_.v[p].norm();
  m.finite = m.finite && std::isfinite(v) && particles_.x[p].allFinite();
  m.speed = std::max(m.speed, v);
  m.signal = std::max(m.signal, pWaveSpeed(lame(p), restDensity(p)) + v);
  // Kinetic plus gravitational energy, the latter from the origin (collectMeasures shifts it).
  return particles_.mass[p] *
         (T(0.5) * particles_.v[p].squaredNorm() - gravity_.dot(particles_.x[p]));
}

template <int D, class T>
void MpmSolver<D, T>::measureParticles() {
  part_measures_.resize(schedule_.prepare());
  schedule_.passOverParticles("measure particles", particles_.x, part_measures_,
                              [&](std::span<const int> batch, PartMeasure& m, Real* shares) {
                                BatchMaxima maxima;
                                for (size_t i = 0; i < batch.size(); ++i)
                                  shares[i] = measure(batch[i], maxima);
                                maxima.foldInto(m);
                              });
  collectMeasures();
}

template <int D, class T>
void MpmSolver<D, T>::collectMeasures() {
  schedule_.passDone();
  fastest_speed_ = fastest_signal_ = 0;
  finite_ = true;
  for (const PartMeasure& m : part_measures_) {  // maxima: exact in any order
    fastest_speed_ = std::max(fastest_speed_, m.speed);
    fastest_signal_ = std::max(fastest_signal_, m.signal);
    finite_ = finite_ && m.finite;
  }
  Real energy = schedule_.orderedSum();
  if (slabs_.distributed()) {  // the whole snow's, alike on every rank
    std::vector<Real> largest = {fastest_speed_, fastest_signal_, finite_ ? 0.0 : 1.0};
    energy = slabs_.maxAndSum(largest, energy);
    fastest_speed_ = largest[0];
    fastest_signal_ = largest[1];
    finite_ = largest[2] == 0;
  }
  // The gravitational energy counts from the domain's lowest point along gravity, so it is >= 0.
  Real lowest = 0;  // min over the domain box of -g.x
  for (int a = 0; a < D; ++a) lowest += std::min(Real(0), -gravity_[a] * grid_.extent()[a]);
  energy_ = energy - total_mass_ * lowest;
}

template <int D, class T>
void MpmSolver<D, T>::beforeFirstStep() {
  // The state as the first step finds it (a caller may have set velocities since construction).
  measureParticles();
  initial_energy_ = energy_;
}

template <int D, class T>
void MpmSolver<D, T>::scatter(Real dt) {
  const VectorIsa isa = vectorIsa();
  withTransferAndKernel(params_.transfer, params_.kernel, [&]<class Transfer, class Kernel>() {
    schedule_.scatterAlone(particles_.x, [&](int p, PartialGrid& g) {
      scatterParticleOn<Transfer, Kernel>(isa, p, g, dt);
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
    schedule_.passOverParticles("move particles", particles_.x, part_measures_,
                                [&](std::span<const int> batch, PartMeasure& m, Real* shares) {
                                  moveParticles<Transfer, Kernel>(batch, m, shares, dt, isa);
                                });
  });
  collectMeasures();
}

template <int D, class T>
Real MpmSolver<D, T>::cflTimeStep() const {
  // dt <= C h / (c + |v|)max, c = sqrt((lambda + 2 mu) / rho) with hardening (docs/mpm.md). With
  // a damper, a wave of rate omega = 2 s / h (s = c + |v|) damped at gamma = 2 s_d / h (s_d its
  // signal speed) is stable while (omega dt)^2 + 2 gamma dt <= 4: dt <= h / S with
  // S = (s_d + sqrt(s_d^2 + 4 s^2)) / 2, which is s without the damper and s_d without the wave.
  const Real s = fastest_signal_, s_d = viscous_speed_;
  const Real signal = s_d > 0 ? (s_d + std::sqrt(s_d * s_d + 4 * s * s)) / 2 : s;
  const Real fastest = std::max(signal, collider_speed_);
  return fastest > 0 ? params_.cfl * grid_.h / fastest : std::numeric_limits<Real>::infinity();
}

template <int D, class T>
Real MpmSolver<D, T>::advectionTimeStep() const {
  // The semi-implicit step has no elastic wave limit, only advection: dt <= C h / |v|max.
  const Real fastest = std::max(fastest_speed_, collider_speed_);
  return fastest > 0 ? params_.cfl * grid_.h / fastest : std::numeric_limits<Real>::infinity();
}

template <int D, class T>
Real MpmSolver<D, T>::stableTimeStep() const {
  if (!params_.adaptive_dt) return std::numeric_limits<Real>::infinity();
  return semiImplicit() ? advectionTimeStep() : cflTimeStep();
}

template <int D, class T>
StepLimit MpmSolver<D, T>::stepLimit() const {
  // The particle of the largest signal speed: c_p + |v_p| for the CFL step (which a damper's
  // constant term shortens further), |v_p| semi-implicit.
  StepLimit limit{stableTimeStep()};
  Real largest = -1;
  for (int p = 0; p < particles_.size(); ++p) {
    const Real speed = particles_.v[p].norm();
    const Real wave = semiImplicit() ? 0 : Real(pWaveSpeed<T>(lame(p), restDensity(p)));
    if (speed + wave <= largest) continue;
    largest = speed + wave;
    limit.particle_speed = speed;
    limit.wave_speed = wave;
    limit.plastic_j = particles_.J_P[p];
    limit.hardening = particles_.hardening[p];
  }
  // Across ranks, the particle of the largest signal speed of all (the first rank's of equals).
  struct Candidate {
    Real signal;
    StepLimit limit;
  };
  const std::vector<Candidate> ranks = slabs_.gatherEach(Candidate{largest, limit});
  return std::max_element(
             ranks.begin(), ranks.end(),
             [](const Candidate& a, const Candidate& b) { return a.signal < b.signal; })
      ->limit;
}

template <int D, class T>
void MpmSolver<D, T>::checkDivergence(Real dt) const {
  // An explicit step beyond its limit grows exponentially; a particle crossing more than a cell
  // per step or a non-finite velocity is where we stop it.
  // The snow starts unstrained and plasticity, friction and the transfers only dissipate, so
  // without a moving collider its kinetic plus gravitational energy cannot grow; an unstable
  // explicit step can make it grow while every particle still moves less than a cell per step.
  const bool energy_grew =
      !colliders_move_ && energy_ > kEnergyGrowthLimit * initial_energy_ + 1e-12 * total_mass_;
  if (finite_ && fastest_speed_ * dt <= grid_.h && !energy_grew) return;
  std::ostringstream s;
  s << "MPM blew up at step " << this->steps() << " (t = " << this->time() << " s): largest speed ";
  if (!finite_)
    s << "overflowed (non-finite)";
  else if (fastest_speed_ * dt > grid_.h)
    s << fastest_speed_ << " m/s moves a particle more than a cell per step";
  else
    s << fastest_speed_ << " m/s, and the kinetic plus gravitational energy grew to "
      << energy_ / initial_energy_
      << " times its initial value, which no force of the scene can do";
  s << "; dt = " << dt << " s";
  if (step_when_exceeded_ >= 0)
    s << " exceeded the CFL limit from step " << step_when_exceeded_ << " on, when that limit was "
      << limit_when_exceeded_ << " s; set mpm.adaptive_dt=true or time.dt below "
      << limit_when_exceeded_;
  else
    s << " kept within the CFL limit; lower mpm.cfl";
  throw SimulationError(s.str());
}

template <int D, class T>
void MpmSolver<D, T>::describe(Snapshot& snapshot) const {
  const MpmParticles<D, T>& particles = outputParticles();
  const int n = particles.size();
  snapshot.density.resize(n);
  snapshot.plastic_j.resize(n);
  for (int p = 0; p < n; ++p) {  // in creation order, as the snapshot's positions
    const T J = particles.F_E[p].determinant() * particles.J_P[p];
    const int id = particles.id[p];
    snapshot.density[id] = static_cast<float>(particles.mass[p] / (particles.volume[p] * J));
    snapshot.plastic_j[id] = static_cast<float>(particles.J_P[p]);
  }
  const Real area = grid_.h * grid_.h;
  if (D == 2 && cracks_) {
    // Near an open crack the grid's own mass is side 0's alone: every field's is scattered again,
    // from the particles where they are now. One process: open cracks refuse MPI.
    std::vector<T> mass(grid_.nodeCount());
    withKernel(params_.kernel, [&]<class Kernel>() {
      for (int p = 0; p < n; ++p)
        forEachStencilNode<D, Kernel>(
            grid_, particles.x[p], [&](int k, T w, const V&) { mass[k] += w * particles.mass[p]; });
    });
    domainNodeValues(
        grid_, [&](int k) { return mass[k] / area; }, snapshot.grid.node_density);
  } else {
    domainNodeValues(
        grid_, [&](int k) { return fields_.mass[k] / area; }, snapshot.grid.node_density);
    slabs_.combineNodeValues(snapshot.grid.node_density);
  }
}

template <int D, class T>
const MpmParticles<D, T>& MpmSolver<D, T>::outputParticles() const {
  if (!slabs_.distributed()) return particles_;
  if (gathered_at_step_ != this->steps()) {
    slabs_.gatherById(particles_, gathered_);
    gathered_at_step_ = this->steps();
  }
  return gathered_;
}

template <int D, class T>
const Particles<D>& MpmSolver<D, T>::particles() const {
  const MpmParticles<D, T>& particles = outputParticles();
  if constexpr (double_precision) {
    return particles;
  } else {
    if (converted_at_step_ == this->steps()) return particles_in_double_;
    converted_at_step_ = this->steps();
    Particles<D>& out = particles_in_double_;
    castEach(particles.x, out.x);
    castEach(particles.v, out.v);
    out.mass.assign(particles.mass.begin(), particles.mass.end());
    out.volume.assign(particles.volume.begin(), particles.volume.end());
    out.body = particles.body;
    out.id = particles.id;
    return out;
  }
}

template <int D, class T>
void MpmSolver<D, T>::saveSolverState(StateWriter& out) const {
  if (!slabs_.distributed()) return saveRankState(out);
  // Each rank's state in rank order, on rank 0, which writes the file (the others' writers discard
  // what they are given): a resume under as many ranks takes the very steps the run would have.
  StateWriter mine;
  saveRankState(mine);
  const std::vector<std::string> ranks = slabs_.gatherToFirst(mine.bytes());
  out.value(static_cast<std::uint32_t>(ranks.size()));
  for (const std::string& bytes : ranks) {  // as an array of chars, without copying it into one
    out.value(static_cast<std::uint64_t>(bytes.size()));
    out.append(bytes);
  }
}

template <int D, class T>
void MpmSolver<D, T>::loadSolverState(StateReader& in) {
  if (!slabs_.distributed()) return loadRankState(in);
  const auto ranks = in.value<std::uint32_t>();
  if (static_cast<int>(ranks) != slabs_.ranks())
    in.fail("a run across " + std::to_string(ranks) +
            " MPI ranks resumes across as many (mpirun -np " + std::to_string(ranks) + "), not " +
            std::to_string(slabs_.ranks()));
  std::vector<char> mine;
  for (int r = 0; r < slabs_.ranks(); ++r) {
    std::vector<char> bytes;
    in.array(bytes);
    if (r == slabs_.rank()) mine.swap(bytes);
  }
  StateReader rank_state(std::string_view(mine.data(), mine.size()), in.file());
  loadRankState(rank_state);
  rank_state.finish();
}

template <int D, class T>
void MpmSolver<D, T>::saveRankState(StateWriter& out) const {
  saveParticleArrays(out, particles_);
  for (const Collider<D>& c : colliders_) out.value(c.position);  // moved by the steps
  saveScheduleState(out, schedule_);
  for (const Real r :
       {fastest_speed_, fastest_signal_, energy_, initial_energy_, limit_when_exceeded_})
    out.value(r);
  out.value(finite_);
  out.value(step_when_exceeded_);
  out.value(solves_);
  out.value(sleep_tally_);
  if (slabs_.distributed()) slabs_.saveState(out);
}

template <int D, class T>
void MpmSolver<D, T>::loadRankState(StateReader& in) {
  if (slabs_.distributed()) {  // as many particles as the rank had, of any ids of the scene
    particles_.forEachArray([&](auto& a) {
      in.array(a);
      if (!a.empty() && a.size() != particles_.x.size()) in.fail("arrays of unequal lengths");
    });
    for (const int id : particles_.id)
      if (id < 0 || id >= total_particles_) in.fail("particle id " + std::to_string(id));
    schedule_.resize(particles_.x);
  } else {
    loadParticleArrays(in, particles_);
  }
  for (Collider<D>& c : colliders_) in.value(c.position);
  loadScheduleState(in, schedule_);
  for (Real* r :
       {&fastest_speed_, &fastest_signal_, &energy_, &initial_energy_, &limit_when_exceeded_})
    in.value(*r);
  in.value(finite_);
  in.value(step_when_exceeded_);
  in.value(solves_);
  in.value(sleep_tally_);
  if (slabs_.distributed()) slabs_.loadState(in);
  // Each step writes the grid nodes near the snow and leaves the rest zero, as here.
  fields_.resize(grid_.nodeCount());
  converted_at_step_ = gathered_at_step_ = -1;
}

template class MpmSolver<2, double>;
template class MpmSolver<3, double>;
template class MpmSolver<2, float>;
template class MpmSolver<3, float>;

}  // namespace snowsim
