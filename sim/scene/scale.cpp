#include "sim/scene/scale.h"

#include <cmath>
#include <sstream>

#include "sim/core/errors.h"

namespace snowsim {

void applyScale(double scale, const std::vector<std::string>& user_overrides, Scene& scene) {
  std::ostringstream option;
  option << "--scale " << scale;
  if (!std::isfinite(scale) || scale <= 0)
    throw InputError(option.str() + ": allowed: a number above 0 (2: cells half the size, " +
                     "twice as many along each axis; 0.5: a coarser draft)");
  try {
    scaleGrid(scene, scale);
  } catch (const InputError& e) {
    throw InputError(option.str() + ": " + e.what());
  }
  // A step resolves a fraction of a cell: with fixed steps the same fraction of the smaller cell.
  if (!overridesField(user_overrides, "time.dt")) scene.dt /= scale;
  if (scene.render.sphere_radius && !overridesField(user_overrides, "render.sphere_radius"))
    *scene.render.sphere_radius /= scale;  // 0, half the particle spacing, follows by itself
}

}  // namespace snowsim
