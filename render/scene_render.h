// The `render` object of a scene file (docs/scene-format.md), validated like the rest of the
// scene: image size, colouring, sphere size, grid and density cells, and the 3D camera. The
// command line overrides any of them (app/render_sink.h).
#pragma once

#include <string>

#include "render/renderer.h"
#include "sim/scene/json_fields.h"

namespace snowsim {

// Throws InputError naming the file, the field and what is allowed.
RenderSettings renderSettingsFromScene(const Json& render, const std::string& file);

}  // namespace snowsim
