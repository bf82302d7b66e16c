// A scene file as a run simulates it: read with the user's assignments, then at the quality
// level and the scale asked for. One step, so that every program resolves a scene alike.
#pragma once

#include <string>
#include <vector>

#include "sim/scene/scene.h"

namespace snowsim {

// The changes asked of a scene file beside what it says, applied in this order.
struct SceneOverrides {
  // "path=value" each, as given to --set (loadScene); the quality level and the scale leave the
  // fields they set alone.
  std::vector<std::string> assignments;
  std::string quality;  // draft | figure | reference (sim/scene/quality.h); empty: as written
  double scale = 1;     // resolution factor (sim/scene/scale.h)
};

// Throws InputError naming the file and field, the --set assignment, the quality level or the
// scale that cannot be met; an unknown quality level before the file is read.
Scene resolveScene(const std::string& path, const SceneOverrides& overrides);

}  // namespace snowsim
