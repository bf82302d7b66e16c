#include "sim/report/density_hybrid.h"

#include <cmath>
#include <sstream>

#include "sim/core/errors.h"
#include "sim/core/pic_flip.h"
#include "sim/core/stencil.h"
#include "sim/io/checkpoint.h"

namespace snowsim {

Real clampTowardsPacked(Real own, Real neighbour) {
  // Same direction and at least as fast: mass leaves the packed cell as fast as it comes in.
  if (own > 0 && neighbour >= own) return own;
  if (own < 0 && neighbour <= own) return own;
  // Same direction but slower: match the packed cell. Opposite direction or still: stop.
  if (own > 0) return neighbour > 0 ? neighbour : 0;
  return neighbour < 0 ? neighbour : 0;
}

template <int D>
void equaliseTowardsPacked(const GridGeometry<D>& grid, const std::vector<Real>& density,
                           Real critical_density, const std::vector<Vec<D>>& in,
                           std::vector<Vec<D>>& out) {
  for (int k = 0; k < grid.nodeCount(); ++k) {
    const IVec<D> i = grid.coords(k);
    out[k] = in[k];
    for (int a = 0; a < D; ++a) {
      const Real own = in[k][a];
      if (own == 0) continue;
      const int step = own > 0 ? 1 : -1;
      const int next = i[a] + step;
      if (next < -grid.ghost || next > grid.cells[a] + grid.ghost) continue;
      const int j = k + step * grid.stride[a];
      if (density[j] >= critical_density) out[k][a] = clampTowardsPacked(own, in[j][a]);
    }
  }
}

template <int D>
DensityHybridSolver<D>::DensityHybridSolver(const Scene& scene, Particles<D> particles)
    : params_(scene.density_hybrid),
      gravity_(sceneGravity<D>(scene)),
      particles_(std::move(particles)),
      grid_(sceneGrid<D>(scene)) {
  const int n = grid_.nodeCount();
  fields_.resize(n);
  node_density_.assign(n, 0);
  scratch_.assign(n, Vec<D>::Zero());
  if (D == 3 && scene.authored_dimension == 2) slab_axis_ = 2;
}

template <int D>
void DensityHybridSolver<D>::advance(Real dt) {
  rasterise();
  if (this->steps() == 0) computeParticleVolumes();
  computeGridForces();
  holdWalls();
  if (params_.flip_reference == FlipReference::Rasterised) fields_.velocity_old = fields_.velocity;
  equaliseForcesAndVelocities();
  if (params_.flip_reference == FlipReference::Equalised) fields_.velocity_old = fields_.velocity;
  updateGridVelocities(dt);
  updateParticleVelocities();
  collideWithGround();
  advect(dt);
}

// Eq. 1 of the report: m_i = sum_p w_ip m_p; v_i = sum_p w_ip m_p v_p / m_i.
template <int D>
void DensityHybridSolver<D>::rasterise() {
  fields_.clear();
  withKernel(params_.kernel, [&]<class K>() {
    for (int p = 0; p < particles_.size(); ++p) {
      const Real m = particles_.mass[p];
      const Vec<D> momentum = m * particles_.v[p];
      forEachStencilNode<D, K>(grid_, particles_.x[p], [&](int i, Real w, const Vec<D>&) {
        fields_.mass[i] += w * m;
        fields_.velocity[i] += w * momentum;
      });
    }
  });
  const Real inv_volume = 1 / std::pow(grid_.h, D);
  for (int i = 0; i < grid_.nodeCount(); ++i) {
    const Real m = fields_.mass[i];
    if (m > 0) fields_.velocity[i] /= m;
    node_density_[i] = m * inv_volume;
  }
}

// Step 2: rho_p = sum_i w_ip m_i / h^d, V_p = m_p / rho_p; the critical density follows.
template <int D>
void DensityHybridSolver<D>::computeParticleVolumes() {
  Real density_sum = 0, mass_sum = 0;
  withKernel(params_.kernel, [&]<class K>() {
    for (int p = 0; p < particles_.size(); ++p) {
      Real rho = 0;
      forEachStencilNode<D, K>(grid_, particles_.x[p],
                               [&](int i, Real w, const Vec<D>&) { rho += w * node_density_[i]; });
      particles_.volume[p] = particles_.mass[p] / rho;
      density_sum += rho;
      mass_sum += particles_.mass[p];
    }
  });
  const int n = std::max(1, particles_.size());
  const Real reference = params_.critical_reference == CriticalReference::RestDensity
                             ? density_sum / n
                             : mass_sum / n / std::pow(grid_.h, D);
  critical_density_ = params_.critical_multiplier * reference;
}

// Step 3: gravity is the only force.
template <int D>
void DensityHybridSolver<D>::computeGridForces() {
  for (int i = 0; i < grid_.nodeCount(); ++i) fields_.force[i] = fields_.mass[i] * gravity_;
}

template <int D>
bool DensityHybridSolver<D>::isWallNode(const IVec<D>& i, int axis) const {
  return i[axis] <= 0 || i[axis] >= grid_.cells[axis];
}

// The box walls on the grid. hold_grid: nodes on or beyond a wall of the scene's own plane keep
// no velocity or force (no-slip); the walls of an extruded slab only stop motion across them.
template <int D>
void DensityHybridSolver<D>::holdWalls() {
  if (params_.walls == WallRule::ParticlesOnly) return;
  for (int k = 0; k < grid_.nodeCount(); ++k) {
    const IVec<D> i = grid_.coords(k);
    for (int a = 0; a < D; ++a) {
      if (!isWallNode(i, a)) continue;
      if (a == slab_axis_ || params_.walls == WallRule::SlipGrid) {
        fields_.velocity[k][a] = 0;
        fields_.force[k][a] = 0;
      } else {
        fields_.velocity[k].setZero();
        fields_.force[k].setZero();
      }
    }
  }
}

template <int D>
void DensityHybridSolver<D>::equaliseForcesAndVelocities() {
  for (std::vector<Vec<D>>* field : {&fields_.force, &fields_.velocity}) {
    equaliseTowardsPacked(grid_, node_density_, critical_density_, *field, scratch_);
    field->swap(scratch_);
  }
}

// Step 5, explicit Euler on the grid.
template <int D>
void DensityHybridSolver<D>::updateGridVelocities(Real dt) {
  for (int i = 0; i < grid_.nodeCount(); ++i)
    if (fields_.mass[i] > 0) fields_.velocity[i] += dt * fields_.force[i] / fields_.mass[i];
}

// Step 6: v_p = (1 - alpha) v_PIC + alpha v_FLIP (Stomakhin et al. 2013, eq. 8 with alpha=0.95).
template <int D>
void DensityHybridSolver<D>::updateParticleVelocities() {
  const Real alpha = params_.flip_alpha;
  withKernel(params_.kernel, [&]<class K>() {
    for (int p = 0; p < particles_.size(); ++p) {
      Vec<D> pic = Vec<D>::Zero(), increment = Vec<D>::Zero();
      forEachStencilNode<D, K>(grid_, particles_.x[p], [&](int i, Real w, const Vec<D>&) {
        pic += w * fields_.velocity[i];
        increment += w * (fields_.velocity[i] - fields_.velocity_old[i]);
      });
      particles_.v[p] = picFlipBlend(particles_.v[p], pic, increment, alpha);
    }
  });
}

// Step 7: a particle at or below the ground keeps no downward velocity; nothing else changes.
template <int D>
void DensityHybridSolver<D>::collideWithGround() {
  for (int p = 0; p < particles_.size(); ++p)
    if (particles_.x[p][1] <= 0 && particles_.v[p][1] < 0) particles_.v[p][1] = 0;
}

// Step 8. The box is the grid: a particle that would leave it stops on the wall, keeping no
// velocity across it.
template <int D>
void DensityHybridSolver<D>::advect(Real dt) {
  const Vec<D> upper = grid_.extent();
  fastest_speed_ = 0;
  widest_crossing_ = 0;
  for (int p = 0; p < particles_.size(); ++p) {
    Vec<D>& x = particles_.x[p];
    const Vec<D> displacement = dt * particles_.v[p];
    x += displacement;
    fastest_speed_ =
        std::max(fastest_speed_, particles_.v[p].stableNorm());  // 1e300 m/s squared overflows
    widest_crossing_ =
        std::max(widest_crossing_, displacement.cwiseAbs().cwiseQuotient(upper).maxCoeff());
    for (int a = 0; a < D; ++a) {
      if (x[a] < 0) x[a] = 0, particles_.v[p][a] = std::max<Real>(particles_.v[p][a], 0);
      if (x[a] > upper[a])
        x[a] = upper[a], particles_.v[p][a] = std::min<Real>(particles_.v[p][a], 0);
    }
  }
}

template <int D>
void DensityHybridSolver<D>::describe(Snapshot& snapshot) const {
  snapshot.grid.critical_density = critical_density_;
  snapshot.density.resize(particles_.size());
  withKernel(params_.kernel, [&]<class K>() {
    for (int p = 0; p < particles_.size(); ++p) {
      Real rho = 0;
      forEachStencilNode<D, K>(grid_, particles_.x[p],
                               [&](int i, Real w, const Vec<D>&) { rho += w * node_density_[i]; });
      snapshot.density[p] = static_cast<float>(rho);
    }
  });
  domainNodeValues(
      grid_, [&](int k) { return node_density_[k]; }, snapshot.grid.node_density);
}

// A blown-up state is stopped where it happens, never written out. The walls would otherwise
// hide it: a particle that crosses the whole box in one step is stopped on a wall with finite
// values. Crossing a cell or more per step is the method's known tunnelling (report Fig. 8), so
// only crossing the domain, which no step of the scene can resolve, counts as divergence.
template <int D>
void DensityHybridSolver<D>::checkDivergence(Real dt) const {
  std::ostringstream s;
  s << "the simulation diverged at step " << this->steps() << " (t = " << this->time() << " s): ";
  for (int i = 0; i < particles_.size(); ++i) {
    if (particles_.x[i].allFinite() && particles_.v[i].allFinite()) continue;
    s << "particle " << i << " has a non-finite position or velocity; try a smaller time.dt than "
      << dt;
    throw SimulationError(s.str());
  }
  if (std::isfinite(fastest_speed_) && widest_crossing_ < 1) return;
  s << "largest speed ";
  if (std::isfinite(fastest_speed_))
    s << fastest_speed_ << " m/s crossed the whole domain in one step of " << dt
      << " s; a step that stays within a cell is time.dt below " << grid_.h / fastest_speed_;
  else
    s << "overflowed (non-finite); check the bodies' velocities";
  throw SimulationError(s.str());
}

template void equaliseTowardsPacked<2>(const GridGeometry<2>&, const std::vector<Real>&, Real,
                                       const std::vector<Vec<2>>&, std::vector<Vec<2>>&);
template void equaliseTowardsPacked<3>(const GridGeometry<3>&, const std::vector<Real>&, Real,
                                       const std::vector<Vec<3>>&, std::vector<Vec<3>>&);
template <int D>
void DensityHybridSolver<D>::saveSolverState(StateWriter& out) const {
  saveParticleArrays(out, particles_);
  out.value(critical_density_);
  out.value(fastest_speed_);
  out.value(widest_crossing_);
}

template <int D>
void DensityHybridSolver<D>::loadSolverState(StateReader& in) {
  // The grid fields are rasterised anew by every step.
  loadParticleArrays(in, particles_);
  in.value(critical_density_);
  in.value(fastest_speed_);
  in.value(widest_crossing_);
}

template class DensityHybridSolver<2>;
template class DensityHybridSolver<3>;

}  // namespace snowsim
