#include "sim/io/vdb.h"

#include <cmath>
#include <filesystem>
#include <mutex>

#include <openvdb/openvdb.h>
#include <openvdb/tools/SignedFloodFill.h>

#include "sim/core/bspline.h"
#include "sim/core/errors.h"
#include "sim/geometry/snow_surface.h"
#include "sim/io/files.h"

namespace snowsim {

namespace {

// The voxel of node (i, j, k) in the file's axes: (x, y, z) -> (x, -z, y) for z up.
openvdb::Coord voxelOf(int i, int j, int k, UpAxis up) {
  const auto turned = toUpAxis<int>({i, j, k}, up);
  return {turned[0], turned[1], turned[2]};
}

// The surface's narrow band as a level set grid; the interior's tiles take their sign from it.
openvdb::FloatGrid::Ptr surfaceGrid(const SurfaceField& field, UpAxis up) {
  auto grid = openvdb::FloatGrid::create(field.background);
  {
    auto at = grid->getAccessor();
    for (size_t v = 0; v < field.voxels.size(); ++v) {
      const auto& c = field.voxels[v];
      at.setValue(voxelOf(c[0], c[1], c[2], up), field.values[v]);
    }
  }
  openvdb::tools::signedFloodFill(grid->tree());
  grid->setTransform(openvdb::math::Transform::createLinearTransform(field.voxel_size));
  grid->setName("surface");
  grid->setGridClass(openvdb::GRID_LEVEL_SET);
  return grid;
}

}  // namespace

void writeVdb(const std::string& path, const Snapshot& s, UpAxis up) {
  if (s.grid.dimension != 3 || s.mass.size() != s.position.size())
    throw InputError(path + ": a VDB volume needs a 3D frame with particle masses");
  static std::once_flag initialised;
  std::call_once(initialised, [] { openvdb::initialize(); });

  const double h = s.grid.cell_size;
  const auto transform = openvdb::math::Transform::createLinearTransform(h);
  auto mass = openvdb::FloatGrid::create(0.f);
  auto momentum = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.f));
  {
    auto mass_at = mass->getAccessor();
    auto momentum_at = momentum->getAccessor();
    for (int p = 0; p < s.size(); ++p) {
      const auto v = toUpAxis(s.velocity[p], up);
      forEachQuadraticNode(s.position[p], h, [&](int i, int j, int k, double w) {
        const float m = static_cast<float>(s.mass[p] * w);
        const openvdb::Coord voxel = voxelOf(i, j, k, up);
        mass_at.setValue(voxel, mass_at.getValue(voxel) + m);
        momentum_at.setValue(voxel,
                             momentum_at.getValue(voxel) + openvdb::Vec3s(v[0], v[1], v[2]) * m);
      });
    }
  }
  auto density = openvdb::FloatGrid::create(0.f);
  auto velocity = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.f));
  {
    auto density_at = density->getAccessor();
    auto velocity_at = velocity->getAccessor();
    auto momentum_at = momentum->getConstAccessor();
    const float inv_volume = static_cast<float>(1 / (h * h * h));
    for (auto node = mass->cbeginValueOn(); node; ++node) {
      if (*node <= 0) continue;
      density_at.setValue(node.getCoord(), *node * inv_volume);
      velocity_at.setValue(node.getCoord(), momentum_at.getValue(node.getCoord()) / *node);
    }
  }
  density->setName("density");
  density->setGridClass(openvdb::GRID_FOG_VOLUME);
  velocity->setName("velocity");
  velocity->setVectorType(openvdb::VEC_CONTRAVARIANT_RELATIVE);
  openvdb::GridPtrVec grids{density, velocity};
  for (auto& grid : grids) grid->setTransform(transform->copy());
  if (s.surface) grids.push_back(surfaceGrid(s.surface->field, up));
  for (auto& grid : grids) grid->insertMeta("snowsim_time", openvdb::DoubleMetadata(s.time));

  const std::string temporary = path + ".tmp";
  const UnfinishedFile unfinished(temporary);  // a second signal removes it
  try {
    openvdb::io::File file(temporary);
    file.write(grids);
    file.close();
  } catch (const openvdb::Exception& e) {
    std::filesystem::remove(temporary);
    throw InputError(path + ": cannot write (" + e.what() + ")");
  }
  try {
    syncFile(temporary, path);
  } catch (const InputError&) {
    std::filesystem::remove(temporary);
    throw;
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    std::filesystem::remove(temporary);
    throw InputError(path + ": cannot write (" + ec.message() + ")");
  }
}

}  // namespace snowsim
