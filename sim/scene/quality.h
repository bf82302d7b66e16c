// snowsim run --quality: the solver settings, time step and resolution the study (docs/study.md)
// measured as the cheapest for a given error, applied to the parsed scene as typed changes.
#pragma once

#include <string>
#include <vector>

#include "sim/scene/scene.h"

namespace snowsim {

// Throws InputError unless the level is draft, figure, reference or "" (the scene as written).
void checkQualityLevel(const std::string& level);

// Applies the level for the scene's solver, dimension and grid. The user's --set wins: a field
// one of `user_overrides` set is left as it is (for the reference level's finer grid, either of
// grid.cells and grid.cell_size keeps the grid as the user gave it).
void applyQuality(const std::string& level, const std::vector<std::string>& user_overrides,
                  Scene& scene);

}  // namespace snowsim
