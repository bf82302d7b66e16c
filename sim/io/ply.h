// Frames as binary little-endian PLY, one vertex per particle: float x y z vx vy vz density
// (kg/m^D), plastic_j (MPM's J_P), mass (kg), pscale (radius, m; Houdini's name) and int id (the
// particle's index at creation, Houdini's name), readable by Blender and Houdini. The grid and the
// up axis are recorded in comments and, for 2D runs, the node densities as a second element, so a
// frame can be rendered again later.
#pragma once

#include <istream>
#include <string>
#include <vector>

#include "sim/core/snapshot.h"
#include "sim/geometry/snow_surface.h"
#include "sim/io/up_axis.h"

namespace snowsim {

// Writes atomically (a temporary file renamed into place). Throws InputError when it cannot.
// UpAxis::Z writes positions and velocities turned to z up (sim/io/up_axis.h).
void writePly(const std::string& path, const Snapshot& snapshot, UpAxis up = UpAxis::Y);

// The snow's surface mesh of a frame (sim/geometry/snow_surface.h) as binary little-endian PLY:
// vertices float x y z nx ny nz, faces as lists of three uint vertex_indices (counter-clockwise
// seen from outside), the frame, time, up axis and loose grains in comments. Atomic, turned to
// z up as writePly does; throws InputError when it cannot write.
void writeSurfacePly(const std::string& path, const SnowSurface& surface, const Snapshot& snapshot,
                     UpAxis up = UpAxis::Y);

// What a reader needs from a file: a snowsim frame (the grid comments and density, for drawing
// it), or only particles (x y z vx vy vz; any other tool's binary PLY) to start a run from.
enum class PlyContent { Frame, Particles };

// Reads a file written by writePly (old frames without mass, pscale and id too), in the scene's
// y-up coordinates whatever its up axis. Throws InputError naming the file and what is wrong.
Snapshot readPly(const std::string& path, PlyContent content = PlyContent::Frame);
// The same from a stream that can seek (a file, a string), `path` naming it in messages.
Snapshot readPly(std::istream& in, const std::string& path, PlyContent content = PlyContent::Frame);

// The .ply files of a directory (a run's frame_NNNNN.ply, not its surface_NNNNN.ply meshes),
// sorted by name. Throws InputError when there are none.
std::vector<std::string> plyFramesIn(const std::string& directory);

}  // namespace snowsim
