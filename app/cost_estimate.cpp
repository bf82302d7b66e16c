#include "app/cost_estimate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <vector>

namespace snowsim {

namespace {

struct Unit {
  double from, size;
  const char* format;  // of value / size
};

// The value in the first unit it reaches.
std::string inUnits(double value, std::initializer_list<Unit> units) {
  char text[64] = "";
  for (const Unit& unit : units)
    if (value >= unit.from) {
      std::snprintf(text, sizeof text, unit.format, value / unit.size);
      break;
    }
  return text;
}

// The time the steps so far spent in the stages of cracks that open (the solver's stages
// "crack: ...", its crack scatter among them).
double crackSeconds(const Simulation& simulation) {
  double seconds = 0;
  for (const StageSeconds& s : simulation.stepStages())
    if (s.stage.starts_with("crack:")) seconds += s.seconds;
  return seconds;
}

}  // namespace

std::string roughCount(double count) {
  return inUnits(count, {{1e9, 1e9, "%.1f billion"},
                         {1e6, 1e6, "%.1f million"},
                         {1e4, 1e3, "%.0f thousand"},
                         {-INFINITY, 1, "%.0f"}});
}

std::string roughDuration(double seconds) {
  return inUnits(seconds, {{5400, 3600, "%.1f h"}, {90, 60, "%.0f min"}, {-INFINITY, 1, "%.2g s"}});
}

CostEstimate::CostEstimate(const Scene& scene, int particles, const StepLimit& start,
                           std::optional<Resumed> resumed)
    : name_(scene.name),
      duration_(std::max(0.0, scene.duration - (resumed ? resumed->simulated : 0))),
      resumed_(resumed.has_value()),
      steps_taken_(resumed ? resumed->steps_taken : 0),
      particles_(particles),
      initial_step_(std::min(scene.dt, start.step)),
      forecast_(forecastStep(scene, start)),
      open_cracks_(scene.solver == SolverType::Mpm && scene.mpm.open_cracks) {
  // A moving collider can compact snow past what an impact does, unless the hardening is bounded.
  may_harden_further_ = forecast_ && forecast_->driven && scene.material.hardening_max > 1e6;
  mesh_collider_ =
      scene.solver == SolverType::Mpm &&
      std::any_of(scene.colliders.begin(), scene.colliders.end(),
                  [](const ColliderParams& c) { return c.shape == ColliderShape::Mesh; });
  if (forecast_ && resumed) forecast_->impact_time -= resumed->simulated;
  char grid[96];
  int n = std::snprintf(grid, sizeof grid, "%d", scene.cells[0]);
  for (int a = 1; a < scene.dimension; ++a)
    n += std::snprintf(grid + n, sizeof grid - n, " x %d", scene.cells[a]);
  std::snprintf(grid + n, sizeof grid - n, " cells of %g m", scene.cell_size);
  grid_ = grid;
  particle_steps_ = double(particles_) * stepCount();
}

double CostEstimate::stepCount() const {
  // The first step until the impact (without a forecast, throughout), the hardened one after. A
  // duration a round-off above a whole number of steps takes no extra step; zero takes none (not
  // the -0 that ceil gives).
  const double before_impact =
      forecast_ ? std::clamp(forecast_->impact_time, 0.0, duration_) : duration_;
  const double after_impact =
      forecast_ ? (duration_ - before_impact) / forecast_->hardened_step : 0;
  return std::max(0.0, std::ceil(before_impact / initial_step_ + after_impact - 1e-9));
}

std::string CostEstimate::before() const {
  char hardened[160] = "";
  if (forecast_ && forecast_->hardened_step < initial_step_ && forecast_->impact_time < duration_)
    std::snprintf(hardened, sizeof hardened,
                  ", %.2g s once it meets an obstacle at about %.2g m/s and hardens",
                  forecast_->hardened_step, forecast_->impact_speed);
  char text[600];  // the scene's name, of any length, goes in front
  std::snprintf(text, sizeof text,
                ": %s particles, %s; %.3g s %s at a first step of %.2g s%s: about %s "
                "steps, %s particle-steps",
                roughCount(particles_).c_str(), grid_.c_str(), duration_,
                resumed_ ? "left to simulate" : "simulated", initial_step_, hardened,
                roughCount(stepCount()).c_str(), roughCount(particle_steps_).c_str());
  return name_ + text;
}

std::string CostEstimate::afterStep(const Simulation& simulation) {
  if (said_) return "";
  const long steps = simulation.steps() - steps_taken_;
  if (steps == 1) {
    seconds_after_first_ = simulation.stepSeconds();
    crack_seconds_after_first_ = crackSeconds(simulation);
  }
  // Snow stretched at the first timed step stays so: every timed step runs the crack step.
  if (steps == 2 && open_cracks_)
    cracks_timed_ = crackSeconds(simulation) > crack_seconds_after_first_;
  if (seconds_after_first_ < 0 || steps < 1 + measured_steps) return "";
  const double seconds = simulation.stepSeconds() - seconds_after_first_;
  if (seconds < measured_seconds && steps < 1 + most_measured_steps) return "";
  said_ = true;
  // Of the simulation timed, which --estimate may make at a coarser resolution than the run's.
  const double rate = simulation.particleCount() * double(steps - 1) / std::max(seconds, 1e-9);
  // A semi-implicit step's solve takes more iterations once the snow meets a collider or
  // hardens, which the first steps of a falling body do not show.
  const bool solves = simulation.statistics().implicit_solves.solves > 0;
  // Cracks that open cost their passes only once some snow has stretched past J_P = 1, which the
  // first steps before an impact do not show (docs/snow-at-scale.md measures the factor), unless
  // the timed steps ran them from the first (a resumed run, snow stretched from the start).
  const bool cracks_ahead = open_cracks_ && !cracks_timed_;
  std::string caveat = solves ? "; more if the step shrinks or its solves take more iterations, "
                                "as they do once the snow lands"
                              : "";
  if (cracks_ahead)
    caveat +=
        "; the range allows a step 2 to 4 times as long once any snow has stretched past "
        "J_P = 1 (mpm.open_cracks)";
  if (may_harden_further_)
    caveat += "; and up to twice the steps as a moving collider compacts the snow";
  // Snow near a mesh collider reads its distance field at every particle and grid node, which
  // snow falling towards it does not yet.
  if (mesh_collider_)
    caveat += "; and up to twice as long a step once the snow meets the mesh collider";
  const double seconds_at_rate = particle_steps_ / rate;
  const double low = seconds_at_rate * (cracks_ahead ? 2 : 1);
  const double high = seconds_at_rate * (cracks_ahead ? 4 : 1) * (may_harden_further_ ? 2 : 1) *
                      (mesh_collider_ ? 2 : 1);
  std::string span = roughDuration(low);
  if (roughDuration(high) != span) span += " to " + roughDuration(high);
  char text[600];  // the scene's name, of any length, goes in front
  std::snprintf(text, sizeof text,
                ": estimate: the steps take about %s (%s particle-steps a second over steps "
                "2-%d%s); rendering and writing frames come on top",
                span.c_str(), roughCount(rate).c_str(), int(steps), caveat.c_str());
  return name_ + text;
}

}  // namespace snowsim
