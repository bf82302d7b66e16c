// The quality levels, from the full study's Pareto fronts: docs/study.md, "snowsim run --quality",
// has each level's measured cost and error on the report's snowball drop and thrown ball and on
// a 3D smash.
#include "sim/scene/quality.h"

#include "sim/core/errors.h"

namespace snowsim {

namespace {

// The level's changes, each made unless the user's --set gave the field.
class Changes {
 public:
  Changes(Scene& scene, const std::vector<std::string>& user) : scene(scene), user_(user) {}

  bool free(const char* path) const { return !overridesField(user_, path); }
  template <class T>
  void set(const char* path, T& field, T value) {
    if (free(path)) field = value;
  }
  void particlesPerCell(int count) {
    if (free("particles_per_cell")) setParticlesPerCell(scene, count);
  }

  Scene& scene;

 private:
  const std::vector<std::string>& user_;
};

// The report's method: only its time step and particle count matter (a finer grid is a different
// model for it, not a more accurate one).
void densityHybrid(const std::string& level, Changes& c) {
  // A draft dt of 0.005 would halve the cost, but the thrown ball then tunnels through the tower.
  c.set("time.dt", c.scene.dt, level == "draft" ? 0.002 : level == "figure" ? 0.001 : 0.0002);
  c.particlesPerCell(level == "draft" ? 9 : 16);
}

// MPM: explicit MLS at the adaptive CFL step. The semi-implicit solver is on the drop's front at
// half the cell size but costs several times more on the thrown ball (the tower's ground contact)
// and more still in 3D (docs/study.md), so no level uses it.
void mpm(const std::string& level, Changes& c) {
  const bool two_d = c.scene.authored_dimension == 2;
  c.set("mpm.transfer", c.scene.mpm.transfer, MpmTransfer::Mls);
  c.set("mpm.integrator", c.scene.mpm.integrator, MpmIntegrator::Explicit);
  c.set("mpm.adaptive_dt", c.scene.mpm.adaptive_dt, true);
  if (level == "draft") c.particlesPerCell(two_d ? 4 : 8);
  // 27 per cell in 3D triples the cost for no measured gain at this level.
  if (level == "figure") c.particlesPerCell(two_d ? 9 : 8);
  if (level == "reference") {
    c.particlesPerCell(two_d ? 9 : 27);
    c.set("mpm.cfl", c.scene.mpm.cfl, 0.5);
    if (c.free("grid.cells") && c.free("grid.cell_size")) refineGrid(c.scene, 2);
  }
}

}  // namespace

void checkQualityLevel(const std::string& level) {
  if (!level.empty() && level != "draft" && level != "figure" && level != "reference")
    throw InputError("--quality: unknown level '" + level + "'; allowed: draft, figure, reference");
}

void applyQuality(const std::string& level, const std::vector<std::string>& user_overrides,
                  Scene& scene) {
  checkQualityLevel(level);
  if (level.empty()) return;
  Changes changes(scene, user_overrides);
  try {
    if (scene.solver == SolverType::Mpm)
      mpm(level, changes);
    else
      densityHybrid(level, changes);
  } catch (const InputError& e) {
    throw InputError("--quality " + level + ": " + e.what());
  }
}

}  // namespace snowsim
