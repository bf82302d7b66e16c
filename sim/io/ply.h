// Frames as binary little-endian PLY: one vertex per particle with position, velocity and density
// (and plastic_j for MPM), readable by Blender and Houdini. The grid is recorded in comments and,
// for 2D runs, the node densities as a second element, so a frame can be rendered again later.
#pragma once

#include <istream>
#include <string>
#include <vector>

#include "sim/core/snapshot.h"

namespace snowsim {

// Writes atomically (a temporary file renamed into place). Throws InputError when it cannot.
void writePly(const std::string& path, const Snapshot& snapshot);

// Reads a file written by writePly. Throws InputError naming the file and what is wrong.
Snapshot readPly(const std::string& path);
// The same from a stream that can seek (a file, a string), `path` naming it in messages.
Snapshot readPly(std::istream& in, const std::string& path);

// The .ply files of a directory (a run's frame_NNNNN.ply), sorted by name. Throws InputError when
// there are none.
std::vector<std::string> plyFramesIn(const std::string& directory);

}  // namespace snowsim
