#include "render/colour.h"

#include <algorithm>
#include <cmath>

namespace snowsim {

glm::vec3 colormap(float t) {
  t = std::clamp(t, 0.f, 1.f);
  const glm::vec3 low(0.15f, 0.35f, 0.85f), mid(0.95f, 0.95f, 0.95f), high(0.85f, 0.15f, 0.1f);
  return t < 0.5f ? glm::mix(low, mid, 2 * t) : glm::mix(mid, high, 2 * t - 1);
}

namespace {
const glm::vec3 snow_white(0.93f, 0.95f, 1.0f);
}  // namespace

glm::vec3 particleColour(const Snapshot& s, int i, ColorBy by, float scale) {
  auto speed = [&] { return std::hypot(s.velocity[i][0], s.velocity[i][1], s.velocity[i][2]); };
  switch (by) {
    case ColorBy::Density:
      return scale > 0 ? colormap(s.density[i] / scale) : snow_white;
    case ColorBy::Speed:
      return scale > 0 ? colormap(speed() / scale) : snow_white;
    case ColorBy::Plastic:
      // J_P = 1 white; 0.8 (compressed by a fifth) full red; 1.2 full blue.
      return colormap(0.5f + 2.5f * (1.f - s.plastic_j[i]));
    case ColorBy::White:
      break;
  }
  return snow_white;
}

}  // namespace snowsim
