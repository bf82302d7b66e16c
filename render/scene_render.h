// The scene's `render` object (sim/scene/scene.h, parsed and validated with the rest of the scene
// file) as the renderer's settings: image size, colouring and its range, sphere size, grid and
// density cells, the 3D camera, the look, background, shadows and occlusion. The command line
// overrides any of them (app/render_sink.h).
#pragma once

#include "render/renderer.h"
#include "sim/scene/scene.h"

namespace snowsim {

// The renderer's defaults with the fields the scene gives.
RenderSettings renderSettingsFromScene(const SceneRender& render);

// What a run of the scene settles before its first frame, so that every frame is drawn alike:
// a 3D camera that is not placed frames, from its preset, the first frame's snow swept along
// its bodies' initial velocities over the run (within the domain) and down to the ground, and
// the colliders inside the domain; a colour range not given is the physical default
// (physicalColourRange).
void fitToScene(RenderSettings& settings, const Scene& scene, const Snapshot& first);

// The range a quantity can reach in a run of the scene, known before it runs. Density: the
// report's method colours against twice its critical density (none here); MPM from 0 to twice
// the densest body's rest density. Speed: from 0 to the fastest body's initial speed plus the
// speed of a fall through the domain's height, sqrt(2 |g| H). Plastic (MPM): J_P from a quarter
// to four (kPlasticRange, render/colour.h).
std::optional<ColourRange> physicalColourRange(const Scene& scene, ColorBy by);

}  // namespace snowsim
