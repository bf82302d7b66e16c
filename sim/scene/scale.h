// snowsim run --scale S: the scene at S times the resolution, as a typed change of the parsed
// scene (docs/scene-format.md, "Running at scale").
#pragma once

#include <string>
#include <vector>

#include "sim/scene/scene.h"

namespace snowsim {

// S times the cells along every axis and the cell size over S: the same domain, the same bodies
// at the same particles per cell, so about S^D times the particles. What is tied to the cell
// follows it: time.dt (the fixed step, or the largest one of an adaptive step) and the render's
// sphere radius shrink by S, unless one of `user_overrides` (--set) gave them. Throws InputError
// unless S > 0 gives a whole number of cells from 1 to 4096 along every axis.
void applyScale(double scale, const std::vector<std::string>& user_overrides, Scene& scene);

}  // namespace snowsim
