#include "sim/mpm/mpm_solver.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <sstream>
#include <utility>

#include "sim/core/errors.h"
#include "sim/core/stencil.h"

namespace snowsim {

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// D_p^{-1} of APIC (Jiang et al. 2015, eq. after 11): 4 / h^2 for quadratic, 3 / h^2 for cubic.
template <class Kernel>
Real inertiaInverse(Real h) {
  return (Kernel::support == 3 ? Real(4) : Real(3)) / (h * h);
}

}  // namespace

template <int D>
MpmSolver<D>::MpmSolver(const Scene& scene, Particles<D> particles, int threads)
    : params_(scene.mpm),
      material_(scene.material),
      file_(scene.file),
      particles_(std::move(particles)),
      threads_(threads) {
  for (int a = 0; a < D; ++a) gravity_[a] = scene.gravity[a];
  IVec<D> cells;
  for (int a = 0; a < D; ++a) cells[a] = scene.cells[a];
  grid_ = GridGeometry<D>(cells, scene.cell_size);
  fields_.resize(grid_.nodeCount());
  colliders_ = makeColliders<D>(scene);
  for (const Body& body : scene.bodies) body_density_.push_back(body.density);

  const int n = particles_.size();
  parallel_ = n >= parallel_min_particles;
  F_E_.assign(n, Mat<D>::Identity());
  R_E_.assign(n, Mat<D>::Identity());
  if constexpr (D == 3) V_E_.assign(n, Mat<D>::Identity());
  J_P_.assign(n, 1);
  lame_.resize(n);
  for (int p = 0; p < n; ++p) updateLame(p);
  C_.assign(n, Mat<D>::Zero());
  order_.resize(n);
  spare_.resize(n);
  particle_block_.resize(n);
  block_count_ = 1;
  for (int a = 0; a < D; ++a) {
    blocks_[a] = (cells[a] + block_cells - 1) / block_cells;
    block_count_ *= blocks_[a];
  }
  row_start_.assign(block_count_ / blocks_[0] + 1, 0);
  chunk_energy_.resize((n + energy_chunk - 1) / energy_chunk);
  partial_.resize(colours);
  for (PartialGrid& g : partial_) {
    g.mass.resize(grid_.nodeCount());  // zero, untouched
    g.momentum.resize(grid_.nodeCount());
    if (params_.transfer != MpmTransfer::Mls) g.force.resize(grid_.nodeCount());
  }
  // Paper section 4 step 2, done once before the first step: densities and volumes from the grid.
  prepareParts();
  scatter(0);
  updateGridVelocities(0);  // the grid's mass, for the volumes
  computeParticleVolumes();
  for (int p = 0; p < n; ++p) total_mass_ += particles_.mass[p];
  for (const Collider<D>& c : colliders_) colliders_move_ = colliders_move_ || !c.velocity.isZero();
  measureParticles();
}

template <int D>
void MpmSolver<D>::step(Real dt) {
  if (steps_ == 0) {
    // The state as the first step finds it (a caller may have set velocities since construction).
    measureParticles();
    initial_energy_ = energy_;
  }
  const bool semi_implicit = params_.integrator == MpmIntegrator::SemiImplicit;
  const Real stable_dt = semi_implicit ? advectionTimeStep() : cflTimeStep();
  if (dt > stable_dt && step_when_exceeded_ < 0) {
    limit_when_exceeded_ = stable_dt;
    step_when_exceeded_ = steps_;
  }
  prepareParts();
  // The rows hold until a particle has moved more than drift_cells beyond its row's cells
  // (withinRowCells); their split between the parts follows the shares.
  const bool bin = must_bin_ || drift_cells == 0;
  if (!bin) splitRows();
  if (unsummed_scatter_) emptyPartialGrids();  // left by the public stages
  binned_since_stored_ = binned_since_stored_ || bin;
  const bool store = binned_since_stored_ && steps_ - stored_step_ >= sorted_storage_interval;
  if (store) {
    binned_since_stored_ = false;
    stored_step_ = steps_;
  }
  // The explicit stages are one task of the team's threads (sim/parallel/team.h); the semi-implicit
  // solve opens OpenMP regions of its own and may throw, so its stages each meet on their own
  // (nothing in a shared task throws: a worker thread has no one to throw to).
  team_.together(!semi_implicit, [&] {
    if (bin) binParticles();
    if (store) storeInSortedOrder();  // each part together in memory
    rasterise(dt);                    // 1, 3: mass, momentum and forces to the grid
    if (semi_implicit) {
      updateGridNodes(dt, false);   // 4: explicit update
      solveImplicitVelocities(dt);  // 5 + 6: collided v*, then the solve holding the contacts
    } else {
      updateGridNodes(dt, true);  // 4 + 5: explicit update, grid collisions
    }
    moveParticles(dt);  // 8, 7, 9, 10: velocities, F_E and plasticity, collisions, positions
  });
  gridStageDone();
  collectMeasures();
  for (Collider<D>& c : colliders_) c.advance(dt);
  ++steps_;
  time_ += dt;
  checkBlowUp(dt);
}

template <int D>
void MpmSolver<D>::prepareParts() {
  const int threads = threads_ > 0 ? threads_ : omp_get_max_threads();
  team_.configure(parallel_ ? threads : 1, parallel_);
  const int parts = this->parts();
  if (particle_shares_.parts() == parts) return;
  // The first step, or another thread count.
  part_rows_.resize(parts + 1);
  part_measures_.assign(parts, PartMeasure());
  particle_shares_.reset(parts);
  line_shares_.reset(parts);
  range_count_.assign(static_cast<size_t>(parts) * block_count_, 0);
  range_cursor_.resize(static_cast<size_t>(parts) * block_count_);
  range_first_block_.assign(parts, blocks_);  // empty boxes: nothing counted yet
  range_last_block_.assign(parts, IVec<D>::Constant(-1));
}

template <int D>
void MpmSolver<D>::binParticles() {
  const int n = particles_.size();
  const int rows = static_cast<int>(row_start_.size()) - 1;
  const Real inv_h = 1 / grid_.h;
  const auto countsOf = [&](int range) {
    return &range_count_[static_cast<size_t>(range) * block_count_];
  };
  // Counting sort, each part on one contiguous range of particle indices: count per block, a
  // prefix sum over (block, range) gives each range its place in each block, each range places
  // its particles. A stable sort: its result does not depend on how the particles were split.
  // A range's counts are zero outside the box of blocks its particles were in, which is all
  // that is cleared and summed: the snow's blocks, not the domain's.
  team_.forEachPart("bin: count", [&](int r) {
    int* count = countsOf(r);
    for (int row = 0; row < rows; ++row)
      forBlocksOfRowInBox(
          row, range_first_block_[r], range_last_block_[r],
          [&](int first, int length, const IVec<D>&) { std::fill_n(count + first, length, 0); });
    IVec<D> first = blocks_, last = IVec<D>::Constant(-1);
    for (int p = particle_shares_.start(r, n), end = particle_shares_.start(r + 1, n); p < end;
         ++p) {
      int b = 0, s = 1;
      for (int a = 0; a < D; ++a) {
        // The cell as the kernels compute it (sim/core/bspline.h), so that a particle never reaches
        // beyond its row's nodes (withinRowCells).
        const int cell = static_cast<int>(std::floor(particles_.x[p][a] * inv_h));
        const int k = std::min(std::max(cell, 0) / block_cells, blocks_[a] - 1);
        first[a] = std::min(first[a], k);
        last[a] = std::max(last[a], k);
        b += k * s;
        s *= blocks_[a];
      }
      particle_block_[p] = b;
      ++count[b];
    }
    range_first_block_[r] = first;
    range_last_block_[r] = last;
  });
  // Each part sums the prefix itself rather than waiting for one thread to sum it: a barrier
  // and, on two threads, the cursors crossing between caches twice.
  team_.forEachPart("bin: place", [&](int r) {
    const int ranges = parts();
    IVec<D> lo = blocks_, hi = IVec<D>::Constant(-1);  // the union of the ranges' boxes
    for (int range = 0; range < ranges; ++range) {
      lo = lo.cwiseMin(range_first_block_[range]);
      hi = hi.cwiseMax(range_last_block_[range]);
    }
    int* cursor = &range_cursor_[static_cast<size_t>(r) * block_count_];
    int placed = 0;
    for (int row = 0; row < rows; ++row) {
      if (r == 0) row_start_[row] = placed;
      forBlocksOfRowInBox(row, lo, hi, [&](int first, int length, IVec<D> block) {
        for (int b = first; b < first + length; ++b, ++block[0])
          for (int range = 0; range < ranges; ++range) {
            if ((block.array() < range_first_block_[range].array()).any() ||
                (block.array() > range_last_block_[range].array()).any())
              continue;  // outside its box: none of its particles
            if (range == r) cursor[b] = placed;
            placed += countsOf(range)[b];
          }
      });
    }
    for (int p = particle_shares_.start(r, n), end = particle_shares_.start(r + 1, n); p < end; ++p)
      order_[cursor[particle_block_[p]]++] = p;
    if (r == 0) {  // read after this stage only
      row_start_[rows] = placed;
      splitRows();
      findActiveNodes();
      must_bin_ = false;
      ++binnings_;
    }
  });
}

template <int D>
template <class F>
void MpmSolver<D>::forBlocksOfRowInBox(int row, const IVec<D>& lo, const IVec<D>& hi, F&& f) const {
  if (lo[0] > hi[0]) return;
  IVec<D> block;
  block[0] = lo[0];
  for (int a = 1, rest = row; a < D; ++a) {
    block[a] = rest % blocks_[a];
    rest /= blocks_[a];
    if (block[a] < lo[a] || block[a] > hi[a]) return;
  }
  f(row * blocks_[0] + lo[0], hi[0] - lo[0] + 1, block);
}

template <int D>
void MpmSolver<D>::findActiveNodes() {
  IVec<D> first_block = blocks_, last_block = IVec<D>::Constant(-1);
  for (int r = 0; r < parts(); ++r) {
    first_block = first_block.cwiseMin(range_first_block_[r]);
    last_block = last_block.cwiseMax(range_last_block_[r]);
  }
  binned_first_block_ = first_block;
  binned_last_block_ = last_block;
  const NodeBox<D> previous = active_;
  // A particle of cell c reaches nodes c-1 .. c+2 with either kernel, and may move drift_cells
  // before the next binning; two more on each side hold particles just outside the domain, which
  // the edge blocks keep.
  constexpr int margin = 2 + drift_cells;
  for (int a = 0; a < D; ++a) {
    active_.lo[a] = std::max(0, first_block[a] * block_cells - margin + grid_.ghost);
    active_.hi[a] =
        std::min(grid_.nodes[a], (last_block[a] + 1) * block_cells + 1 + margin + grid_.ghost);
  }
  // The partial grids hold mass in this binning's active_, the grid still holds the last grid
  // stage's, in the previous binning's: the grid stage updates both.
  updated_ = active_;
  if (previous.count() > 0) {
    updated_.lo = updated_.lo.cwiseMin(previous.lo);
    updated_.hi = updated_.hi.cwiseMax(previous.hi);
  }
}

template <int D>
template <class F>
void MpmSolver<D>::forEachParticleArray(F&& f) {
  f(particles_.x), f(particles_.v), f(particles_.mass), f(particles_.volume);
  f(particles_.density), f(particles_.body), f(particles_.id);
  f(F_E_), f(R_E_), f(J_P_), f(C_), f(lame_);
  if constexpr (D == 3) f(V_E_);
}

template <int D>
template <class F>
void MpmSolver<D>::forParticleArraysOfRound(int round, F&& f) {
  std::array<int, SpareArrays::types> met{};  // per type, the arrays met so far
  forEachParticleArray([&](auto& array) {
    if (met[SpareArrays::type(array)]++ == round) f(array);
  });
}

template <int D>
void MpmSolver<D>::storeInSortedOrder() {
  // Each array is gathered in the sorted order into the spare array of its type, each part
  // writing the places its particle pass will read, and the two swap; then order_ is the
  // identity. A part's particles end up in its own thread's cache, where an in-place permutation
  // on one thread left them all in that thread's. Round r takes the r-th array of each type at
  // once, so the threads meet twice a round rather than twice an array (8 meetings, where one
  // array at a time took 25 in 2D and 27 in 3D).
  const auto places = [&](int part, auto&& f) {  // the places of the part's particle pass
    const auto [first, last] = passChunks(part);
    for (int o = chunkStart(first); o < chunkStart(last); ++o) f(o);
  };
  std::array<int, SpareArrays::types> arrays{};
  forEachParticleArray([&](auto& array) { ++arrays[SpareArrays::type(array)]; });
  const int rounds = *std::max_element(arrays.begin(), arrays.end());
  for (int round = 0; round < rounds; ++round) {
    team_.forEachPart("sort: gather", [&](int part) {
      forParticleArraysOfRound(round, [&](auto& array) {
        auto& spare = spare_.of(array);
        places(part, [&](int o) { spare[o] = array[order_[o]]; });
      });
      // A part reads order_ at its own places only: it may reset them once it has gathered.
      if (round == rounds - 1) places(part, [&](int o) { order_[o] = o; });
    });
    team_.serially("sort: swap", [&] {
      forParticleArraysOfRound(round, [&](auto& array) { array.swap(spare_.of(array)); });
    });
  }
}

template <int D>
void MpmSolver<D>::splitRows() {
  const int rows = static_cast<int>(row_start_.size()) - 1;
  const int n = particles_.size();
  part_rows_[0] = 0;
  int row = 0;
  for (int t = 1; t < parts(); ++t) {
    const int target = particle_shares_.start(t, n);
    while (row < rows && rowFirstParticle(row) < target) ++row;
    // The row across the target goes to the part that holds more of it.
    if (row > part_rows_[t - 1] &&
        target - rowFirstParticle(row - 1) < rowFirstParticle(row) - target)
      --row;
    part_rows_[t] = row;
  }
  part_rows_[parts()] = rows;
}

template <int D>
int MpmSolver<D>::rowColour(int row) const {
  int colour = 0;
  for (int a = 1, weight = 1; a < D; ++a, weight *= colour_stride) {
    colour += row % blocks_[a] % colour_stride * weight;
    row /= blocks_[a];
  }
  return colour;
}

template <int D>
template <class F>
void MpmSolver<D>::forActiveNodes(F&& f) {
  const int count = active_.count();
#pragma omp parallel for schedule(static) if (parallel_)
  for (int n = 0; n < count; ++n) f(active_.flatIndex(grid_, n));
}

template <int D>
template <class F>
void MpmSolver<D>::forUpdatedNodes(F&& f) {
  const NodeBox<D>& box = updated_;
  // A part takes a run of consecutive lines of nodes along x, about those its thread scattered
  // to, still in its cache (interleaving the nodes across threads instead doubled this stage's
  // time on two). The lines are cut by this stage's own measured speeds, not at the rows of the
  // scatter: a line whose partial grids the other thread wrote costs more, and on the small 2D
  // bench the upper part took 12-13 µs where the lower took 10.
  const int width = box.hi[0] - box.lo[0];
  const int lines = width > 0 ? box.count() / width : 0;
  team_.forEachPart("grid update", [&](int part) {
    const auto start = parallel_ ? Clock::now() : Clock::time_point();
    const int first = line_shares_.start(part, lines), last = line_shares_.start(part + 1, lines);
    for (int line = first; line < last; ++line) {
      const int k = box.flatIndex(grid_, line * width);
      for (int i = 0; i < width; ++i) f(k + i);  // x is the grid's contiguous axis
    }
    if (parallel_) line_shares_.record(part, last - first, secondsSince(start));
  });
}

template <int D>
void MpmSolver<D>::scatter(Real dt) {
  // Binned anew, a particle that moved since cannot write beyond its row's nodes; emptied, the
  // partial grids drop a scatter that no grid stage has summed.
  binParticles();
  if (unsummed_scatter_) emptyPartialGrids();
  rasterise(dt);
  unsummed_scatter_ = true;
}

template <int D>
typename MpmSolver<D>::RowCells MpmSolver<D>::rowCellsAt(int o) const {
  const int rows = static_cast<int>(row_start_.size()) - 1;
  // The last row whose first place is o or before (o = the particle count: an empty part's end).
  int row = std::min(rows - 1,
                     static_cast<int>(std::upper_bound(row_start_.begin(), row_start_.end(), o) -
                                      row_start_.begin()) -
                         1);
  RowCells cells;
  cells.end = rowFirstParticle(row + 1);
  cells.inv_h = 1 / grid_.h;
  constexpr Real unbounded = std::numeric_limits<Real>::infinity();
  const auto allow = [&](int a, int first_block, int last_block) {
    cells.lo[a] = first_block == 0 ? -unbounded : first_block * block_cells - drift_cells;
    cells.hi[a] =
        last_block == blocks_[a] - 1 ? unbounded : (last_block + 1) * block_cells + drift_cells;
  };
  allow(0, binned_first_block_[0], binned_last_block_[0]);  // a row spans the binning's box
  for (int a = 1; a < D; ++a) {
    allow(a, row % blocks_[a], row % blocks_[a]);
    row /= blocks_[a];
  }
  return cells;
}

template <int D>
bool MpmSolver<D>::withinRowCells(int o, const Vec<D>& x, RowCells& row) const {
  if (o >= row.end) row = rowCellsAt(o);
  // The cell as binParticles computes it, floor(x / h), within [lo, hi): no branch per axis.
  bool within = true;
  for (int a = 0; a < D; ++a) {
    const Real cell = x[a] * row.inv_h;
    within &= (cell >= row.lo[a]) & (cell < row.hi[a]);
  }
  return within;
}

template <int D>
void MpmSolver<D>::emptyPartialGrids() {
  unsummed_scatter_ = false;
  const NodeBox<D>& box = updated_;
  const int width = box.hi[0] - box.lo[0];
  if (width <= 0) return;
  for (int line = 0, lines = box.count() / width; line < lines; ++line) {
    const int first = box.flatIndex(grid_, line * width);
    for (PartialGrid& g : partial_) {
      std::fill_n(g.mass.begin() + first, width, Real(0));
      std::fill_n(g.momentum.begin() + first, width, Vec<D>::Zero());
      if (!g.force.empty()) std::fill_n(g.force.begin() + first, width, Vec<D>::Zero());
    }
  }
}

template <int D>
void MpmSolver<D>::rasterise(Real dt) {
  withKernel(params_.kernel, [&]<class Kernel>() { rasteriseWith<Kernel>(dt); });
}

template <int D>
void MpmSolver<D>::sumPartialGrids(int k) {
  const bool forces = !partial_[0].force.empty();  // MLS's force field stays zero
  Real mass = 0;
  Vec<D> momentum = Vec<D>::Zero(), force = Vec<D>::Zero();
  for (PartialGrid& g : partial_) {  // in colour order: the same sum on any thread count
    mass += g.mass[k];
    momentum += g.momentum[k];
    if (forces) force += g.force[k];
    // Emptied for the next scatter, only where a row wrote (a cubic weight may round to 0 where
    // its gradient does not), so the lines nobody scattered to are only read and do not pass
    // between the threads' caches every step.
    const bool written = g.mass[k] != 0 || (g.momentum[k].array() != 0).any() ||
                         (forces && (g.force[k].array() != 0).any());
    if (!written) continue;
    g.mass[k] = 0;
    g.momentum[k].setZero();
    if (forces) g.force[k].setZero();
  }
  fields_.mass[k] = mass;
  fields_.velocity[k] = momentum;
  if (forces) fields_.force[k] = force;
}

template <int D>
void MpmSolver<D>::velocityFromMomentum(int k) {
  // Keeps the rasterised velocity for the FLIP increment.
  const Real m = fields_.mass[k];
  fields_.velocity[k] = m > 0 ? Vec<D>(fields_.velocity[k] / m) : Vec<D>::Zero();
  if (params_.transfer == MpmTransfer::PicFlip) fields_.velocity_old[k] = fields_.velocity[k];
}

template <int D>
template <class Kernel>
void MpmSolver<D>::rasteriseWith(Real dt) {
  const Real h = grid_.h, inv_h = 1 / h;
  const Real D_inv = inertiaInverse<Kernel>(h);
  const bool affine = params_.transfer != MpmTransfer::PicFlip;
  const bool mls = params_.transfer == MpmTransfer::Mls;
  team_.forEachPart("rasterise", [&](int part) {
    for (int row = part_rows_[part]; row < part_rows_[part + 1]; ++row) {
      PartialGrid& g = partial_[rowColour(row)];
      for (int o = rowFirstParticle(row); o < rowFirstParticle(row + 1); ++o) {
        const int p = order_[o];
        const Vec<D>& x = particles_.x[p];
        const Real m = particles_.mass[p];
        const Vec<D> mv = m * particles_.v[p];
        // Grid force f_i = -sum_p V_p^0 P_p F_E^T grad w_ip (paper eq. 7), with the Kirchhoff
        // stress tau = P F_E^T; MLS replaces grad w by w D^-1 (x_i - x_p) (Hu et al. 2018, eq.
        // 18).
        const Real V0 = particles_.volume[p];
        const Mat<D> stress =
            V0 > 0 ? Mat<D>(-V0 * fixedCorotatedKirchhoff<D>(F_E_[p], R_E_[p], lame(p)))
                   : Mat<D>::Zero();
        const Stencil<D, Kernel> s(x, inv_h);
        if (mls) {
          // MLS-MPM puts dt f_i straight into the momentum (Hu et al. 2018, section 5.1): node i
          // receives w (m v_p + (m C_p + dt D^-1 (-V_p^0 tau_p)) (x_i - x_p)), mass and momentum
          // of eq. 1 with the affine part of APIC and the force of eq. 8 in one scatter.
          const Mat<D> A = m * C_[p] + (dt * D_inv) * stress;
          TensorStencil<D, Kernel>(grid_, s, x)
              .scatterAffine(mv, A, [&](int k, Real w, const Vec<D>& momentum) {
                g.mass[k] += w * m;
                g.momentum[k] += w * momentum;
              });
          continue;
        }
        const Mat<D> mC = m * C_[p];
        visitStencil(grid_, s, x, [&](const StencilVisit<D>& node) {
          const int k = node.index;
          const Real w = s.weightAt(node.offset);
          g.mass[k] += w * m;
          // Momentum, eq. 1; APIC adds the affine part m C (x_i - x_p) (Jiang et al. 2015).
          Vec<D> momentum = mv;
          if (affine) momentum.noalias() += mC * node.dx;
          g.momentum[k] += w * momentum;
          g.force[k].noalias() += stress * s.gradientAt(node.offset, inv_h);
        });
      }
    }
  });
}

template <int D>
void MpmSolver<D>::computeParticleVolumes() {
  const int n = particles_.size();
  if (params_.initial_volume == InitialVolume::Lattice) {
    // Each particle carries its share of its body: V_p^0 = m_p / rho_body = spacing^D.
    for (int p = 0; p < n; ++p) {
      particles_.density[p] = body_density_[particles_.body[p]];
      particles_.volume[p] = particles_.mass[p] / particles_.density[p];
    }
    return;
  }
  const Real cell_volume = std::pow(grid_.h, D);
  withKernel(params_.kernel, [&]<class Kernel>() {
#pragma omp parallel for schedule(static) if (parallel_)
    for (int p = 0; p < n; ++p) {
      // rho_p^0 = sum_i m_i w_ip / h^D, V_p^0 = m_p / rho_p^0 (paper section 4 step 2).
      Real rho = 0;
      forEachStencilNode<D, Kernel>(grid_, particles_.x[p], [&](int k, Real w, const Vec<D>&) {
        rho += fields_.mass[k] * w;
      });
      rho /= cell_volume;
      particles_.density[p] = rho;
      particles_.volume[p] = particles_.mass[p] / rho;
    }
  });
}

template <int D>
void MpmSolver<D>::accelerate(int k, Real dt) {
  const Real m = fields_.mass[k];
  if (m <= 0) return;
  fields_.velocity[k] += dt * gravity_;
  // MLS rasterised dt f_i with the momentum: its force field stays zero and only gravity remains.
  if (params_.transfer != MpmTransfer::Mls)
    fields_.velocity[k] += (dt / m) * fields_.force[k];  // eq. 8, explicit
}

template <int D>
void MpmSolver<D>::collideNode(int k) {
  if (fields_.mass[k] <= 0) return;
  const Vec<D> x = grid_.position(grid_.coords(k));
  for (const Collider<D>& c : colliders_) c.collide(x, fields_.velocity[k]);
}

template <int D>
void MpmSolver<D>::updateGridVelocities(Real dt) {
  updateGridNodes(dt, false);
  gridStageDone();
}

template <int D>
void MpmSolver<D>::updateCollidedGridVelocities(Real dt) {
  updateGridNodes(dt, true);
  gridStageDone();
}

template <int D>
void MpmSolver<D>::gridStageDone() {
  unsummed_scatter_ = false;
  // The grid stage zeroed the nodes the binning before left outside active_.
  updated_ = active_;
}

template <int D>
void MpmSolver<D>::updateGridNodes(Real dt, bool collide) {
  forUpdatedNodes([&](int k) {  // one pass: each node is loaded once for all of them
    sumPartialGrids(k);
    velocityFromMomentum(k);
    accelerate(k, dt);
    if (collide) collideNode(k);
  });
}

template <int D>
void MpmSolver<D>::solveImplicitVelocities(Real dt) {
  // Section 9: grid collisions act on v* before the solve, which then holds what they fixed.
  node_free_.resize(grid_.nodeCount());
  forActiveNodes([&](int k) {
    if (fields_.mass[k] > 0)
      node_free_[k] =
          collideAndConstrain(colliders_, grid_.position(grid_.coords(k)), fields_.velocity[k]);
  });
  implicit_.prepare(grid_, fields_, particles_, F_E_, lame_, params_, dt);
  last_solve_ = implicit_.solve(fields_, node_free_, params_.implicit_beta,
                                params_.implicit_tolerance, params_.implicit_max_iterations);
  solves_.add(last_solve_);
  if (!std::isfinite(last_solve_.residual)) {
    std::ostringstream s;
    s << file_ << ": semi-implicit MPM solve failed at step " << steps_ << " (t = " << time_
      << " s): non-finite residual after " << last_solve_.iterations << " iterations; dt = " << dt
      << " s";
    throw SimulationError(s.str());
  }
}

template <int D>
void MpmSolver<D>::updateParticles(Real dt) {
  moveParticles(dt);
  collectMeasures();
}

template <int D>
void MpmSolver<D>::moveParticles(Real dt) {
  withKernel(params_.kernel, [&]<class Kernel>() { moveParticlesWith<Kernel>(dt); });
}

template <int D>
template <class Kernel>
void MpmSolver<D>::moveParticlesWith(Real dt) {
  // One pass: each particle's arrays are loaded once for the four stages, not once per stage.
  passOverParticles("move particles", [&](int p) {
    gatherVelocity<Kernel>(p);  // 8 (gathered first: 7 needs grad v)
    updateDeformation(p, dt);   // 7
    collideParticle(p);         // 9
    advect(p, dt);              // 10
  });
}

template <int D>
template <class F>
void MpmSolver<D>::passOverParticles(std::string_view stage, F&& update) {
  // The particles in the scatter's order, cut at the parts' shares: a thread moves the particles
  // it scattered and stored, still in its cache. The energy is summed per chunk of the order,
  // then the chunks in order: the same sum on any thread count.
  team_.forEachPart(stage, [&](int part) {
    const auto start = parallel_ ? Clock::now() : Clock::time_point();
    PartMeasure m;
    const auto [first, last] = passChunks(part);
    RowCells row;
    if constexpr (drift_cells > 0) row = rowCellsAt(chunkStart(first));
    for (int chunk = first; chunk < last; ++chunk) {
      Real energy = 0;
      for (int o = chunkStart(chunk); o < chunkStart(chunk + 1); ++o) {
        const int p = order_[o];
        update(p);
        measure(p, m);
        if constexpr (drift_cells > 0) m.in_rows &= withinRowCells(o, particles_.x[p], row);
        energy += particleEnergy(p);
      }
      chunk_energy_[chunk] = energy;
    }
    if (parallel_)
      particle_shares_.record(part, chunkStart(last) - chunkStart(first), secondsSince(start));
    part_measures_[part] = m;
  });
}

template <int D>
std::pair<int, int> MpmSolver<D>::passChunks(int part) const {
  const int chunks = static_cast<int>(chunk_energy_.size());
  return {particle_shares_.start(part, chunks), particle_shares_.start(part + 1, chunks)};
}

template <int D>
void MpmSolver<D>::collectMeasures() {
  if (parallel_) {
    particle_shares_.update();
    line_shares_.update();
  }
  fastest_speed_ = fastest_signal_ = 0;
  finite_ = true;
  for (int part = 0; part < parts(); ++part) {  // maxima: exact in any order
    fastest_speed_ = std::max(fastest_speed_, part_measures_[part].speed);
    fastest_signal_ = std::max(fastest_signal_, part_measures_[part].signal);
    finite_ = finite_ && part_measures_[part].finite;
    must_bin_ = must_bin_ || !part_measures_[part].in_rows;
  }
  Real energy = 0;
  for (const Real chunk : chunk_energy_) energy += chunk;
  // The gravitational energy counts from the domain's lowest point along gravity, so it is >= 0.
  Real lowest = 0;  // min over the domain box of -g.x
  for (int a = 0; a < D; ++a) lowest += std::min(Real(0), -gravity_[a] * grid_.extent()[a]);
  energy_ = energy - total_mass_ * lowest;
}

template <int D>
void MpmSolver<D>::measureParticles() {
  passOverParticles("measure particles", [](int) {});
  collectMeasures();
}

template <int D>
template <class Kernel>
void MpmSolver<D>::gatherVelocity(int p) {
  const Real inv_h = 1 / grid_.h;
  const Vec<D> x = particles_.x[p];
  const Stencil<D, Kernel> s(x, inv_h);
  if (params_.transfer != MpmTransfer::PicFlip) {
    // v_p = sum_i w v_i, B_p = sum_i w v_i (x_i - x_p)^T (Jiang et al. 2015, eq. 10),
    // C_p = B_p D_p^-1, also grad v_p for MLS (Hu et al. 2018).
    Mat<D> B;
    particles_.v[p] =
        TensorStencil<D, Kernel>(grid_, s, x).gatherAffine(fields_.velocity.data(), B);
    C_[p] = inertiaInverse<Kernel>(grid_.h) * B;
    return;
  }
  Vec<D> v_pic = Vec<D>::Zero(), dv = Vec<D>::Zero();
  Mat<D> grad_v = Mat<D>::Zero();
  visitStencil(grid_, s, x, [&](const StencilVisit<D>& node) {
    const Real w = s.weightAt(node.offset);
    const Vec<D>& vi = fields_.velocity[node.index];
    v_pic += w * vi;
    dv += w * (vi - fields_.velocity_old[node.index]);
    grad_v += vi * s.gradientAt(node.offset, inv_h).transpose();  // grad v_p, eq. 10
  });
  // v_p = (1 - alpha) v_PIC + alpha v_FLIP (paper section 4 step 8).
  const Real alpha = params_.flip_alpha;
  particles_.v[p] = (1 - alpha) * v_pic + alpha * (particles_.v[p] + dv);
  C_[p] = grad_v;
}

template <int D>
void MpmSolver<D>::updateDeformation(int p, Real dt) {
  // For PIC/FLIP C_ holds grad v; for APIC/MLS the affine C, equal to grad v for these kernels.
  F_E_[p] = (Mat<D>::Identity() + dt * C_[p]) * F_E_[p];  // eq. 10, F_E^trial
  if constexpr (D == 2)
    J_P_[p] = plasticReturnMappingJ(material_, F_E_[p], J_P_[p], R_E_[p]);  // eqs. 11-12
  else
    J_P_[p] = plasticReturnMappingJ(material_, F_E_[p], J_P_[p], R_E_[p], V_E_[p]);
  updateLame(p);
  // PIC/FLIP keeps no affine velocity: C_ must not feed the next rasterisation.
  if (params_.transfer == MpmTransfer::PicFlip) C_[p].setZero();
}

template <int D>
void MpmSolver<D>::collideParticle(int p) {
  for (const Collider<D>& c : colliders_) c.collide(particles_.x[p], particles_.v[p]);
}

template <int D>
void MpmSolver<D>::advect(int p, Real dt) {
  Vec<D>& x = particles_.x[p];
  x += dt * particles_.v[p];
  for (const Collider<D>& c : colliders_) c.pushOut(x);
  x = x.cwiseMax(Vec<D>::Zero()).cwiseMin(grid_.extent());  // never leave the domain
}

template <int D>
void MpmSolver<D>::measure(int p, PartMeasure& m) const {
  const Real v = particles_.v[p].norm();
  m.finite = m.finite && std::isfinite(v) && particles_.x[p].allFinite();
  m.speed = std::max(m.speed, v);
  m.signal = std::max(m.signal, pWaveSpeed(lame_[p], particles_.density[p]) + v);
}

template <int D>
Real MpmSolver<D>::particleEnergy(int p) const {
  // Kinetic plus gravitational, the latter from the origin (passOverParticles shifts it).
  return particles_.mass[p] *
         (Real(0.5) * particles_.v[p].squaredNorm() - gravity_.dot(particles_.x[p]));
}

template <int D>
Real MpmSolver<D>::cflTimeStep() const {
  // dt <= C h / (c + |v|)max, c = sqrt((lambda + 2 mu) / rho) with hardening (method-notes.md).
  return fastest_signal_ > 0 ? params_.cfl * grid_.h / fastest_signal_
                             : std::numeric_limits<Real>::infinity();
}

template <int D>
Real MpmSolver<D>::advectionTimeStep() const {
  // The semi-implicit step has no elastic wave limit, only advection: dt <= C h / |v|max.
  return fastest_speed_ > 0 ? params_.cfl * grid_.h / fastest_speed_
                            : std::numeric_limits<Real>::infinity();
}

template <int D>
Real MpmSolver<D>::stableTimeStep() const {
  if (!params_.adaptive_dt) return std::numeric_limits<Real>::infinity();
  return params_.integrator == MpmIntegrator::SemiImplicit ? advectionTimeStep() : cflTimeStep();
}

template <int D>
void MpmSolver<D>::checkBlowUp(Real dt) const {
  // An explicit step beyond its limit grows exponentially; a particle crossing more than a cell
  // per step or a non-finite velocity is where we stop it.
  // The snow starts unstrained and plasticity, friction and the transfers only dissipate, so
  // without a moving collider its kinetic plus gravitational energy cannot grow; an unstable
  // explicit step can make it grow while every particle still moves less than a cell per step.
  const bool energy_grew =
      !colliders_move_ && energy_ > kEnergyGrowthLimit * initial_energy_ + 1e-12 * total_mass_;
  if (finite_ && fastest_speed_ * dt <= grid_.h && !energy_grew) return;
  std::ostringstream s;
  s << file_ << ": MPM blew up at step " << steps_ << " (t = " << time_ << " s): largest speed ";
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

template <int D>
void MpmSolver<D>::describe(Snapshot& snapshot) const {
  const int n = particles_.size();
  snapshot.density.resize(n);
  snapshot.plastic_j.resize(n);
  for (int p = 0; p < n; ++p) {  // in creation order, as the snapshot's positions
    const Real J = F_E_[p].determinant() * J_P_[p];
    const int id = particles_.id[p];
    snapshot.density[id] = static_cast<float>(particles_.mass[p] / (particles_.volume[p] * J));
    snapshot.plastic_j[id] = static_cast<float>(J_P_[p]);
  }
  if constexpr (D == 2) {
    const Real area = grid_.h * grid_.h;
    snapshot.grid.node_density.clear();
    for (int j = 0; j <= grid_.cells[1]; ++j)
      for (int i = 0; i <= grid_.cells[0]; ++i)
        snapshot.grid.node_density.push_back(
            static_cast<float>(fields_.mass[grid_.index(IVec<2>(i, j))] / area));
  }
}

template class MpmSolver<2>;
template class MpmSolver<3>;

}  // namespace snowsim
