// The explicit MPM step a run will come down to once its snow meets a collider or other snow and
// hardens: the CFL step C h / max_p (c_p + |v_p|) shrinks as the wave speed c_p grows by the
// square root of the hardening factor e^{xi (1 - J_P)} (Stomakhin et al. 2013, eq. 8).
//
// Snow hit at speed v stops where its hardened stress, about rho c^2 theta_c at the critical
// compression, carries the impact's momentum flux rho c v: c ~ v / theta_c, and a softer
// hardening (smaller xi) leaves it a little below. The constant is fitted to the shipped scenes
// (scripts/estimate_check.py prints their estimates against their runs); bounded hardening caps
// c at c_0 sqrt(hardening_max).
#pragma once

#include "sim/scene/scene.h"
#include "sim/solver.h"

namespace snowsim {

struct StepForecast {
  double impact_speed = 0;   // m/s: the fastest snow meets a collider, the ground or other snow
  double impact_time = 0;    // s: when the first body does, at the earliest
  double hardened_step = 0;  // s: the step once it has hardened
  // A moving collider keeps pushing the snow, which can compact it past what one impact does.
  bool driven = false;
};

// For an explicit MPM scene with an adaptive step, starting at `start`; none for any other.
std::optional<StepForecast> forecastStep(const Scene& scene, const StepLimit& start);

}  // namespace snowsim
