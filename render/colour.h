// The colours of particles: snow white, or a quantity over a range fixed for the whole run, so a
// colour means the same value in every frame: density and speed through viridis, the plastic
// volume ratio J_P through a diverging map over log J_P, neutral at 1.
#pragma once

#include <string>

#include <glm/glm.hpp>

#include "render/renderer.h"
#include "sim/core/snapshot.h"

namespace snowsim {

// The colour of snow: the white colouring's, and the volume look's albedo.
glm::vec3 snowWhite();

// Viridis (perceptually uniform, readable in grey and by colour-blind viewers), t in [0, 1].
glm::vec3 viridis(float t);

// Cool to warm (Moreland): t = 0 warm red, 0.5 light grey, 1 cool blue; t in [0, 1].
glm::vec3 coolWarm(float t);

// J_P's default range, known before a run: a quarter to four times the volume, symmetric in log.
constexpr ColourRange kPlasticRange{0.25, 4};

// Where `value` sits on the colour map, 0 to 1 (clamped): linearly from range.low to range.high;
// for J_P over log J_P, 1 in the middle and each side reaching its end of the range
// (range.low < 1 < range.high), so a range symmetric in log is symmetric in colour.
float colourScale(double value, ColorBy by, const ColourRange& range);

// The map of the quantity: coolWarm for J_P, viridis for the others.
glm::vec3 colourMap(ColorBy by, float t);

// The range symmetric in log about J_P = 1 that spans J_P from smallest to largest (both > 0).
ColourRange plasticRangeSpanning(double smallest, double largest);

// The values the colour map spans for this frame: the settings' range when given; else for
// density twice the critical density (the report's method), for plastic kPlasticRange, and
// otherwise (only when the caller fixed nothing) the frame's own extremes.
ColourRange colourRange(const RenderSettings& settings, const Snapshot& s);

// "white", "density", "speed" or "plastic": the name parseColorBy reads.
std::string colorByName(ColorBy by);

// The quantity and its unit, for colour bars: "density (kg/m^3)", "speed (m/s)", ...
std::string colourLabel(ColorBy by, int dimension);

// The colour of particle i under the chosen attribute and range.
glm::vec3 particleColour(const Snapshot& s, int i, ColorBy by, const ColourRange& range);

}  // namespace snowsim
