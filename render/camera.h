// Where the renderer looks from: the view and projection matrices of a frame.
#pragma once

#include <glm/glm.hpp>

#include "sim/core/snapshot.h"

namespace snowsim {

struct RenderSettings;

struct View {
  glm::mat4 view, projection;
};

// 2D: the whole domain, orthographic, with a margin. 3D: the scene's camera, or by default a
// perspective view of the whole domain from the front, above and to the right.
View cameraFor(const Snapshot& s, const RenderSettings& settings, glm::vec3 extent);

}  // namespace snowsim
