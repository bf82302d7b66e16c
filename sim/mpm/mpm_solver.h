// MPM snow (Stomakhin, Schroeder, Chai, Teran, Selle 2013, "A Material Point Method for Snow
// Simulation"), explicit symplectic Euler or the paper's semi-implicit solve, PIC/FLIP, APIC or
// MLS-MPM transfers, quadratic or cubic B-splines. stepWith() is the paper's section 4 list of
// stages; each stage is a per-particle or per-node function below, and how they run over threads
// (binning, rows and colours, partial grids, sorting) is the schedule's (sim/parallel/). The
// optional features enter the step as parts chosen once per step and passed to it as template
// arguments: the crack opening's transfers (sim/mpm/crack_opening.h) and auto-sleep
// (sim/mpm/auto_sleep.h). The other MPI ranks enter through the rank state
// (sim/distributed/rank_state.h), whose calls return at once in one process. The state and the
// arithmetic of the explicit step are in the precision T, double or float (mpm.precision); what the
// solver hands out is in double, but for snapshots, which it writes from its own arrays.
#pragma once

#include <limits>
#include <memory>
#include <span>
#include <type_traits>
#include <vector>

#include "sim/core/collider.h"
#include "sim/core/collider_screen.h"
#include "sim/core/grid.h"
#include "sim/core/stencil.h"
#include "sim/distributed/rank_state.h"
#include "sim/mpm/auto_sleep.h"
#include "sim/mpm/crack_opening.h"
#include "sim/mpm/implicit_solve.h"
#include "sim/mpm/mpm_particles.h"
#include "sim/mpm/snow_material.h"
#include "sim/parallel/particle_grid_schedule.h"
#include "sim/scene/scene.h"
#include "sim/solver.h"

namespace snowsim {

template <int D, class T = Real>
class MpmSolver final : public Solver<D> {
 public:
  static constexpr bool double_precision = std::is_same_v<T, Real>;

  // threads: how many threads a step may use; 0 takes the OpenMP default (OMP_NUM_THREADS, else
  // every core). A float solver runs the explicit integrator only. world: the ranks the run is
  // split across, each building the same solver (sim/distributed/).
  MpmSolver(const Scene& scene, Particles<D> particles, int threads = 0,
            RankExchange& world = oneProcess());

  Real stableTimeStep() const override;
  StepLimit stepLimit() const override;
  std::vector<StageSeconds> stageSeconds() const override { return schedule_.stageSeconds(); }
  // In double: a float solver's particles converted, once per step that asks for them.
  const Particles<D>& particles() const override;
  int particleCount() const override { return total_particles_; }
  void snapshotParticles(const Scene& scene, Snapshot& snapshot) const override {
    putParticles(outputParticles(), scene, snapshot);
  }
  void describe(Snapshot& snapshot) const override;
  SolverStatistics statistics() const override {
    return {solves_, sleeper_ ? sleeper_->tally() : SleepTally{}, ranks_.slabs().traffic()};
  }

  const GridGeometry<D>& grid() const { return grid_; }
  const GridFields<D, T>& fields() const { return fields_; }
  const std::vector<Mat<D, T>>& elasticGradient() const { return particles_.F_E; }
  const std::vector<T>& plasticJ() const { return particles_.J_P; }
  const std::vector<Mat<D, T>>& affine() const { return particles_.C; }
  LameOf<T> lame(int p) const { return lameOf(unhardened_lame_, particles_.hardening[p]); }
  // rho_p^0, which the state does not keep: on the lattice its body's density (what V_p^0 was made
  // from), else its mass over its initial volume (which can round to the last bit differently
  // from the density the volume was made from).
  T restDensity(int p) const {
    return params_.initial_volume == InitialVolume::Lattice
               ? T(body_density_[particles_.body[p]])
               : particles_.mass[p] / particles_.volume[p];
  }
  const std::vector<Symmetric<D, T>>& stress() const { return particles_.tau; }
  // Auto-sleep: how many particle scatters this process's still blocks added, kept, instead of
  // scattering again (not checkpointed: counted from construction or resume).
  long keptScatters() const { return schedule_.keptScatters(); }
  // Auto-sleep: whether particle p (in the order of particles()) is asleep after the last step.
  bool asleep(int p) const { return sleeper_ && sleeper_->asleep(particles_.calm_steps[p]); }
  const SnowMaterial& material() const { return material_; }
  // The colliders where they were at the start of the last step.
  const std::vector<Collider<D>>& colliders() const { return colliders_; }
  const MpmParams& params() const { return params_; }
  // The CFL step C h / (c + |v|)max of the current state (shorter with a damper, cflTimeStep),
  // whether or not dt is adaptive, and at most C h / (a collider's fastest surface speed).
  Real cflTimeStep() const;
  // The advection limit C h / |v|max that bounds the semi-implicit step (colliders as above).
  Real advectionTimeStep() const;
  // The Krylov solve of the last semi-implicit step.
  const KrylovResult& lastImplicitSolve() const { return last_solve_; }

  void setThreads(int threads) { schedule_.setThreads(threads); }  // from the next step on
  // Where the steps' time goes, stage by stage and thread by thread (bench/mpm_bench prints it).
  void profileStages(bool on) { schedule_.profileStages(on); }
  int profiledThreads() const { return schedule_.profiledThreads(); }
  const std::vector<StageTime>& stageTimes(int thread) const {
    return schedule_.stageTimes(thread);
  }
  long binnings() const { return schedule_.binnings(); }
  // The split across MPI ranks (one rank when not launched by mpirun): this rank's slab, and what
  // it sent to the others.
  const SlabDecomposition<D>& slabs() const { return ranks_.slabs(); }
  // This rank's particles, in the order it stores them (all of them on one rank).
  int ownParticles() const { return particles_.size(); }
  // Every rank's particles in the order of their ids on rank 0, once per step that asks, none on
  // the other ranks (this process's when not distributed): what the output sees.
  const MpmParticles<D, T>& outputParticles() const {
    return ranks_.output(particles_, this->steps());
  }

  // Stages run alone, for tests: P2G (1 + 3), which drops a scatter no grid stage summed; the
  // grid velocities from it (4, no collisions); G2P and the particle updates (8, 7, 9, 10).
  void scatter(Real dt);
  void updateGridVelocities(Real dt);
  void updateParticles(Real dt);

 private:
  using V = Vec<D, T>;
  using M = Mat<D, T>;
  using Schedule = ParticleGridSchedule<D, MpmParticles<D, T>>;
  using PartialGrid = typename Schedule::PartialGrid;

  bool semiImplicit() const {
    return double_precision && params_.integrator == MpmIntegrator::SemiImplicit;
  }
  void beforeFirstStep() override;
  void advance(Real dt) override;
  // After a step across ranks: the particles that left their slab move to their new rank.
  void migrate();
  void checkDivergence(Real dt) const override;
  void saveSolverState(StateWriter& out) const override;
  void loadSolverState(StateReader& in) override;
  // What this rank holds; under MPI the checkpoint holds each rank's in turn (RankState).
  void saveRankState(StateWriter& out) const;
  void loadRankState(StateReader& in);
  // f(opening, sleep) with this step's parts: the crack opening's transfers once some snow is
  // damaged (MLS only), else one velocity a node; auto-sleep's, else NoSleep.
  template <class Transfer, class Kernel, class F>
  void withParts(F&& f);
  SleepStep<D, T> sleepStep() {
    return sleeper_->step<D, T>(particles_.calm_steps, grid_, colliders_, colliders_move_);
  }
  // The step: stages 1-10 of the paper's section 4 with the parts given.
  template <class Transfer, class Kernel, class Opening, class Sleep>
  void stepWith(T dt, Opening& opening, Sleep& sleep);

  // The J_P a points body's file gives (a run continued from its frame); the elastic part starts
  // unstrained, as the file does not hold F_E.
  void continuePlasticity(const Scene& scene);
  // Per particle p, in the paper's order.
  // 1 + 3. Mass and momentum (eq. 1) and the force (eq. 7) of one particle into a partial grid.
  template <class Transfer, class Kernel>
  void scatterParticle(int p, PartialGrid& g, T dt) const;
  // 2. First step only: rho_p^0 and V_p^0 from the grid (section 4 step 2).
  template <class Kernel>
  void estimateVolume(int p);
  // 8. v_p (PIC/FLIP, APIC or MLS) and its velocity gradient.
  template <class Transfer, class Kernel>
  void gatherVelocity(int p);
  // 1 + 3 and 8 in the build for isa (runFor): one build of each per transfer and kernel, which
  // every step's parts share.
  template <class Transfer, class Kernel>
  void scatterParticleOn(VectorIsa isa, int p, PartialGrid& g, T dt) const {
    runFor(isa, [&] { scatterParticle<Transfer, Kernel>(p, g, dt); });
  }
  template <class Transfer, class Kernel>
  void gatherVelocityOn(VectorIsa isa, int p) {
    runFor(isa, [&] { gatherVelocity<Transfer, Kernel>(p); });
  }
  // 7. F_E <- (I + dt grad v) F_E (eq. 10).
  void trialDeformation(int p, T dt);
  // 7, then: plasticity (eqs. 11-12) and hardening (eq. 8) of particles ps, in 3D eight at a time
  // in vector lanes (the build for isa), and the stress tau of their new F_E, which the next
  // scatter reads: whatever changes F_E must set tau.
  template <class Transfer>
  void returnMapping(std::span<const int> ps, VectorIsa isa);
  // tau += sign times the damper's stress of C (material.viscosity): 1 after the return
  // mapping, -1 as the particle falls asleep and C stops.
  void addDamperStress(int p, T sign);
  // Auto-sleep: particle p falls asleep at rest, and its slow drift and its affine velocity stop
  // feeding the grid's momentum, and the damper's stress of that velocity gradient its forces.
  void fallAsleep(int p);
  void collideParticle(int p);  // 9. particle-based body collisions (section 8)
  void advect(int p, T dt);     // 10. x += dt v, kept out of colliders and in the domain

  // Per grid node k, after the scatter.
  template <class Transfer>
  void velocityFromMomentum(int k);  // 4. v_i = momentum / m_i
  template <class Transfer>
  void accelerate(int k, T dt);           // 4. v* = v + dt f / m + dt g (eq. 8 explicit)
  void collideAtNode(int k, V& v) const;  // 5. grid-based body collisions (section 8)

  // 5 + 6, semi-implicit: collide v*, then solve for v (section 9).
  void solveImplicitVelocities(Real dt);

  // What the particle pass measures: the fastest particles of one part, for the CFL limits and
  // the blow-up check; the energy is summed by the schedule.
  struct PartMeasure {
    Real speed = 0, signal = 0;
    bool finite = true;
    long asleep = 0;  // particles that slept through the pass
  };
  // A batch's maxima, held in registers over its loop and folded into its part's measure after
  // it: a running maximum kept in memory makes each particle wait on the last one's store.
  struct BatchMaxima {
    T speed = 0, signal = 0;
    bool finite = true;
    void foldInto(PartMeasure& m) const {
      m.speed = std::max<Real>(m.speed, speed);
      m.signal = std::max<Real>(m.signal, signal);
      m.finite = m.finite && finite;
    }
  };
  // 8, 7, 9, 10 for a batch of the particle pass, each particle measured into m; shares[i] is
  // batch[i]'s energy.
  template <class Transfer, class Kernel, class Opening, class Sleep>
  void moveParticles(std::span<const int> batch, PartMeasure& m, Real* shares, T dt, VectorIsa isa,
                     Opening& opening, Sleep& sleep);
  // Measures particle p into its batch's maxima and returns its energy.
  [[gnu::always_inline]] inline Real measure(int p, BatchMaxima& m) const;
  void measureParticles();  // the speeds and energy of the current state
  void collectMeasures();   // after each particle pass

  MpmParams params_;
  SnowMaterial material_;
  LameOf<T> unhardened_lame_;  // mu0 and lambda0 in T, which each particle's hardening scales
  V gravity_;
  MpmParticles<D, T> particles_;
  GridGeometry<D> grid_;
  T inv_h_;            // 1 / h
  T inertia_inverse_;  // D_p^-1 of APIC for the scene's kernel (transfer_scheme.h)
  GridFields<D, T> fields_;
  // The colliders where they are at the start of the step, and their screens.
  std::vector<Collider<D>> colliders_;
  ColliderScreens<D> screens_;
  Real collider_speed_ = 0;  // the fastest any point of a collider moves (fastestColliderSpeed)
  // The damper's signal speed 4 eta / (rho h): an explicit step resolves the damper's grid-scale
  // rate as it does the elastic wave (docs/mpm.md).
  Real viscous_speed_ = 0;
  std::vector<Real> body_density_;  // rest density of each body of the scene
  Schedule schedule_;
  RankState<D, MpmParticles<D, T>> ranks_;
  std::unique_ptr<CrackOpening<D, T>> cracks_;  // with mpm.open_cracks
  bool cracked_last_step_ = false;
  std::unique_ptr<AutoSleeper> sleeper_;  // with mpm.auto_sleep
  ImplicitVelocitySolve<D> implicit_;
  std::vector<Mat<D>> node_free_;  // per grid node: components the collisions left free
  KrylovResult last_solve_;
  SolveTally solves_;
  // Measured once at the end of each step, read by the CFL limits and the blow-up check.
  std::vector<PartMeasure> part_measures_;
  Real fastest_speed_ = 0;   // max |v_p|
  Real fastest_signal_ = 0;  // max (c_p + |v_p|), c_p the P-wave speed
  bool finite_ = true;       // every position and velocity finite
  Real energy_ = 0;          // kinetic + gravitational (J)
  Real initial_energy_ = 0;
  Real total_mass_ = 0;
  int total_particles_ = 0;      // of every rank
  bool colliders_move_ = false;  // a moving collider adds energy: no energy check then
  // How far the energy may grow before a step counts as blown up: stable steps keep it far
  // below, unstable ones grow it well past (docs/mpm.md measures both).
  static constexpr Real kEnergyGrowthLimit = 1.05;
  // A float solver's particles in double, and the step they were converted at.
  mutable Particles<D> particles_in_double_;
  mutable long converted_at_step_ = -1;
  // The stable dt at the first step a fixed dt exceeded it, before the blow-up inflated the speeds
  // (what the blow-up message recommends), and that step.
  Real limit_when_exceeded_ = std::numeric_limits<Real>::infinity();
  long step_when_exceeded_ = -1;
};

// Inlined where the particle passes call it, so that the maxima stay in registers.
template <int D, class T>
inline Real MpmSolver<D, T>::measure(int p, BatchMaxima& m) const {
  const T v = particles_.v[p].norm();
  m.finite = m.finite && std::isfinite(v) && particles_.x[p].allFinite();
  m.speed = std::max(m.speed, v);
  m.signal = std::max(m.signal, pWaveSpeed(lame(p), restDensity(p)) + v);
  // Kinetic plus gravitational energy, the latter from the origin (collectMeasures shifts it).
  return particles_.mass[p] *
         (T(0.5) * particles_.v[p].squaredNorm() - gravity_.dot(particles_.x[p]));
}

}  // namespace snowsim
