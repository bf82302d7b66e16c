// The snow's surface from its particles, as Houdini's MPM Surface builds it: each particle a
// sphere, their union a narrow-band signed distance field (OpenVDB's particles to level set),
// smoothed and eroded back, then the triangle mesh of its zero level (OpenVDB's volume to mesh).
// Particles the surface cannot hold (isolated ones, and those the smoothing leaves outside) are
// handed back as loose grains, to be drawn as spheres beside it. OpenVDB stays in the .cpp.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "sim/core/snapshot.h"

namespace snowsim {

enum class SurfaceFilter { Gaussian, MeanCurvature, None };

// Parses "gaussian", "mean-curvature", "none"; throws InputError listing the allowed names.
SurfaceFilter parseSurfaceFilter(const std::string& name, const std::string& where);
std::string surfaceFilterName(SurfaceFilter filter);

struct SurfaceSettings {
  // Voxel side, a fraction of the cell size; smaller where a particle's sphere would be narrower
  // than 1.5 voxels (voxelSize).
  double voxel = 0.5;
  double radius = 1.5;  // each particle's sphere, in particle spacings
  // How far the smoothed surface is moved in, in particle spacings (negative: out). The default
  // takes back the spheres' reach beyond the particles' own rest volume (radius - 0.5) less what
  // the smoothing already took, so that a ball of snow keeps its volume.
  double erode = 0.3;
  SurfaceFilter filter = SurfaceFilter::Gaussian;
  int smoothing = 2;        // filter iterations
  double adaptivity = 0.0;  // volume to mesh: 0 uniform triangles, up to 1 fewer and larger
  // A particle with fewer other particles in the 3x3x3 cells around its own is a loose grain.
  int min_neighbours = 8;
  int threads = 0;  // OpenVDB's (TBB's) threads; 0: all
};

// Checks the settings; throws InputError naming the field (`where` + voxel, radius, erode,
// smoothing, adaptivity, min-neighbours, threads) and what is allowed.
void validate(const SurfaceSettings& settings, const std::string& where);

// The narrow band of the signed distance field, as plain data: voxel (i, j, k) is at
// (i, j, k) * voxel_size (m), its value the distance (m, negative inside).
struct SurfaceField {
  double voxel_size = 0;
  float background = 0;  // the band's half width (m): the value beyond it outside, minus inside
  std::vector<std::array<int, 3>> voxels;
  std::vector<float> values;
};

struct SnowSurface {
  std::vector<std::array<float, 3>> vertices;           // m, the snapshot's frame (y up)
  std::vector<std::array<float, 3>> normals;            // unit, outward, one per vertex
  std::vector<std::array<std::uint32_t, 3>> triangles;  // counter-clockwise seen from outside
  std::vector<std::uint32_t> loose;  // particle indices not in the surface, ascending
  int isolated = 0;                  // of them, particles with too few neighbours to be rasterised
  // Of them, particles the smoothed, eroded surface leaves farther outside than their sphere's
  // radius.
  int smoothed_away = 0;
  SurfaceField field;
};

// The voxel side (m) the surface of this snapshot is built on.
double voxelSize(const Snapshot& snapshot, const SurfaceSettings& settings);

// The surface of a 3D snapshot. The same snapshot and settings give the same surface, bit for
// bit, on any number of threads. Throws InputError for a 2D snapshot.
SnowSurface buildSnowSurface(const Snapshot& snapshot, const SurfaceSettings& settings);

// For each vertex, the average of `components` values a particle (values[p * components + c])
// over the particles within `reach` (m), weighted (1 - d^2 / reach^2)^2; the nearest particle's
// where none is that close.
std::vector<float> averageAtVertices(const SnowSurface& surface,
                                     const std::vector<std::array<float, 3>>& positions,
                                     const std::vector<float>& values, int components,
                                     double reach);

}  // namespace snowsim
