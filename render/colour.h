// The colours of particles: snow white, or a quantity (density, speed, plastic compression)
// through viridis over a range fixed for the whole run, so a colour means the same value in
// every frame.
#pragma once

#include <string>

#include <glm/glm.hpp>

#include "render/renderer.h"
#include "sim/core/snapshot.h"

namespace snowsim {

// Viridis (perceptually uniform, readable in grey and by colour-blind viewers), t in [0, 1].
glm::vec3 viridis(float t);

// The values the colour map spans for this frame: the settings' range when given; else for
// density twice the critical density (the report's method), for plastic J_P 0.8 to 1.2, and
// otherwise (only when the caller fixed nothing) the frame's own extremes.
ColourRange colourRange(const RenderSettings& settings, const Snapshot& s);

// "white", "density", "speed" or "plastic": the name parseColorBy reads.
std::string colorByName(ColorBy by);

// The quantity and its unit, for colour bars: "density (kg/m^3)", "speed (m/s)", ...
std::string colourLabel(ColorBy by, int dimension);

// The colour of particle i under the chosen attribute and range.
glm::vec3 particleColour(const Snapshot& s, int i, ColorBy by, const ColourRange& range);

}  // namespace snowsim
