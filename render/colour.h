// The colours of particles.
#pragma once

#include <glm/glm.hpp>

#include "render/renderer.h"
#include "sim/core/snapshot.h"

namespace snowsim {

// Blue (low) through white to red (high), t in [0, 1].
glm::vec3 colormap(float t);

// The colour of particle i under the chosen attribute; scale normalises density and speed.
glm::vec3 particleColour(const Snapshot& s, int i, ColorBy by, float scale);

}  // namespace snowsim
