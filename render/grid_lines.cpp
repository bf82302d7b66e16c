#include "render/grid_lines.h"

#include <algorithm>

namespace snowsim {

namespace {

// Appends one line segment (two vertices of position and colour).
void addLine(std::vector<float>& out, glm::vec3 a, glm::vec3 b, glm::vec3 colour) {
  for (const glm::vec3& p : {a, b})
    out.insert(out.end(), {p.x, p.y, p.z, colour.r, colour.g, colour.b});
}

}  // namespace

void gridLines(const Snapshot& s, glm::vec3 extent, std::vector<float>& out) {
  const float cell = static_cast<float>(s.grid.cell_size);
  const glm::vec3 thin(0.36f, 0.39f, 0.45f), wall(0.75f, 0.78f, 0.85f), ground(0.55f, 0.42f, 0.3f);
  for (int i = 0; i <= s.grid.cells[0]; ++i) {
    const bool edge = i == 0 || i == s.grid.cells[0];
    addLine(out, {i * cell, 0, 0}, {i * cell, extent.y, 0}, edge ? wall : thin);
  }
  for (int j = 0; j <= s.grid.cells[1]; ++j) {
    const bool edge = j == s.grid.cells[1];
    addLine(out, {0, j * cell, 0}, {extent.x, j * cell, 0}, j == 0 ? ground : edge ? wall : thin);
  }
  if (s.grid.dimension == 3)
    for (int k = 0; k <= s.grid.cells[2]; ++k)
      addLine(out, {0, 0, k * cell}, {extent.x, 0, k * cell}, ground);
}

void densityCells(const Snapshot& s, glm::vec3 extent, std::vector<float>& out) {
  const auto& d = s.grid.node_density;
  const int nx = s.grid.cells[0] + 1, ny = s.grid.cells[1] + 1;
  if (s.grid.dimension != 2 || static_cast<int>(d.size()) != nx * ny) return;
  float reference = static_cast<float>(s.grid.critical_density);
  if (!(reference > 0)) reference = *std::max_element(d.begin(), d.end());
  if (!(reference > 0)) return;
  const float h = static_cast<float>(s.grid.cell_size), z = -0.002f;  // just behind the lines
  const glm::vec3 background(0.2f, 0.22f, 0.27f), loose(0.25f, 0.45f, 0.75f),
      critical(0.95f, 0.62f, 0.15f);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const float ratio = d[static_cast<size_t>(j) * nx + i] / reference;
      if (ratio <= 0) continue;
      const glm::vec3 colour =
          ratio >= 1 ? critical : glm::mix(background, loose, std::min(ratio, 1.f));
      const float x0 = std::max(0.f, (i - 0.5f) * h), x1 = std::min(extent.x, (i + 0.5f) * h);
      const float y0 = std::max(0.f, (j - 0.5f) * h), y1 = std::min(extent.y, (j + 0.5f) * h);
      for (const glm::vec2& p : {glm::vec2(x0, y0), glm::vec2(x1, y0), glm::vec2(x1, y1),
                                 glm::vec2(x0, y0), glm::vec2(x1, y1), glm::vec2(x0, y1)})
        out.insert(out.end(), {p.x, p.y, z, colour.r, colour.g, colour.b});
    }
}

}  // namespace snowsim
