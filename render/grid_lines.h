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

// The grid as a viewer can resolve it: the cell lines on the back plane (3D: and the floor's z
// lines), each line drawn only where the lines of its level lie at least kLineFadePixels apart on
// screen (levels 1, 5, 10, 50, ... cells: every 5th line stays when single cells are too small,
// every 10th when those are, ...) and faded towards the background just above that, so no cell
// count or image size gives moire. The walls, the ground and (3D) the floor's outline are always
// drawn. Appends line segments (two vertices each).
// Faded lines blend into the frame's background colour.
void gridLines(const Snapshot& s, glm::vec3 extent, const View& view, int width, int height,
               glm::vec3 background, std::vector<float>& out);

// The ground: the domain's bottom edge, y = 0 along x at z = 0 (2D frames draw it with or without
// the grid). Appends one line segment.
void groundLine(glm::vec3 extent, std::vector<float>& out);

// 2D: each node's cell (side h, centred on the node, clipped to the domain) shaded by its density
// against the critical density: the background turning blue below it, amber at or above it.
// Appends triangles.
void densityCells(const Snapshot& s, glm::vec3 extent, glm::vec3 background,
                  std::vector<float>& out);

}  // namespace snowsim
