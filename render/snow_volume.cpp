#include "render/snow_volume.h"

#include <algorithm>
#include <cmath>

#include "sim/core/bspline.h"

namespace snowsim {

namespace {

size_t indexOf(const SnowVolume& v, int x, int y, int z) {
  return 3 * ((static_cast<size_t>(z) * v.size.y + y) * v.size.x + x);
}

// Channel c of layer y at (x, z), bilinear between texels; zero outside the texels.
float layerAt(const SnowVolume& v, int y, float x, float z, int c) {
  const int x0 = static_cast<int>(std::floor(x)), z0 = static_cast<int>(std::floor(z));
  const float fx = x - x0, fz = z - z0;
  float sum = 0;
  for (int corner = 0; corner < 4; ++corner) {
    const int cx = x0 + (corner & 1), cz = z0 + (corner >> 1);
    if (cx < 0 || cz < 0 || cx >= v.size.x || cz >= v.size.z) continue;
    sum += (corner & 1 ? fx : 1 - fx) * (corner & 2 ? fz : 1 - fz) *
           v.texels[indexOf(v, cx, y, cz) + c];
  }
  return sum;
}

}  // namespace

void buildSnowVolume(const Snapshot& s, float radius, glm::vec3 towards_light, SnowVolume& v) {
  v.texels.clear();
  v.size = glm::ivec3(0);
  v.low = glm::vec3(1), v.high = glm::vec3(0);
  if (s.size() == 0) return;
  // Texels half a cell apart, over the nodes the particles reach and one more each side (zero).
  const double h = 0.5 * s.grid.cell_size;
  v.spacing = static_cast<float>(h);
  glm::vec3 lowest(1e30f), highest(-1e30f);
  for (const auto& x : s.position) {
    lowest = glm::min(lowest, glm::vec3(x[0], x[1], x[2]));
    highest = glm::max(highest, glm::vec3(x[0], x[1], x[2]));
  }
  const glm::ivec3 first = glm::ivec3(glm::floor(lowest / v.spacing - 0.5f)) - 1;
  const glm::ivec3 last = glm::ivec3(glm::floor(highest / v.spacing - 0.5f)) + 3;
  v.size = last - first + 1;
  v.origin = glm::vec3(first) * v.spacing;
  v.texels.assign(3 * static_cast<size_t>(v.size.x) * v.size.y * v.size.z, 0.f);
  const double cross_section = 3.14159265358979 * radius * radius / (h * h * h);
  for (const auto& x : s.position)
    forEachQuadraticNode(x, h, [&](int i, int j, int k, double w) {
      v.texels[indexOf(v, i - first.x, j - first.y, k - first.z)] +=
          static_cast<float>(w * cross_section);
    });
  v.low = v.origin;
  v.high = v.origin + glm::vec3(v.size - 1) * v.spacing;

  // Towards the light, which comes from above: layer by layer from the top, each texel's depth is
  // that where the ray towards the light meets the layer above (bilinear) plus the trapezoid rule
  // between the two, so the march costs a few samples a texel.
  const glm::vec2 shift(towards_light.x / towards_light.y, towards_light.z / towards_light.y);
  const float step = v.spacing / towards_light.y;
  for (int y = v.size.y - 2; y >= 0; --y)
    for (int z = 0; z < v.size.z; ++z)
      for (int x = 0; x < v.size.x; ++x) {
        const float ux = x + shift.x, uz = z + shift.y;
        float* texel = &v.texels[indexOf(v, x, y, z)];
        texel[1] =
            layerAt(v, y + 1, ux, uz, 1) + 0.5f * step * (texel[0] + layerAt(v, y + 1, ux, uz, 0));
      }
  // Upwards: the trapezoid rule down each column.
  for (int z = 0; z < v.size.z; ++z)
    for (int x = 0; x < v.size.x; ++x) {
      float depth = 0, above = 0;
      for (int y = v.size.y - 1; y >= 0; --y) {
        float* texel = &v.texels[indexOf(v, x, y, z)];
        depth += 0.5f * (above + texel[0]) * v.spacing;
        above = texel[0];
        texel[2] = depth;
      }
    }
}

}  // namespace snowsim
