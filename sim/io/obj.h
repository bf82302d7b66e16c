// The snow's surface mesh of a frame as Wavefront OBJ text, which every 3D package imports.
#pragma once

#include <string>

#include "sim/core/snapshot.h"
#include "sim/geometry/snow_surface.h"
#include "sim/io/up_axis.h"

namespace snowsim {

// Vertices (v), their normals (vn) and triangles (f v//vn, counter-clockwise seen from outside),
// the frame and time in comments; the same mesh and up axis as writeSurfacePly (sim/io/ply.h).
// Atomic; throws InputError when it cannot write.
void writeSurfaceObj(const std::string& path, const SnowSurface& surface, const Snapshot& snapshot,
                     UpAxis up = UpAxis::Y);

}  // namespace snowsim
