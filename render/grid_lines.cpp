#include "render/grid_lines.h"

#include <algorithm>

namespace snowsim {

namespace {

const glm::vec3 kGroundColour(0.55f, 0.42f, 0.3f);

// Appends one line segment (two vertices of position and colour).
void addLine(std::vector<float>& out, glm::vec3 a, glm::vec3 b, glm::vec3 colour) {
  for (const glm::vec3& p : {a, b})
    out.insert(out.end(), {p.x, p.y, p.z, colour.r, colour.g, colour.b});
}

// The largest of the nested levels 1, 5, 10, 50, 100, ... cells that divides line `index`.
int lineLevel(int index) {
  int level = 1, next = 5;
  for (bool doubling = true; index % next == 0 && next < (1 << 28); doubling = !doubling) {
    level = next;
    next *= doubling ? 2 : 5;
  }
  return level;
}

// How far apart on screen two lines one cell apart are, around point p with the step between
// them; lines behind the camera count as far apart (they are clipped anyway).
float pixelsPerCell(const View& view, int width, int height, glm::vec3 p, glm::vec3 step) {
  const glm::mat4 to_clip = view.projection * view.view;
  const glm::vec4 a = to_clip * glm::vec4(p, 1), b = to_clip * glm::vec4(p + step, 1);
  if (a.w <= 0 || b.w <= 0) return 1e9f;
  const glm::vec2 d = glm::vec2(a) / a.w - glm::vec2(b) / b.w;
  return glm::length(d * 0.5f * glm::vec2(width, height));
}

// A cell line's colour faded by its on-screen spacing; zero opacity: not drawn.
float lineOpacity(int level, float pixels_per_cell) {
  return std::clamp((level * pixels_per_cell - kLineFadePixels) / kLineFadePixels, 0.f, 1.f);
}

}  // namespace

void groundLine(glm::vec3 extent, std::vector<float>& out) {
  addLine(out, {0, 0, 0}, {extent.x, 0, 0}, kGroundColour);
}

void gridLines(const Snapshot& s, glm::vec3 extent, const View& view, int width, int height,
               const GridCanvas& canvas, std::vector<float>& back, std::vector<float>& floor) {
  const float cell = static_cast<float>(s.grid.cell_size);
  const bool dark = glm::dot(canvas.background, glm::vec3(0.299f, 0.587f, 0.114f)) < 0.5f;
  const glm::vec3 wall = dark ? glm::vec3(0.75f, 0.78f, 0.85f) : glm::vec3(0.45f, 0.48f, 0.55f);
  const glm::vec3 thin = glm::mix(canvas.background, wall, 0.3f);
  const glm::vec3 floor_thin = 0.6f * canvas.ground;
  const glm::vec3 centre = 0.5f * extent;
  // A cell line from a to b, faded into `under` by how far apart its level's lines lie, lines a
  // cell apart lying `pixels` apart.
  auto cellLine = [&](std::vector<float>& out, int index, float pixels, glm::vec3 a, glm::vec3 b,
                      glm::vec3 colour, glm::vec3 under) {
    const float opacity = canvas.weight * lineOpacity(lineLevel(index), pixels);
    if (opacity > 0) addLine(out, a, b, glm::mix(under, colour, opacity));
  };
  auto spacing = [&](glm::vec3 at, glm::vec3 step) {
    return pixelsPerCell(view, width, height, at, step);
  };
  // On the floor, the closer of the two families: both are drawn at a point, or neither.
  auto floorSpacing = [&](glm::vec3 at) {
    return std::min(spacing(at, {cell, 0, 0}), spacing(at, {0, 0, cell}));
  };
  for (int i = 0; i <= s.grid.cells[0]; ++i) {
    const glm::vec3 a(i * cell, 0, 0), b(i * cell, extent.y, 0);
    if (i == 0 || i == s.grid.cells[0])
      addLine(back, a, b, wall);
    else
      cellLine(back, i, spacing({i * cell, centre.y, 0}, {cell, 0, 0}), a, b, thin,
               canvas.background);
  }
  for (int j = 1; j <= s.grid.cells[1]; ++j) {
    const glm::vec3 a(0, j * cell, 0), b(extent.x, j * cell, 0);
    if (j == s.grid.cells[1])
      addLine(back, a, b, wall);
    else
      cellLine(back, j, spacing({centre.x, j * cell, 0}, {0, cell, 0}), a, b, thin,
               canvas.background);
  }
  if (s.grid.dimension != 3) {
    groundLine(extent, back);
    return;
  }
  // The floor's two families, a segment a cell long at a time: a line far from the camera fades
  // where its neighbours close up, and stays where they are apart; seen at a grazing angle, the
  // lines across the view fade and those along it with them, so no stripes are left.
  const int nx = s.grid.cells[0], nz = s.grid.cells[2];
  for (int k = 1; k < nz; ++k)
    for (int i = 0; i < nx; ++i)
      cellLine(floor, k, floorSpacing({(i + 0.5f) * cell, 0, k * cell}), {i * cell, 0, k * cell},
               {(i + 1) * cell, 0, k * cell}, floor_thin, canvas.ground);
  for (int i = 1; i < nx; ++i)
    for (int k = 0; k < nz; ++k)
      cellLine(floor, i, floorSpacing({i * cell, 0, (k + 0.5f) * cell}), {i * cell, 0, k * cell},
               {i * cell, 0, (k + 1) * cell}, floor_thin, canvas.ground);
  groundLine(extent, floor);
  addLine(floor, {0, 0, extent.z}, {extent.x, 0, extent.z}, kGroundColour);
  addLine(floor, {0, 0, 0}, {0, 0, extent.z}, kGroundColour);
  addLine(floor, {extent.x, 0, 0}, {extent.x, 0, extent.z}, kGroundColour);
}

void densityCells(const Snapshot& s, glm::vec3 extent, glm::vec3 background,
                  std::vector<float>& out) {
  const auto& d = s.grid.node_density;
  const int nx = s.grid.cells[0] + 1, ny = s.grid.cells[1] + 1;
  if (s.grid.dimension != 2 || static_cast<int>(d.size()) != nx * ny) return;
  float reference = static_cast<float>(s.grid.critical_density);
  if (!(reference > 0)) reference = *std::max_element(d.begin(), d.end());
  if (!(reference > 0)) return;
  const float h = static_cast<float>(s.grid.cell_size), z = -0.002f;  // just behind the lines
  const glm::vec3 loose(0.25f, 0.45f, 0.75f), critical(0.95f, 0.62f, 0.15f);
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
