#include "sim/scene/resolve_scene.h"

#include "sim/scene/quality.h"
#include "sim/scene/scale.h"

namespace snowsim {

Scene resolveScene(const std::string& path, const SceneOverrides& overrides) {
  // Read and checked once, with the user's --set; the quality level (for the scene's solver and
  // dimension) then leaves alone what --set gave.
  checkQualityLevel(overrides.quality);
  Scene scene = loadScene(path, overrides.assignments);
  applyQuality(overrides.quality, overrides.assignments, scene);
  if (overrides.scale != 1) applyScale(overrides.scale, overrides.assignments, scene);
  return scene;
}

}  // namespace snowsim
