#include "sim/simulation.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "sim/core/errors.h"
#include "sim/mpm/mpm_solver.h"
#include "sim/report/density_hybrid.h"
#include "sim/scene/sampling.h"

namespace snowsim {

namespace {

template <int D>
class SimulationOf final : public Simulation {
 public:
  SimulationOf(const Scene& scene, int threads) : scene_(scene) {
    if (scene.solver == SolverType::Mpm)
      solver_ = std::make_unique<MpmSolver<D>>(scene, sampleBodies<D>(scene), threads);
    else
      solver_ = std::make_unique<DensityHybridSolver<D>>(scene, sampleBodies<D>(scene));
  }

  void advanceTo(double target) override {
    while (target - time_ > 1e-9 * scene_.dt) {
      double dt = std::min<double>(scene_.dt, solver_->stableTimeStep());
      // Land exactly on the target instead of leaving a sliver for one more step.
      if (target - time_ - dt < 1e-6 * dt) dt = target - time_;
      solver_->step(dt);
      time_ += dt;
      ++steps_;
      checkFinite();
    }
    time_ = std::max(time_, target);
  }

  Snapshot snapshot(int frame) const override {
    Snapshot s;
    s.frame = frame;
    s.time = time_;
    s.grid.dimension = D;
    for (int a = 0; a < 3; ++a) s.grid.cells[a] = a < D ? scene_.cells[a] : 1;
    s.grid.cell_size = scene_.cell_size;
    s.grid.particle_spacing = scene_.cell_size;
    for (const Body& body : scene_.bodies)
      s.grid.particle_spacing = std::min(s.grid.particle_spacing, particleSpacing(scene_, body));
    const Particles<D>& p = solver_->particles();
    s.position.resize(p.size());
    s.velocity.resize(p.size());
    for (int i = 0; i < p.size(); ++i)  // in creation order, however the solver stores them
      for (int a = 0; a < 3; ++a) {
        s.position[p.id[i]][a] = a < D ? static_cast<float>(p.x[i][a]) : 0.f;
        s.velocity[p.id[i]][a] = a < D ? static_cast<float>(p.v[i][a]) : 0.f;
      }
    solver_->describe(s);
    return s;
  }

  double time() const override { return time_; }
  long steps() const override { return steps_; }
  int particleCount() const override { return solver_->particles().size(); }
  SolveTally implicitSolves() const override { return solver_->implicitSolves(); }

 private:
  // A blown-up state is stopped where it happens, never written out.
  void checkFinite() const {
    const Particles<D>& p = solver_->particles();
    for (int i = 0; i < p.size(); ++i) {
      if (p.x[i].allFinite() && p.v[i].allFinite()) continue;
      std::ostringstream s;
      s << scene_.file << ": the simulation diverged at step " << steps_ << " (t = " << time_
        << " s): particle " << i << " has a non-finite position or velocity; try a smaller "
        << "time.dt than " << scene_.dt;
      throw SimulationError(s.str());
    }
  }

  Scene scene_;
  std::unique_ptr<Solver<D>> solver_;
  double time_ = 0;
  long steps_ = 0;
};

}  // namespace

std::unique_ptr<Simulation> makeSimulation(const Scene& scene, int threads) {
  if (scene.dimension == 2) return std::make_unique<SimulationOf<2>>(scene, threads);
  return std::make_unique<SimulationOf<3>>(scene, threads);
}

}  // namespace snowsim
