// The geometry behind the particles: the grid's lines and the 2D density cells, as vertices of
// position and colour (six floats each) for the line program.
#pragma once

#include <vector>

#include <glm/glm.hpp>

#include "render/camera.h"
#include "sim/core/snapshot.h"

namespace snowsim {

// Lines closer than this on screen fade out; at twice it they are drawn in full.
constexpr float kLineFadePixels = 4;

// What the grid's lines are drawn over: the frame's background (the back wall's lines fade into
// it) and the ground's albedo (the floor's lines are lit as the ground is, and fade into it).
// weight scales the cell lines' contrast: 1 where lines are anti-aliased by supersampling, 0.5
// where they are not, so a line a pixel wide carries the same ink either way.
struct GridCanvas {
  glm::vec3 background{0}, ground{0};
  float weight = 1;
};

// The grid as a viewer can resolve it: the cell lines on the back plane, and in 3D both families
// of the floor's lines, each drawn only where the lines of its level lie at least kLineFadePixels
// apart on screen (on the floor: those of both families) (levels 1, 5, 10, 50, ... cells: every 5th
// line stays when single cells are too small, every 10th when those are, ...) and faded just above
// that, so no cell count or image size gives moire. The walls, the ground and (3D) the floor's
// outline are always drawn. Appends line segments (two vertices each): those on the back plane (2D:
// all) to `back`, those on the floor y = 0 (3D) to `floor`. Cell lines are a third of the way from
// the canvas to the wall's colour, light ink on a dark background and dark ink on a light one.
void gridLines(const Snapshot& s, glm::vec3 extent, const View& view, int width, int height,
               const GridCanvas& canvas, std::vector<float>& back, std::vector<float>& floor);

// The ground: the domain's bottom edge, y = 0 along x at z = 0 (2D frames draw it with or without
// the grid). Appends one line segment.
void groundLine(glm::vec3 extent, std::vector<float>& out);

// 2D: each node's cell (side h, centred on the node, clipped to the domain) shaded by its density
// against the critical density: the background turning blue below it, amber at or above it.
// Appends triangles.
void densityCells(const Snapshot& s, glm::vec3 extent, glm::vec3 background,
                  std::vector<float>& out);

}  // namespace snowsim
