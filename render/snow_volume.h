// The snow as a participating medium, for --look volume: the particles rasterised onto texels half
// a cell apart with MPM's quadratic B-spline weights (scaled to that spacing), as an extinction
// coefficient, with the optical depth from each texel towards the key light and straight up,
// which the renderer's ray march reads for the light's shadow and the sky's. Plain arrays, no
// OpenGL.
#pragma once

#include <vector>

#include <glm/glm.hpp>

#include "sim/core/snapshot.h"

namespace snowsim {

struct SnowVolume {
  glm::ivec3 size{0};         // texels along x, y, z: those the particles reach, one more each side
  float spacing = 0;          // between texels: half the cell size (m)
  glm::vec3 origin{0};        // world position of texel (0, 0, 0)
  glm::vec3 low{0}, high{0};  // world box of the texels' centres; low > high: no snow
  // Three floats a texel, x fastest: extinction sigma (1/m), then the optical depth
  // integral(sigma) from the texel towards the key light and straight up.
  std::vector<float> texels;

  bool empty() const { return low.x > high.x; }
};

// Fills `volume` (reusing its storage) from a 3D snapshot: sigma = n pi r^2 at each texel, n the
// particles' number density sum_p w_ip / h^3 (h the texel spacing) and r the spheres' radius, so
// that a ray meets as many spheres per metre as through the beads the other looks draw. The
// optical depth towards `towards_light` (a unit vector, its y the largest component and
// positive: a light from above) is carried down from layer to layer; upwards it is summed along
// each column.
void buildSnowVolume(const Snapshot& s, float radius, glm::vec3 towards_light, SnowVolume& volume);

}  // namespace snowsim
