// What the MPM solver measures of its state and hands out: the step's limits and the blow-up
// check, snapshots, the particles in double, and checkpoints. The step itself is mpm_solver.cpp.
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "sim/core/errors.h"
#include "sim/io/schedule_state.h"
#include "sim/mpm/mpm_solver.h"

namespace snowsim {

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
  ranks_.combineMeasures(fastest_speed_, fastest_signal_, finite_, energy);
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
  const std::vector<Candidate> ranks = ranks_.gatherEach(Candidate{largest, limit});
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
    // from the particles where they are now (on rank 0 across ranks: it holds them all here).
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
    ranks_.combineNodeValues(snapshot.grid.node_density);
  }
}

template <int D, class T>
const Particles<D>& MpmSolver<D, T>::particles() const {
  const MpmParticles<D, T>& particles = outputParticles();
  if constexpr (double_precision) {
    return particles;
  } else {
    if (converted_at_step_ == this->steps()) return particles_in_double_;
    converted_at_step_ = this->steps();
    convertParticles(particles, particles_in_double_);
    return particles_in_double_;
  }
}

template <int D, class T>
void MpmSolver<D, T>::saveSolverState(StateWriter& out) const {
  ranks_.save(out, [&](StateWriter& rank) { saveRankState(rank); });
}

template <int D, class T>
void MpmSolver<D, T>::loadSolverState(StateReader& in) {
  ranks_.load(in, [&](StateReader& rank) { loadRankState(rank); });
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
  out.value(sleeper_ ? sleeper_->tally() : SleepTally{});
  if (cracks_) cracks_->save(out);  // the damage field the next step reads
  ranks_.saveSlabs(out);
}

template <int D, class T>
void MpmSolver<D, T>::loadRankState(StateReader& in) {
  if (ranks_.loadParticles(in, particles_, total_particles_)) schedule_.resize(particles_.x);
  for (Collider<D>& c : colliders_) in.value(c.position);
  loadScheduleState(in, schedule_);
  for (Real* r :
       {&fastest_speed_, &fastest_signal_, &energy_, &initial_energy_, &limit_when_exceeded_})
    in.value(*r);
  in.value(finite_);
  in.value(step_when_exceeded_);
  in.value(solves_);
  SleepTally sleep;
  in.value(sleep);
  if (sleeper_) sleeper_->restore(sleep);
  if (cracks_) cracks_->load(in);
  ranks_.loadSlabs(in);
  // Each step writes the grid nodes near the snow and leaves the rest zero, as here.
  fields_.resize(grid_.nodeCount());
  converted_at_step_ = -1;
}

// The class is instantiated in mpm_solver.cpp; these are the members defined here.
#define SNOWSIM_MPM_SOLVER_STATE(D, T)                                \
  template void MpmSolver<D, T>::measureParticles();                  \
  template void MpmSolver<D, T>::collectMeasures();                   \
  template void MpmSolver<D, T>::beforeFirstStep();                   \
  template Real MpmSolver<D, T>::cflTimeStep() const;                 \
  template Real MpmSolver<D, T>::advectionTimeStep() const;           \
  template Real MpmSolver<D, T>::stableTimeStep() const;              \
  template StepLimit MpmSolver<D, T>::stepLimit() const;              \
  template void MpmSolver<D, T>::checkDivergence(Real) const;         \
  template void MpmSolver<D, T>::describe(Snapshot&) const;           \
  template const Particles<D>& MpmSolver<D, T>::particles() const;    \
  template void MpmSolver<D, T>::saveSolverState(StateWriter&) const; \
  template void MpmSolver<D, T>::loadSolverState(StateReader&);       \
  template void MpmSolver<D, T>::saveRankState(StateWriter&) const;   \
  template void MpmSolver<D, T>::loadRankState(StateReader&);
SNOWSIM_MPM_SOLVER_STATE(2, double)
SNOWSIM_MPM_SOLVER_STATE(3, double)
SNOWSIM_MPM_SOLVER_STATE(2, float)
SNOWSIM_MPM_SOLVER_STATE(3, float)
#undef SNOWSIM_MPM_SOLVER_STATE

}  // namespace snowsim
