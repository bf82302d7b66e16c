// The quality levels, from the Pareto fronts of the full study (docs/study.md; errors against the
// APIC MPM reference run, 0.5 s of the report's snowball drop on its 10 x 12 grid).
#include "app/quality.h"

#include "sim/errors.h"

namespace snowsim {

namespace {

// The report's method: only its time step and particle count matter (a finer grid does not
// converge for this method).
std::vector<std::string> densityHybrid(const std::string& level) {
  // draft: dt 0.005, 9 per cell: 1.8 ms, density-field error 0.70, centre of mass 7.2 mm off.
  if (level == "draft") return {"time.dt=0.005", "particles_per_cell=9"};
  // figure: the report's dt 0.001: 12 ms, error 0.53, 3.5 mm (16 per cell).
  if (level == "figure") return {"time.dt=0.001", "particles_per_cell=16"};
  // reference: dt 0.0002, 16 per cell: 57 ms, error 0.27, 2.0 mm.
  return {"time.dt=0.0002", "particles_per_cell=16"};
}

// MPM: the semi-implicit APIC runs form the front from 20 ms up; its step is capped by time.dt
// and by the advection limit.
std::vector<std::string> mpm(const std::string& level, const Scene& scene) {
  const std::string ppc = scene.authored_dimension == 2 ? "9" : "8";
  std::vector<std::string> o = {"mpm.transfer=apic", "mpm.integrator=semi_implicit",
                                "mpm.adaptive_dt=true", "particles_per_cell=" + ppc};
  // draft: dt 0.005: 21 ms, error 0.41, centre of mass 3.3 mm off.
  if (level == "draft") o.push_back("time.dt=0.005");
  // figure: dt 0.002: 27 ms, error 0.35, 1.2 mm.
  if (level == "figure") o.push_back("time.dt=0.002");
  if (level == "reference") {
    // reference: dt 0.002 on a grid of half the cell size: 0.7 s, error 0.10, 0.8 mm.
    o.push_back("time.dt=0.002");
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
