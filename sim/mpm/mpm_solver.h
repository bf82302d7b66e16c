// MPM snow (Stomakhin, Schroeder, Chai, Teran, Selle 2013, "A Material Point Method for Snow
// Simulation"), explicit symplectic Euler, PIC/FLIP, APIC or MLS-MPM transfers, quadratic or cubic
// B-splines. One step is the paper's section 4 list of stages. The semi-implicit velocity solve
// (paper section 9) takes the place of the grid collisions after updateGridVelocities(): it reads
// the grid (fields(), grid()) and the per-particle F_E, V_p^0 and Lamé parameters
// (elasticGradient(), particles().volume, lame()).
#pragma once

#include <cmath>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "sim/core/collider.h"
#include "sim/core/grid.h"
#include "sim/mpm/implicit_solve.h"
#include "sim/mpm/snow_material.h"
#include "sim/parallel/team.h"
#include "sim/parallel/work_shares.h"
#include "sim/parallel/zero_page_allocator.h"
#include "sim/scene/scene.h"
#include "sim/solver.h"

namespace snowsim {

template <int D>
class MpmSolver final : public Solver<D> {
 public:
  // threads: how many threads the step may use; 0 takes the OpenMP default at each step.
  MpmSolver(const Scene& scene, Particles<D> particles, int threads = 0);

  void step(Real dt) override;
  Real stableTimeStep() const override;
  const Particles<D>& particles() const override { return particles_; }
  void describe(Snapshot& snapshot) const override;

  const GridGeometry<D>& grid() const { return grid_; }
  const GridFields<D>& fields() const { return fields_; }
  GridFields<D>& fields() { return fields_; }
  const std::vector<Mat<D>>& elasticGradient() const { return F_E_; }
  const std::vector<Real>& plasticJ() const { return J_P_; }
  const std::vector<Mat<D>>& affine() const { return C_; }
  const SnowMaterial& material() const { return material_; }
  Lame lame(int p) const { return lame_[p]; }
  const std::vector<Collider<D>>& colliders() const { return colliders_; }
  const MpmParams& params() const { return params_; }
  // The CFL step C h / (c + |v|)max of the current state, whether or not dt is adaptive.
  Real cflTimeStep() const;
  // The advection limit C h / |v|max that bounds the semi-implicit step.
  Real advectionTimeStep() const;
  // The Krylov solve of the last semi-implicit step.
  const KrylovResult& lastImplicitSolve() const { return last_solve_; }
  SolveTally implicitSolves() const override { return solves_; }
  // Where the steps' time goes, stage by stage and thread by thread (sim/parallel/team.h): on from
  // the next step until turned off. The semi-implicit solve's own OpenMP regions are not in it.
  // bench/mpm_bench prints it.
  void profileStages(bool on) { team_.profileStages(on); }
  int profiledThreads() const { return team_.threads(); }
  const std::vector<StageTime>& stageTimes(int thread) const { return team_.stageTimes(thread); }
  // How many times the particles were binned into rows, construction included. 2D: once, then
  // again whenever one had moved more than drift_cells beyond its row's cells; 3D: every step.
  long binnings() const { return binnings_; }

  // The stages of one step (paper section 4), public so tests and the implicit solve can drive
  // them.
  // 1 + 3. P2G mass, momentum (eq. 1) and forces (eq. 7) into the partial grids of the rows,
  // after binning the particles into the rows where they are now.
  void scatter(Real dt);
  // 2. First step only, after updateGridVelocities: rho_p^0, V_p^0 (section 4 step 2).
  void computeParticleVolumes();
  // 4. Once after each scatter: the grid's mass, momentum and force are the sums of the partial
  // grids, v = momentum / m, then v* = v + dt f / m + dt g (eq. 8 explicit). It empties the
  // partial grids: a second call finds no mass.
  void updateGridVelocities(Real dt);
  // 5 + 6, semi-implicit: collide v*, then solve for v (section 9).
  void solveImplicitVelocities(Real dt);
  // 4 + 5, explicit: updateGridVelocities, then the grid body collisions (section 8), in one pass.
  void updateCollidedGridVelocities(Real dt);
  // 8, 7, 9, 10 below, in one pass over the particles.
  void updateParticles(Real dt);

 private:
  // Per grid node k, after the scatter: what stages 1, 4 and 5 do to it.
  void sumPartialGrids(int k);
  void velocityFromMomentum(int k);
  void accelerate(int k, Real dt);  // eq. 8 explicit, plus gravity
  void collideNode(int k);
  // The stages' parallel work, which step() runs as one task of the team (sim/parallel/team.h); the
  // public stages above add what a stage run alone needs.
  void rasterise(Real dt);                      // 1 + 3
  void updateGridNodes(Real dt, bool collide);  // 4, and 5 if collide
  void moveParticles(Real dt);                  // 8, 7, 9, 10, and each part's measures
  template <class Kernel>
  void rasteriseWith(Real dt);
  template <class Kernel>
  void moveParticlesWith(Real dt);
  template <class Kernel>
  void gatherVelocity(int p);              // 8. v_p by PIC/FLIP, APIC or MLS, and grad v_p
  void updateDeformation(int p, Real dt);  // 7. F_E <- (I + dt grad v) F_E, plasticity (eqs. 10-12)
  void collideParticle(int p);             // 9. particle-based body collisions (section 8)
  void advect(int p, Real dt);             // 10. x += dt v, kept out of colliders and in the domain

  void prepareParts();  // the team's parts and their state, for the thread count of this step
  int parts() const { return team_.parts(); }
  void binParticles();
  void findActiveNodes();  // active_ and updated_ from the blocks the particles are in
  // The particle arrays permuted into the sorted order of the last binParticles(). Each array
  // swaps with a spare one: the arrays' data pointers change.
  void storeInSortedOrder();
  template <class F>
  void forEachParticleArray(F&& f);  // f(array) for each per-particle array
  template <class F>
  void forParticleArraysOfRound(int round, F&& f);  // f(array) for the round-th of each type
  void splitRows();                                 // part_rows_ from the sorted particles
  int rowColour(int row) const;
  // Zero over updated_. The grid stage empties them as it sums them, so only a scatter of the
  // public stages that no grid stage followed needs this.
  void emptyPartialGrids();
  void gridStageDone();  // after each grid stage: nothing unsummed, updated_ back to active_
  // Where the particles of the row at sorted place o may be, in cells (x / h), for the nodes they
  // reach to stay the row's: [lo, hi) on each axis, unbounded at the domain's edges; and where
  // the row ends in the sorted order.
  struct RowCells {
    int end = 0;
    Vec<D> lo = Vec<D>::Zero(), hi = Vec<D>::Zero();
    Real inv_h = 0;
  };
  RowCells rowCellsAt(int o) const;
  // Whether the particle at sorted place o, now at x, is within its row's cells; `row` follows a
  // pass in sorted order from row to row.
  bool withinRowCells(int o, const Vec<D>& x, RowCells& row) const;
  int rowFirstParticle(int row) const { return row_start_[row]; }
  // f(first, length, block): the blocks of row `row` within the box [lo, hi] of block coordinates,
  // a run of `length` along x from flat block index `first`, at coordinates `block`; nothing if
  // the row misses the box.
  template <class F>
  void forBlocksOfRowInBox(int row, const IVec<D>& lo, const IVec<D>& hi, F&& f) const;
  template <class F>
  void forActiveNodes(F&& f);  // f(k) for each node of active_, in parallel for large scenes
  // The grid stage after a scatter: f(k) for each node of updated_, which leaves nothing outside
  // active_.
  template <class F>
  void forUpdatedNodes(F&& f);
  void updateLame(int p) { lame_[p] = hardenedLame(material_, J_P_[p]); }

  struct PartMeasure {  // the fastest particles of one part
    Real speed = 0, signal = 0;
    bool finite = true;
    bool in_rows = true;  // every particle within its row's cells (withinRowCells)
  };
  // update(p) for each particle, part by part, each part measuring what it leaves.
  template <class F>
  void passOverParticles(std::string_view stage, F&& update);
  void collectMeasures();   // the speeds, energy and shares from the parts' measures
  void measureParticles();  // the speeds and energy of the current state
  // The chunks of the sorted order that part `part`'s particle pass takes, [first, last).
  std::pair<int, int> passChunks(int part) const;
  // Where chunk `chunk` starts in the sorted order.
  int chunkStart(int chunk) const { return std::min(particles_.size(), chunk * energy_chunk); }
  void measure(int p, PartMeasure& m) const;
  Real particleEnergy(int p) const;
  void checkBlowUp(Real dt) const;

  MpmParams params_;
  SnowMaterial material_;
  Vec<D> gravity_;
  std::string file_;
  Particles<D> particles_;
  std::vector<Mat<D>> F_E_;  // elastic deformation gradient
  std::vector<Mat<D>> R_E_;  // its polar rotation, from the last return mapping
  std::vector<Mat<D>> V_E_;  // 3D: its right singular vectors, the next SVD's starting guess
  std::vector<Real> J_P_;    // det F_P, plastic volume ratio
  std::vector<Mat<D>> C_;    // affine velocity (APIC/MLS), or grad v (PIC/FLIP)
  GridGeometry<D> grid_;
  GridFields<D> fields_;
  std::vector<Collider<D>> colliders_;
  std::vector<Real> body_density_;  // rest density of each body of the scene
  // Deterministic parallel P2G: particles binned into blocks of block_cells^D cells, sorted by
  // block, in stored order within a block. A row of blocks along x is the unit of work. Each row
  // scatters into the partial grid of its colour, its y (and z) block index modulo colour_stride:
  // a particle of cell c reaches nodes c-1 .. c+2, so rows of one colour write no common node as
  // long as their particles stay within drift_cells of their rows' cells. A node of a partial grid
  // sums the particles of one row, in sorted order, and the grid sums the partial grids in colour
  // order: the same sums on any thread count, and the rows need no order among them.
  // 2D: rows 3 cells tall, three colours. 3D: blocks of 4^3 cells, four colours (two along y,
  // two along z); it has rows enough, and its larger blocks sort faster.
  static constexpr int block_cells = D == 2 ? 3 : 4;
  static constexpr int colour_stride = D == 2 ? 3 : 2;  // per axis
  static constexpr int colours = D == 2 ? colour_stride : colour_stride * colour_stride;
  // The nodes reached by rows colour_stride blocks apart leave block_cells * (colour_stride -
  // 1) - 3 nodes between them; half of that, rounded down, is how many cells a particle may move
  // beyond its row's on either side and still write only nodes no other row of its colour can. 2D:
  // one cell, so the particles are binned anew only when one has moved farther (withinRowCells), 4
  // times in the small bench's 200 steps. 3D: none, so they are binned every step; three colours a
  // side would be nine partial grids to sum, and blocks of 5^3 cells with two colours cost more on
  // two threads than the binning saved (README, "Speed").
  static constexpr int drift_cells = (block_cells * (colour_stride - 1) - 3) / 2;
  // Grid-sized, but only the nodes near the snow are ever touched, and only they take memory.
  template <class T>
  using ZeroPageVector = std::vector<T, ZeroPageAllocator<T>>;
  struct PartialGrid {
    ZeroPageVector<Real> mass;
    ZeroPageVector<Vec<D>> momentum, force;  // force stays empty for MLS (its force is in momentum)
  };
  std::vector<PartialGrid> partial_;  // one per colour
  IVec<D> blocks_;
  int block_count_ = 0;
  std::vector<int> row_start_;  // particles of row r: order_[row_start_[r] .. [r + 1])
  std::vector<int> order_;
  std::vector<int> particle_block_;  // per stored particle, binParticles' scratch: stale after it
  // Once a binning has changed the sorted order, the particles are stored in it, at most every
  // sorted_storage_interval steps, so that each part's particles lie together in memory: two
  // threads then rarely write the same cache line, which on this machine cost up to 25% of the
  // particle pass on two threads (README, "Speed"). In between, the stored order drifts from the
  // sorted one: storing it every 64 steps, the last steps were 10% slower than the first. Steps
  // and binnings, never threads or time, decide it, so the results stay the same on any thread
  // count.
  static constexpr int sorted_storage_interval = 16;
  struct SpareArrays {  // one per type of particle array: storeInSortedOrder's target
    std::vector<Vec<D>> vec;
    std::vector<Mat<D>> mat;
    std::vector<Real> real;
    std::vector<int> integer;
    std::vector<Lame> lame;
    void resize(int n) {
      vec.resize(n), mat.resize(n), real.resize(n), integer.resize(n), lame.resize(n);
    }
    std::vector<Vec<D>>& of(const std::vector<Vec<D>>&) { return vec; }
    std::vector<Mat<D>>& of(const std::vector<Mat<D>>&) { return mat; }
    std::vector<Real>& of(const std::vector<Real>&) { return real; }
    std::vector<int>& of(const std::vector<int>&) { return integer; }
    std::vector<Lame>& of(const std::vector<Lame>&) { return lame; }
    // Which of the types an array is, 0 .. types - 1.
    static constexpr int types = 5;
    static int type(const std::vector<Vec<D>>&) { return 0; }
    static int type(const std::vector<Mat<D>>&) { return 1; }
    static int type(const std::vector<Real>&) { return 2; }
    static int type(const std::vector<int>&) { return 3; }
    static int type(const std::vector<Lame>&) { return 4; }
  } spare_;
  // The work is cut into parts, one per thread. In the scatter part t has the rows
  // part_rows_[t] .. part_rows_[t + 1]; the particle pass cuts the sorted order at the same
  // shares, so the particles a thread writes in one stage are mostly the ones it reads in the
  // next, from its own cache. The grid stage cuts its node lines by its own speeds.
  Team team_;  // its parts() is the number of parts
  std::vector<int> part_rows_;
  // Each part's share of the work follows its measured speed (sim/parallel/work_shares.h): the
  // particles by the particle pass's speeds (the rows split there, and the sorted order too), the
  // grid stage's lines of nodes by its own.
  WorkShares particle_shares_, line_shares_;
  std::vector<PartMeasure> part_measures_;
  // Counting-sort state per part r, each sorting one contiguous range of particle indices:
  // range_count_[r * block_count_ + b] counts its particles of block b, range_cursor_ places them;
  // range_first/last_block_[r] bound the blocks its particles are in.
  std::vector<int> range_count_, range_cursor_;
  std::vector<IVec<D>> range_first_block_, range_last_block_;
  // The last binning's box of blocks; whether a particle has left its row's cells since (then the
  // next step bins anew); whether the sorted order changed since the particles were last stored
  // in it, and at which step they were.
  IVec<D> binned_first_block_, binned_last_block_;
  bool must_bin_ = true;
  // Whether the partial grids hold a scatter no grid stage has summed (and emptied): only the
  // public stages leave them so.
  bool unsummed_scatter_ = false;
  long binnings_ = 0;
  bool binned_since_stored_ = true;
  long stored_step_ = -sorted_storage_interval;
  // The nodes within the kernel's reach of the particles' blocks, widened by drift_cells, found
  // by binParticles: the grid stages touch only these, so a small snowball in a large domain
  // costs what the snowball does. Nodes outside stay zero: the first grid stage after a binning
  // sums the partial grids over updated_, active_ and the previous binning's, which zeroes the
  // nodes active_ no longer covers; the grid stages after it, over active_ alone.
  NodeBox<D> active_;
  NodeBox<D> updated_;  // what the next grid stage updates
  ImplicitVelocitySolve<D> implicit_;
  std::vector<Lame> lame_;  // per particle, hardened by J_P (eq. 8); refreshed with J_P
  // Measured once at the end of each step, read by the CFL limits and the blow-up check.
  Real fastest_speed_ = 0;                 // max |v_p|
  Real fastest_signal_ = 0;                // max (c_p + |v_p|), c_p the P-wave speed
  bool finite_ = true;                     // every position and velocity finite
  Real energy_ = 0;                        // kinetic + gravitational (J), see passOverParticles
  static constexpr int energy_chunk = 64;  // particles, in sorted order
  std::vector<Real> chunk_energy_;         // for a thread-count independent total
  Real initial_energy_ = 0;
  Real total_mass_ = 0;
  bool colliders_move_ = false;  // a moving collider adds energy: no energy check then
  // How far the energy may grow before a step counts as blown up. Measured on the snowball drop
  // at fixed dt (docs/mpm.md): stable steps keep it within 0.1%, a step 1.6x beyond the stable one
  // grows it 7.5% as the ball flies apart, 1.8x doubles it.
  static constexpr Real kEnergyGrowthLimit = 1.05;
  // The stable dt at the first step a fixed dt exceeded it, before the blow-up inflated the speeds
  // (what checkBlowUp recommends), and that step.
  Real limit_when_exceeded_ = std::numeric_limits<Real>::infinity();
  int step_when_exceeded_ = -1;
  KrylovResult last_solve_;
  SolveTally solves_;
  std::vector<Mat<D>> node_free_;  // per grid node: components the collisions left free
  // Threads only pay off from a few thousand particles: below, waking the threads and meeting
  // between the stages costs more than they share (README, "Speed", for the measured ratios).
  static constexpr int parallel_min_particles = 2048;
  bool parallel_ = false;
  int threads_ = 0;
  long steps_ = 0;
  Real time_ = 0;
};

}  // namespace snowsim
