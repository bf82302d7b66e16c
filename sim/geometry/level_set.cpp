#include "sim/geometry/level_set.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>

#include <openvdb/openvdb.h>
#include <openvdb/tools/MeshToVolume.h>

namespace snowsim {

double LevelSet::voxelFor(const TriangleMesh& mesh, double voxel_size, double margin) {
  const auto [lo, hi] = mesh.bounds();
  auto count = [&](double v) {  // as many as the constructor's dims_
    double n = 1;
    for (int a = 0; a < 3; ++a)
      n *= std::ceil((hi[a] + margin) / v) - std::floor((lo[a] - margin) / v) + 1;
    return n;
  };
  double voxel = voxel_size;
  while (count(voxel) > kMaxVoxels) voxel *= 1.25;
  return voxel;
}

LevelSet::LevelSet(const TriangleMesh& mesh, double voxel_size, double margin) {
  static std::once_flag initialised;
  std::call_once(initialised, [] { openvdb::initialize(); });

  const auto [lo, hi] = mesh.bounds();
  voxel_ = voxelFor(mesh, voxel_size, margin);

  std::array<int, 3> first{};
  for (int a = 0; a < 3; ++a) {
    first[a] = static_cast<int>(std::floor((lo[a] - margin) / voxel_));
    dims_[a] = static_cast<int>(std::ceil((hi[a] + margin) / voxel_)) - first[a] + 1;
    origin_[a] = first[a] * voxel_;
  }

  std::vector<openvdb::Vec3s> points;
  points.reserve(mesh.vertices.size());
  for (const auto& p : mesh.vertices)
    points.emplace_back(static_cast<float>(p[0]), static_cast<float>(p[1]),
                        static_cast<float>(p[2]));
  std::vector<openvdb::Vec3I> triangles;
  triangles.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) triangles.emplace_back(t[0], t[1], t[2]);
  // The exterior band reaches every voxel of the box; the interior is filled whole, so a deep
  // point still knows its distance to the surface.
  const float exterior_band = static_cast<float>(margin / voxel_) + 2;
  const auto transform = openvdb::math::Transform::createLinearTransform(voxel_);
  const openvdb::FloatGrid::Ptr grid =
      openvdb::tools::meshToSignedDistanceField<openvdb::FloatGrid>(
          *transform, points, triangles, {}, exterior_band, std::numeric_limits<float>::max());

  values_.resize(static_cast<size_t>(dims_[0]) * dims_[1] * dims_[2]);
  const auto accessor = grid->getConstAccessor();
  size_t n = 0;
  for (int k = 0; k < dims_[2]; ++k)
    for (int j = 0; j < dims_[1]; ++j)
      for (int i = 0; i < dims_[0]; ++i)
        values_[n++] = accessor.getValue(openvdb::Coord(first[0] + i, first[1] + j, first[2] + k));
  // Beyond the box phi is a face's value plus the distance to it (phi below).
  float lowest = 0;
  for (int k = 0; k < dims_[2]; ++k)
    for (int j = 0; j < dims_[1]; ++j)
      for (int i = 0; i < dims_[0]; ++i) {
        const bool on_face = i == 0 || j == 0 || k == 0 || i == dims_[0] - 1 || j == dims_[1] - 1 ||
                             k == dims_[2] - 1;
        if (on_face) lowest = std::min(lowest, at(i, j, k));
      }
  face_reach_ = -double(lowest);
}

std::array<double, 3> LevelSet::solidLower() const {
  return {origin_[0] - face_reach_, origin_[1] - face_reach_, origin_[2] - face_reach_};
}

std::array<double, 3> LevelSet::solidUpper() const {
  std::array<double, 3> upper;
  for (int a = 0; a < 3; ++a) upper[a] = origin_[a] + (dims_[a] - 1) * voxel_ + face_reach_;
  return upper;
}

double LevelSet::depth() const {
  return values_.empty()
             ? 0
             : std::max(0.0, -double(*std::min_element(values_.begin(), values_.end())));
}

LevelSet::Position LevelSet::locate(const std::array<double, 3>& x) const {
  Position at;
  for (int a = 0; a < 3; ++a) {
    // Clamped in metres, so a point inside the box is exactly 0 away from it.
    const double inside = std::clamp(x[a], origin_[a], origin_[a] + (dims_[a] - 1) * voxel_);
    at.beyond[a] = x[a] - inside;
    at.voxels[a] = std::min((inside - origin_[a]) / voxel_, dims_[a] - 1.0);
  }
  return at;
}

namespace {

// The cell of u along an axis (its lower corner, so the upper one is still in the box) and the
// fraction across it.
std::pair<int, double> cellOf(double u, int dim) {
  const int i = std::min(static_cast<int>(u), std::max(dim - 2, 0));
  return {i, u - i};
}

}  // namespace

double LevelSet::phi(const std::array<double, 3>& x) const {
  const auto [u, beyond] = locate(x);
  const double outside2 = beyond[0] * beyond[0] + beyond[1] * beyond[1] + beyond[2] * beyond[2];
  const auto [i, fx] = cellOf(u[0], dims_[0]);
  const auto [j, fy] = cellOf(u[1], dims_[1]);
  const auto [k, fz] = cellOf(u[2], dims_[2]);
  auto lerp = [](double a, double b, double t) { return a + t * (b - a); };
  const double c00 = lerp(at(i, j, k), at(i + 1, j, k), fx);
  const double c10 = lerp(at(i, j + 1, k), at(i + 1, j + 1, k), fx);
  const double c01 = lerp(at(i, j, k + 1), at(i + 1, j, k + 1), fx);
  const double c11 = lerp(at(i, j + 1, k + 1), at(i + 1, j + 1, k + 1), fx);
  return lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz) + std::sqrt(outside2);
}

std::array<double, 3> LevelSet::gradient(const std::array<double, 3>& x) const {
  const auto [u, beyond] = locate(x);
  const double outside2 = beyond[0] * beyond[0] + beyond[1] * beyond[1] + beyond[2] * beyond[2];
  if (outside2 > 0) {  // beyond the box: away from it
    const double len = std::sqrt(outside2);
    return {beyond[0] / len, beyond[1] / len, beyond[2] / len};
  }
  const auto [i, fx] = cellOf(u[0], dims_[0]);
  const auto [j, fy] = cellOf(u[1], dims_[1]);
  const auto [k, fz] = cellOf(u[2], dims_[2]);
  // The derivative of the trilinear interpolant along each axis, the others interpolated.
  auto corner = [&](int di, int dj, int dk) {
    return static_cast<double>(at(i + di, j + dj, k + dk));
  };
  const double wx[2] = {1 - fx, fx}, wy[2] = {1 - fy, fy}, wz[2] = {1 - fz, fz};
  std::array<double, 3> g{0, 0, 0};
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) {
      g[0] += wy[a] * wz[b] * (corner(1, a, b) - corner(0, a, b));
      g[1] += wx[a] * wz[b] * (corner(a, 1, b) - corner(a, 0, b));
      g[2] += wx[a] * wy[b] * (corner(a, b, 1) - corner(a, b, 0));
    }
  for (double& c : g) c /= voxel_;
  return g;
}

}  // namespace snowsim
