// snowsim run --quality: the time step and resolution the study (docs/study.md) measured as the
// cheapest for a given error, as scene overrides applied before the user's --set.
#pragma once

#include <string>
#include <vector>

namespace snowsim {

// draft | figure | reference; "" gives no overrides. Throws InputError for any other name.
std::vector<std::string> qualityOverrides(const std::string& level);

}  // namespace snowsim
