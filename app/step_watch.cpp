#include "app/step_watch.h"

#include <cstdio>
#include <limits>

namespace snowsim {

StepWatch::StepWatch(const Scene& scene, double initial_step, const StepLimit& initial_limit)
    : scene_(scene), initial_step_(initial_step), initial_limit_(initial_limit) {}

nlohmann::json StepWatch::state() const {
  const StepLimit& l = initial_limit_;
  return {{"initial_step", initial_step_},
          {"initial_limit", {l.step, l.particle_speed, l.wave_speed, l.plastic_j, l.hardening}},
          {"record", record_}};
}

StepWatch::StepWatch(const Scene& scene, const nlohmann::json& state) : scene_(scene) {
  // JSON has no infinity: an unlimited step was written as null.
  const auto number = [](const nlohmann::json& j) {
    return j.is_null() ? std::numeric_limits<double>::infinity() : j.get<double>();
  };
  initial_step_ = number(state.at("initial_step"));
  const nlohmann::json& l = state.at("initial_limit");
  initial_limit_ = {number(l.at(0)), number(l.at(1)), number(l.at(2)), number(l.at(3)),
                    number(l.at(4))};
  record_ = state.at("record");
}

std::string StepWatch::check(const Simulation& simulation) {
  if (!record_.is_null() || simulation.steps() == 0 ||
      simulation.chosenSteps().smallest >= collapse_fraction * initial_step_)
    return "";
  const StepLimit limit = simulation.stepLimit();
  const double step = simulation.chosenSteps().smallest;
  const bool hardening = limit.wave_speed > limit.particle_speed;
  char text[900];
  int n = std::snprintf(text, sizeof text,
                        "snowsim: warning: %s: at t = %.3g s (step %ld) the time step fell below a "
                        "quarter of the %.2g s it started at, to %.2g s: ",
                        scene_.file.c_str(), simulation.time(), simulation.steps(), initial_step_,
                        step);
  if (hardening)
    std::snprintf(text + n, sizeof text - n,
                  "the snow hardened. Its stiffest elastic wave runs at %.3g m/s (%.3g at the "
                  "start): compacted to J_P = %.3g, that snow is exp(xi (1 - J_P)) = %.3g times as "
                  "stiff (material.xi %g), and an explicit step must resolve the wave. A smaller "
                  "material.xi%s keeps a larger step",
                  limit.wave_speed, initial_limit_.wave_speed, limit.plastic_j, limit.hardening,
                  scene_.material.xi,
                  // The semi-implicit integrator refuses a damper.
                  scene_.material.viscosity > 0
                      ? ""
                      : ", or mpm.integrator=semi_implicit (whose step has no wave term),");
  else
    std::snprintf(text + n, sizeof text - n,
                  "the snow sped up. It moves at %.3g m/s (%.3g at the start; its elastic wave "
                  "at %.3g m/s), and a step may carry it only mpm.cfl (%g) of a cell (%g m)",
                  limit.particle_speed, initial_limit_.particle_speed, limit.wave_speed,
                  scene_.mpm.cfl, scene_.cell_size);
  record_ = {{"time", simulation.time()},
             {"step", simulation.steps()},
             {"step_size", step},
             {"initial_step_size", initial_step_},
             {"cause", hardening ? "hardening" : "speed"},
             {"particle_speed", limit.particle_speed},
             {"wave_speed", limit.wave_speed},
             {"plastic_j", limit.plastic_j},
             {"hardening", limit.hardening},
             {"message", text}};
  return text;
}

}  // namespace snowsim
