// The report's snow method (seed report, sections 3.2-3.3): particles rasterised to a grid,
// gravity only, a critical-density rule that stops grid force and velocity from pushing into
// packed cells, explicit Euler, PIC/FLIP. Where the report is vague, DensityHybridParams selects
// the reading (docs/report-readings.md).
#pragma once

#include <vector>

#include "sim/core/grid.h"
#include "sim/scene/scene.h"
#include "sim/solver.h"

namespace snowsim {

// Step 4 of the report for one axis of one cell: the component this cell pushes towards a
// packed neighbour, given the neighbour's component along the same axis (section 3.3).
// Returns the component unchanged when the neighbour moves away at least as fast.
Real clampTowardsPacked(Real own, Real neighbour);

// Step 4 over a whole field (force or velocity): every component pointing into a neighbour whose
// density is at or above the critical density is clamped by clampTowardsPacked. New values are
// computed from the old ones only (in -> out), so the order of the cells does not matter.
template <int D>
void equaliseTowardsPacked(const GridGeometry<D>& grid, const std::vector<Real>& density,
                           Real critical_density, const std::vector<Vec<D>>& in,
                           std::vector<Vec<D>>& out);

template <int D>
class DensityHybridSolver final : public Solver<D> {
 public:
  DensityHybridSolver(const Scene& scene, Particles<D> particles);

  const Particles<D>& particles() const override { return particles_; }
  void describe(Snapshot& snapshot) const override;

  Real criticalDensity() const { return critical_density_; }
  const GridGeometry<D>& grid() const { return grid_; }
  const GridFields<D>& fields() const { return fields_; }
  const std::vector<Real>& nodeDensity() const { return node_density_; }

  // The stages of one step, in order (report section 3.2); public so tests can drive them.
  void rasterise();                    // 1. mass and velocity to the grid
  void computeParticleVolumes();       // 2. first step only: rho_p, V_p, critical density
  void computeGridForces();            // 3. f_i = m_i g
  void holdWalls();                    //    walls of the box (the fluid code's boundary)
  void equaliseForcesAndVelocities();  // 4. critical-density rule (section 3.3)
  void updateGridVelocities(Real dt);  // 5. v* = v + dt f / m
  void updateParticleVelocities();     // 6. PIC/FLIP blend
  void collideWithGround();            // 7. particles at the ground lose downward speed
  void advect(Real dt);                // 8. x += dt v, kept inside the box

 private:
  void advance(Real dt) override;
  void checkDivergence(Real dt) const override;
  void saveSolverState(StateWriter& out) const override;
  void loadSolverState(StateReader& in) override;
  bool isWallNode(const IVec<D>& i, int axis) const;

  DensityHybridParams params_;
  Vec<D> gravity_;
  Particles<D> particles_;
  GridGeometry<D> grid_;
  GridFields<D> fields_;
  std::vector<Real> node_density_;  // m_i / h^D of the current step
  std::vector<Vec<D>> scratch_;     // new values of step 4 (read old, write new)
  int slab_axis_ = -1;              // the extruded axis of a 2D scene run as a 3D slab, else -1
  Real critical_density_ = 0;
  // Of the last advection, before the walls stopped anyone: the largest speed and the largest
  // fraction of the domain's width along an axis that a particle crossed in the step.
  Real fastest_speed_ = 0;
  Real widest_crossing_ = 0;
};

}  // namespace snowsim
