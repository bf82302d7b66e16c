// Frames as OpenVDB volumes for volumetric rendering (Blender, Houdini): a FloatGrid `density`
// (kg/m^3) and a Vec3SGrid `velocity` (m/s; Blender's default velocity grid name, Houdini's is
// `vel`) on voxels of the run's cell size centred on the MPM grid nodes. OpenVDB's headers stay in
// vdb.cpp: they compile slowly.
#pragma once

#include <string>

#include "sim/core/snapshot.h"
#include "sim/io/up_axis.h"

namespace snowsim {

// Rasterises the particles with MPM's quadratic B-spline weights w_ip onto nodes i h: density
// sum_p m_p w_ip / h^3, velocity sum_p m_p w_ip v_p / sum_p m_p w_ip, only on nodes some particle
// reaches. Voxel (i, j, k) is node (i, j, k) (turned with the positions when `up` is z), so the
// volume lies where the PLY's particles do. Needs a 3D snapshot with masses. Writes atomically
// (a temporary file renamed into place); throws InputError naming the file when it cannot.
// A snapshot that carries its surface (sim/geometry/snow_surface.h) adds the FloatGrid `surface`
// (GRID_LEVEL_SET: the signed distance in m, negative inside, its narrow band active) on voxels
// of the surface's size, placed alike: voxel (i, j, k) at (i, j, k) times it, turned for z up.
void writeVdb(const std::string& path, const Snapshot& snapshot, UpAxis up = UpAxis::Y);

}  // namespace snowsim
