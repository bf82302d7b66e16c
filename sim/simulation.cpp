#include "sim/simulation.h"

#include <algorithm>

#include "sim/core/errors.h"
#include "sim/io/checkpoint.h"
#include "sim/mpm/mpm_solver.h"
#include "sim/report/density_hybrid.h"
#include "sim/scene/sampling.h"
#include "sim/scene/scene_colliders.h"
#include "sim/simulation_memory.h"

namespace snowsim {

namespace {

template <int D, class T>
void putMpmState(const MpmSolver<D, T>& mpm, StateArrays& out) {
  const MpmParticles<D, T>& p = mpm.outputParticles();  // in id order, as particles() is
  out.elastic_gradient.resize(size_t(p.size()) * D * D);
  out.plastic_j.resize(p.size());
  for (int i = 0; i < p.size(); ++i) {
    const size_t id = p.id[i];
    for (int r = 0; r < D; ++r)
      for (int c = 0; c < D; ++c) out.elastic_gradient[(id * D + r) * D + c] = p.F_E[i](r, c);
    out.plastic_j[id] = p.J_P[i];
  }
  const GridGeometry<D>& grid = mpm.grid();
  for (int a = 0; a < D; ++a) out.nodes[a] = grid.nodes[a];
  const GridFields<D, T>& fields = mpm.fields();
  out.node_mass.assign(fields.mass.begin(), fields.mass.end());
  out.node_velocity.resize(fields.velocity.size() * D);
  for (size_t k = 0; k < fields.velocity.size(); ++k)
    for (int a = 0; a < D; ++a) out.node_velocity[k * D + a] = fields.velocity[k][a];
}

template <int D>
class SimulationOf final : public Simulation {
 public:
  SimulationOf(const Scene& scene, int threads, RankExchange& world) : scene_(scene) {
    refuseWhatIsNotDistributed(scene, world.ranks());
    if (scene.solver == SolverType::Mpm && scene.mpm.precision == MpmPrecision::Float)
      solver_ =
          std::make_unique<MpmSolver<D, float>>(scene, sampleBodies<D>(scene), threads, world);
    else if (scene.solver == SolverType::Mpm)
      solver_ = std::make_unique<MpmSolver<D>>(scene, sampleBodies<D>(scene), threads, world);
    else
      solver_ = std::make_unique<DensityHybridSolver<D>>(scene, sampleBodies<D>(scene));
  }

  bool advanceTo(double target, const std::function<bool()>& stop_requested) override {
    try {
      return solver_->advanceTo(target, scene_.dt, stop_requested);
    } catch (const SimulationError& e) {
      throw SimulationError(scene_.file + ": " + e.what());
    }
  }

  void step() override {
    try {
      solver_->stepOnce(scene_.dt);
    } catch (const SimulationError& e) {
      throw SimulationError(scene_.file + ": " + e.what());
    }
  }

  Snapshot snapshot(int frame) const override {
    Snapshot s;
    s.frame = frame;
    s.time = time();
    s.grid.dimension = D;
    for (int a = 0; a < 3; ++a) s.grid.cells[a] = a < D ? scene_.cells[a] : 1;
    s.grid.cell_size = scene_.cell_size;
    s.grid.particle_spacing = scene_.cell_size;
    for (const Body& body : scene_.bodies)
      s.grid.particle_spacing = std::min(s.grid.particle_spacing, particleSpacing(scene_, body));
    solver_->snapshotParticles(scene_, s);
    s.colliders = collidersAt(scene_, D, s.time);
    solver_->describe(s);
    return s;
  }

  StateArrays stateArrays() const override {
    StateArrays out;
    out.dimension = D;
    const Particles<D>& p = solver_->particles();
    const int n = p.size();
    out.position.resize(size_t(n) * D);
    out.velocity.resize(size_t(n) * D);
    out.mass.resize(n);
    for (int i = 0; i < n; ++i) {
      const size_t id = p.id[i];
      for (int a = 0; a < D; ++a) {
        out.position[id * D + a] = p.x[i][a];
        out.velocity[id * D + a] = p.v[i][a];
      }
      out.mass[id] = p.mass[i];
    }
    if (const auto* mpm = dynamic_cast<const MpmSolver<D>*>(solver_.get()))
      putMpmState(*mpm, out);
    else if (const auto* mpm_float = dynamic_cast<const MpmSolver<D, float>*>(solver_.get()))
      putMpmState(*mpm_float, out);
    return out;
  }

  double time() const override { return solver_->time(); }
  long steps() const override { return solver_->steps(); }
  StepSizes chosenSteps() const override { return solver_->chosenSteps(); }
  int particleCount() const override { return solver_->particleCount(); }
  SolverStatistics statistics() const override { return solver_->statistics(); }
  double stepSeconds() const override { return solver_->stepSeconds(); }
  StepLimit stepLimit() const override { return solver_->stepLimit(); }
  std::vector<StageSeconds> stepStages() const override {
    std::vector<StageSeconds> stages = solver_->stageSeconds();
    double rest = solver_->stepSeconds();
    for (const StageSeconds& s : stages) rest -= s.seconds;
    stages.push_back({stages.empty() ? "step" : "rest of the step", std::max(0.0, rest)});
    return stages;
  }
  void saveState(StateWriter& out) const override { solver_->saveState(out); }
  void loadState(std::string_view bytes, const std::string& file) override {
    StateReader in(bytes, file);
    solver_->loadState(in);
    in.finish();
  }

 private:
  Scene scene_;
  std::unique_ptr<Solver<D>> solver_;
};

}  // namespace

std::unique_ptr<Simulation> makeSimulation(const Scene& scene, int threads, RankExchange& world) {
  refuseGridTooLarge(scene.name, gridNodeCount(scene));
  if (scene.dimension == 2) return std::make_unique<SimulationOf<2>>(scene, threads, world);
  return std::make_unique<SimulationOf<3>>(scene, threads, world);
}

}  // namespace snowsim
