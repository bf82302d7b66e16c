// The scene's `render` object (sim/scene/scene.h, parsed and validated with the rest of the scene
// file) as the renderer's settings: image size, colouring, sphere size, grid and density cells,
// the 3D camera, the look, background, shadows and occlusion. The command line overrides any of
// them (app/render_sink.h).
#pragma once

#include "render/renderer.h"
#include "sim/scene/scene.h"

namespace snowsim {

// The renderer's defaults with the fields the scene gives.
RenderSettings renderSettingsFromScene(const SceneRender& render);

}  // namespace snowsim
