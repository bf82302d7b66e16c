// The geometry behind the particles: the grid's lines and the 2D density cells, as vertices of
// position and colour (six floats each) for the line program.
#pragma once

#include <vector>

#include <glm/glm.hpp>

#include "sim/core/snapshot.h"

namespace snowsim {

// The grid: thin cell lines on the back plane, the walls and the ground drawn brighter. Appends
// line segments (two vertices each).
void gridLines(const Snapshot& s, glm::vec3 extent, std::vector<float>& out);

// 2D: each node's cell (side h, centred on the node, clipped to the domain) shaded by its density
// against the critical density: the background turning blue below it, amber at or above it.
// Appends triangles.
void densityCells(const Snapshot& s, glm::vec3 extent, std::vector<float>& out);

}  // namespace snowsim
