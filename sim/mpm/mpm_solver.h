// MPM snow (Stomakhin, Schroeder, Chai, Teran, Selle 2013, "A Material Point Method for Snow
// Simulation"), explicit symplectic Euler or the paper's semi-implicit solve, PIC/FLIP, APIC or
// MLS-MPM transfers, quadratic or cubic B-splines. step() is the paper's section 4 list of
// stages; each stage is a per-particle or per-node function below, and how they run over threads
// (binning, rows and colours, partial grids, sorting) is the schedule's (sim/parallel/). The state
// and the arithmetic of the explicit step are in the precision T, double or float
// (mpm.precision); what the solver hands out is in double, but for snapshots, which it writes from
// its own arrays.
#pragma once

#include <limits>
#include <memory>
#include <span>
#include <type_traits>
#include <vector>

#include "sim/core/collider.h"
#include "sim/core/grid.h"
#include "sim/core/stencil.h"
#include "sim/distributed/slab_decomposition.h"
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
  SolveTally implicitSolves() const override { return solves_; }
  SleepTally autoSleep() const override { return sleep_tally_; }
  std::vector<RankTraffic> rankTraffic() const override { return slabs_.everyRanksTraffic(); }

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
  bool asleep(int p) const {
    return params_.auto_sleep.enabled && particles_.calm_steps[p] >= params_.auto_sleep.steps;
  }
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
  const SlabDecomposition<D>& slabs() const { return slabs_; }
  // This rank's particles, in the order it stores them (all of them on one rank).
  int ownParticles() const { return particles_.size(); }

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
  void checkDivergence(Real dt) const override;
  void saveSolverState(StateWriter& out) const override;
  void loadSolverState(StateReader& in) override;
  // What this rank holds; under MPI the checkpoint holds each rank's in turn.
  void saveRankState(StateWriter& out) const;
  void loadRankState(StateReader& in);
  // Every rank's particles in the order of their ids on rank 0, once per step that asks, none on
  // the other ranks (this process's when not distributed): what the output sees.
  const MpmParticles<D, T>& outputParticles() const;
  template <class Transfer, class Kernel>
  void stepWith(T dt);
  // The MLS step with mpm.open_cracks: the damage field and the sides before the scatter, and
  // each stage with the crack opening's fields beside the grid's (sim/mpm/crack_opening.h).
  template <class Kernel>
  void stepWithCracks(T dt);
  // Whether particle p has no strength left (material.fracture_strain), and its damage.
  bool failed(int p) const { return strengthLeft<T>(material_, particles_.J_P[p]) <= 0; }
  T damage(int p) const { return 1 - strengthLeft<T>(material_, particles_.J_P[p]); }
  // 1 + 3 and 8 of MLS with the crack opening's sides.
  template <class Kernel>
  void scatterParticleWithCracks(int p, PartialGrid& g, T dt) const;
  template <class Kernel>
  void gatherVelocityWithCracks(int p);

  // The J_P a points body's file gives (a run continued from its frame); the elastic part starts
  // unstrained, as the file does not hold F_E.
  void continuePlasticity(const Scene& scene);
  // Per particle p, in the paper's order.
  // 1 + 3. Mass and momentum (eq. 1) and the force (eq. 7) of one particle into a partial grid.
  template <class Transfer, class Kernel>
  void scatterParticle(int p, PartialGrid& g, T dt) const;
  // The same, compiled for AVX2 and for AVX-512, called where vectorIsa() says the processor has
  // them. The same arithmetic (no contraction into fused multiply-adds), so the same results.
  template <class Transfer, class Kernel>
  SNOWSIM_TARGET_AVX2 void scatterParticleAvx2(int p, PartialGrid& g, T dt) const;
  template <class Transfer, class Kernel>
  SNOWSIM_TARGET_AVX512 void scatterParticleAvx512(int p, PartialGrid& g, T dt) const;
  template <class Transfer, class Kernel>  // the build for isa
  void scatterParticleOn(VectorIsa isa, int p, PartialGrid& g, T dt) const;
  // 2. First step only: rho_p^0 and V_p^0 from the grid (section 4 step 2).
  template <class Kernel>
  void estimateVolume(int p);
  // 8. v_p (PIC/FLIP, APIC or MLS) and its velocity gradient.
  template <class Transfer, class Kernel>
  void gatherVelocity(int p);
  template <class Transfer, class Kernel>  // as scatterParticleAvx2 and Avx512
  SNOWSIM_TARGET_AVX2 void gatherVelocityAvx2(int p);
  template <class Transfer, class Kernel>
  SNOWSIM_TARGET_AVX512 void gatherVelocityAvx512(int p);
  template <class Transfer, class Kernel>  // the build for isa
  void gatherVelocityOn(VectorIsa isa, int p);
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
  void collideParticle(int p);  // 9. particle-based body collisions (section 8)
  void advect(int p, T dt);     // 10. x += dt v, kept out of colliders and in the domain

  // Per grid node k, after the scatter.
  template <class Transfer>
  void velocityFromMomentum(int k);  // 4. v_i = momentum / m_i
  template <class Transfer>
  void accelerate(int k, T dt);           // 4. v* = v + dt f / m + dt g (eq. 8 explicit)
  void collideNode(int k);                // 5. grid-based body collisions (section 8)
  void collideAtNode(int k, V& v) const;  // 5 for a velocity v at node k

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
  template <class Transfer, class Kernel>
  void moveParticles(std::span<const int> batch, PartMeasure& m, Real* shares, T dt, VectorIsa isa);
  // Auto-sleep: whether particle p sleeps through this step (waking it if its stencil or a
  // collider moves), and after it moved from x_before, whether it has rested long enough to
  // fall asleep.
  template <class Kernel>
  bool sleepsThrough(int p);
  template <class Kernel>
  void restOrStir(int p, const V& x_before);
  // For the scatter (ParticleGridSchedule::scatter): 0 while particle p moves; 1 once it fell
  // asleep (no velocity, no affine velocity, a deformation that stays); 2 once it also slept
  // through the last particle pass, so that nothing of it changed since the last scatter.
  // calm_steps counts to the sleep steps while it rests awake, and is one more once it slept.
  int stillness(int p) const {
    const int calm = particles_.calm_steps[p], steps = params_.auto_sleep.steps;
    return calm > steps ? 2 : calm == steps ? 1 : 0;
  }
  // Auto-sleep: whether a node of the stencil at x moves faster than the sleep speed, and whether
  // a moving collider is within a cell of x.
  template <class Kernel>
  bool stencilMoves(const V& x) const;
  bool touchedByMovingCollider(const V& x) const;
  // Measures particle p into its batch's maxima and returns its energy. Inlined, so that the
  // maxima stay in registers.
  [[gnu::always_inline]] inline Real measure(int p, BatchMaxima& m) const;
  void measureParticles();  // the speeds and energy of the current state
  void collectMeasures();   // after each particle pass
  void countSleepers();     // after each step's particle pass, with auto-sleep

  MpmParams params_;
  SnowMaterial material_;
  LameOf<T> unhardened_lame_;  // mu0 and lambda0 in T, which each particle's hardening scales
  V gravity_;
  MpmParticles<D, T> particles_;
  GridGeometry<D> grid_;
  T inv_h_;            // 1 / h
  T inertia_inverse_;  // D_p^-1 of APIC for the scene's kernel (transfer_scheme.h)
  GridFields<D, T> fields_;
  // The colliders where they are at the start of the step.
  std::vector<Collider<D>> colliders_;
  // Per collider, a cheap test that passes over it for a point well clear of it (Collider::phi
  // is a call and a rotation), set with the colliders' poses: a half space's plane in world
  // coordinates, a sphere's, a box's or a mesh's world-axis bounding box, each with a margin far
  // beyond the round-off between the two ways of computing the distance, so a point it passes
  // over is one phi puts outside. Drums are always tested (their box spans every axis).
  struct ColliderScreen {
    Vec<D> normal = Vec<D>::Zero();
    Real offset = 0, margin = 0;
    bool half_space = false;
    Vec<D> lo, hi;  // bounding box, margin included
  };
  std::vector<ColliderScreen> screens_;
  void placeScreens();
  bool mayTouch(int c, const Vec<D>& x) const {
    const ColliderScreen& s = screens_[c];
    if (s.half_space) return s.normal.dot(x) - s.offset <= s.margin;
    // Written so that a NaN position passes, and meets phi as it did before the screen.
    return !((x.array() < s.lo.array()).any() || (x.array() > s.hi.array()).any());
  }
  // Most particles are well inside the domain: a box test clears them of every axis-aligned half
  // space (the domain walls) at once, with the screens' margins, so only the colliders the box
  // does not cover are screened one by one. Set with the screens.
  Vec<D> clear_lo_, clear_hi_;
  std::vector<int> every_collider_, uncovered_colliders_;
  const std::vector<int>& collidersNear(const Vec<D>& x) const {
    const bool clear =
        (x.array() > clear_lo_.array()).all() && (x.array() < clear_hi_.array()).all();
    return clear ? uncovered_colliders_ : every_collider_;
  }
  Real collider_speed_ = 0;  // the fastest any point of a collider moves (fastestColliderSpeed)
  // The damper's signal speed 4 eta / (rho h): an explicit step resolves the damper's grid-scale
  // rate as it does the elastic wave (docs/mpm.md).
  Real viscous_speed_ = 0;
  std::vector<Real> body_density_;  // rest density of each body of the scene
  Schedule schedule_;
  std::unique_ptr<CrackOpening<D, T>> cracks_;  // with mpm.open_cracks
  bool crack_step_ = false;  // this step runs with the crack opening's fields (stepWithCracks)
  mutable SlabDecomposition<D> slabs_;  // a gather for output reads every rank, also in const
  mutable MpmParticles<D, T> gathered_;
  mutable long gathered_at_step_ = -1;
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
  SleepTally sleep_tally_;
  Real initial_energy_ = 0;
  Real total_mass_ = 0;
  int total_particles_ = 0;      // of every rank
  bool colliders_move_ = false;  // a moving collider adds energy: no energy check then
  // How far the energy may grow before a step counts as blown up. Measured on the snowball drop
  // at fixed dt (docs/mpm.md): stable steps keep it within 0.1%, a step 1.6x beyond the stable one
  // grows it 7.5% as the ball flies apart, 1.8x doubles it.
  static constexpr Real kEnergyGrowthLimit = 1.05;
  // A float solver's particles in double, and the step they were converted at.
  mutable Particles<D> particles_in_double_;
  mutable long converted_at_step_ = -1;
  // The stable dt at the first step a fixed dt exceeded it, before the blow-up inflated the speeds
  // (what the blow-up message recommends), and that step.
  Real limit_when_exceeded_ = std::numeric_limits<Real>::infinity();
  long step_when_exceeded_ = -1;
};

}  // namespace snowsim
