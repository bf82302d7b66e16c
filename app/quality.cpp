// The quality levels, from the full study's Pareto fronts (docs/study.md: errors against the APIC
// MPM reference run; 0.5 s of the report's snowball drop and thrown ball, 0.3 s of a 3D smash).
// Costs are `snowsim run --quality L --no-png --no-mp4 --no-ply` over the same durations; errors
// are the study's rows with the same settings (MPM: the fixed dt nearest the adaptive one).
#include "app/quality.h"

#include "sim/core/errors.h"

namespace snowsim {

namespace {

// The report's method: only its time step and particle count matter (a finer grid is a different
// model for it, not a more accurate one). Study rows, drop / thrown ball:
std::vector<std::string> densityHybrid(const std::string& level) {
  // draft: 2.7 / 5.6 ms, density-field error 0.68 / 0.75. dt 0.005 would halve the cost, but the
  // thrown ball then tunnels through the tower.
  if (level == "draft") return {"time.dt=0.002", "particles_per_cell=9"};
  // figure: 6.9 / 17 ms, error 0.53 / 0.58.
  if (level == "figure") return {"time.dt=0.001", "particles_per_cell=16"};
  // reference: 33 / 86 ms, error 0.27 / 0.52.
  return {"time.dt=0.0002", "particles_per_cell=16"};
}

// MPM: explicit MLS at the adaptive CFL step. The semi-implicit solver is on the drop's front at
// half the cell size but costs 4-10x more on the thrown ball (the tower's ground contact) and
// 25-60x more in 3D (docs/study.md), so no level uses it.
std::vector<std::string> mpm(const std::string& level, const Scene& scene) {
  const bool two_d = scene.authored_dimension == 2;
  std::vector<std::string> o = {"mpm.transfer=mls", "mpm.integrator=explicit",
                                "mpm.adaptive_dt=true"};
  // draft: 4 per cell (8 in 3D). Drop / ball / smash: 18 / 25 / 1900 ms, error 0.80 / 0.71 / 0.75.
  if (level == "draft") o.push_back(std::string("particles_per_cell=") + (two_d ? "4" : "8"));
  // figure: 9 per cell (8 in 3D: 27 triples the cost for no measured gain): 23 / 58 ms in 2D,
  // error 0.64 / 0.48.
  if (level == "figure") o.push_back(std::string("particles_per_cell=") + (two_d ? "9" : "8"));
  if (level == "reference") {
    // reference: half the cell size, 9 per cell (27 in 3D), C = 0.5: 0.43 / 1.2 / 147 s, error
    // 0.23 / 0.27 in 2D (study rows at half the cell size, dt 1e-4).
    o.push_back(std::string("particles_per_cell=") + (two_d ? "9" : "27"));
    o.push_back("mpm.cfl=0.5");
    o.push_back("grid.cell_size=" + std::to_string(scene.cell_size / 2));
    std::string cells = "grid.cells=[";
    for (int a = 0; a < scene.authored_dimension; ++a)
      cells += (a ? "," : "") + std::to_string(2 * scene.cells[a]);
    o.push_back(cells + "]");
  }
  return o;
}

}  // namespace

std::vector<std::string> qualityOverrides(const std::string& level, const Scene& scene) {
  if (level.empty()) return {};
  if (level != "draft" && level != "figure" && level != "reference")
    throw InputError("--quality: unknown level '" + level + "'; allowed: draft, figure, reference");
  return scene.solver == SolverType::Mpm ? mpm(level, scene) : densityHybrid(level);
}

}  // namespace snowsim
