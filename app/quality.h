// snowsim run --quality: the solver settings, time step and resolution the study (docs/study.md)
// measured as the cheapest for a given error, as scene overrides applied before the user's --set.
#pragma once

#include <string>
#include <vector>

#include "sim/scene/scene.h"

namespace snowsim {

// draft | figure | reference for this scene (its solver, its dimension and grid); "" gives no
// overrides. Throws InputError for any other name.
std::vector<std::string> qualityOverrides(const std::string& level, const Scene& scene);

}  // namespace snowsim
