#include "sim/geometry/snow_surface.h"

#include <algorithm>
#include <cmath>
#include <mutex>

#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/LevelSetFilter.h>
#include <openvdb/tools/LevelSetUtil.h>
#include <openvdb/tools/ParticlesToLevelSet.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/task_arena.h>

#include "sim/core/errors.h"

namespace snowsim {

SurfaceFilter parseSurfaceFilter(const std::string& name, const std::string& where) {
  if (name == "gaussian") return SurfaceFilter::Gaussian;
  if (name == "mean-curvature") return SurfaceFilter::MeanCurvature;
  if (name == "none") return SurfaceFilter::None;
  throw InputError(where + ": \"" + name +
                   "\" is not allowed; allowed: gaussian, mean-curvature, none");
}

std::string surfaceFilterName(SurfaceFilter filter) {
  switch (filter) {
    case SurfaceFilter::Gaussian:
      return "gaussian";
    case SurfaceFilter::MeanCurvature:
      return "mean-curvature";
    case SurfaceFilter::None:
      return "none";
  }
  return "";
}

void validate(const SurfaceSettings& s, const std::string& where) {
  auto check = [&](bool ok, const char* field, double value, const char* allowed) {
    if (!ok)
      throw InputError(where + field + " " + numberText(value) +
                       " is out of range; allowed: " + allowed);
  };
  check(s.voxel >= 0.05 && s.voxel <= 4, "voxel", s.voxel, "0.05 to 4 (a fraction of the cell)");
  check(s.radius >= 0.5 && s.radius <= 8, "radius", s.radius, "0.5 to 8 particle spacings");
  check(s.erode > -8 && s.erode < s.radius, "erode", s.erode,
        "above -8 and below the radius (particle spacings)");
  check(s.smoothing >= 0 && s.smoothing <= 50, "smoothing", s.smoothing, "0 to 50 iterations");
  check(s.adaptivity >= 0 && s.adaptivity <= 1, "adaptivity", s.adaptivity, "0 to 1");
  check(s.min_neighbours >= 0 && s.min_neighbours <= 1000, "min-neighbours", s.min_neighbours,
        "0 to 1000 particles");
  check(s.threads >= 0 && s.threads <= 1024, "threads", s.threads, "0 (all) to 1024");
}

namespace {

// The narrow band's half width in voxels: two, not OpenVDB's three, as each sphere's cost goes
// with the cube of its radius plus the band, and the smoothing needs no more.
constexpr double kHalfWidth = 2;

// The particles ParticlesToLevelSet rasterises: those with enough neighbours.
struct ParticleList {
  using PosType = openvdb::Vec3R;
  const std::vector<std::array<float, 3>>* positions;
  const std::vector<std::uint32_t>* kept;
  double radius;

  size_t size() const { return kept->size(); }
  void getPos(size_t n, openvdb::Vec3R& xyz) const {
    const auto& p = (*positions)[(*kept)[n]];
    xyz = openvdb::Vec3R(p[0], p[1], p[2]);
  }
  void getPosRad(size_t n, openvdb::Vec3R& xyz, openvdb::Real& r) const {
    getPos(n, xyz);
    r = radius;
  }
};

// Whether each particle has at least `wanted` other particles in the 3x3x3 cells of side h around
// its own (cells of the domain, clamped).
std::vector<bool> wellSurrounded(const Snapshot& s, int wanted) {
  const double h = s.grid.cell_size;
  const auto& n = s.grid.cells;
  auto cellOf = [&](const std::array<float, 3>& x, int a) {
    return std::clamp(static_cast<int>(std::floor(x[a] / h)), 0, n[a] - 1);
  };
  std::vector<int> count(static_cast<size_t>(n[0]) * n[1] * n[2], 0);
  auto index = [&](int i, int j, int k) { return (static_cast<size_t>(k) * n[1] + j) * n[0] + i; };
  for (const auto& x : s.position) ++count[index(cellOf(x, 0), cellOf(x, 1), cellOf(x, 2))];
  std::vector<bool> kept(s.position.size());
  for (size_t p = 0; p < s.position.size(); ++p) {
    const int ci = cellOf(s.position[p], 0), cj = cellOf(s.position[p], 1),
              ck = cellOf(s.position[p], 2);
    int around = -1;  // not itself
    for (int k = std::max(ck - 1, 0); k <= std::min(ck + 1, n[2] - 1); ++k)
      for (int j = std::max(cj - 1, 0); j <= std::min(cj + 1, n[1] - 1); ++j)
        for (int i = std::max(ci - 1, 0); i <= std::min(ci + 1, n[0] - 1); ++i)
          around += count[index(i, j, k)];
    kept[p] = around >= wanted;
  }
  return kept;
}

using Vec3 = std::array<float, 3>;

Vec3 minus(const Vec3& a, const Vec3& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// Area-weighted vertex normals, in triangle order (the same sums on any thread count).
void computeNormals(SnowSurface& surface) {
  surface.normals.assign(surface.vertices.size(), Vec3{0, 0, 0});
  for (const auto& t : surface.triangles) {
    const Vec3& a = surface.vertices[t[0]];
    const Vec3 n = cross(minus(surface.vertices[t[1]], a), minus(surface.vertices[t[2]], a));
    for (std::uint32_t v : t)
      for (int c = 0; c < 3; ++c) surface.normals[v][c] += n[c];
  }
  for (Vec3& n : surface.normals) {
    const float length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (length > 0)
      for (float& c : n) c /= length;
  }
}

double particleSpacing(const Snapshot& s) {
  return s.grid.particle_spacing > 0 ? s.grid.particle_spacing : s.grid.cell_size / 2;
}

void buildInArena(const Snapshot& s, const SurfaceSettings& settings, SnowSurface& surface) {
  const double spacing = particleSpacing(s);
  const double radius = settings.radius * spacing;
  const double voxel = voxelSize(s, settings);

  const std::vector<bool> surrounded = wellSurrounded(s, settings.min_neighbours);
  std::vector<std::uint32_t> kept;
  kept.reserve(s.position.size());
  for (size_t p = 0; p < s.position.size(); ++p) {
    if (surrounded[p])
      kept.push_back(static_cast<std::uint32_t>(p));
    else
      surface.loose.push_back(static_cast<std::uint32_t>(p));
  }
  surface.isolated = static_cast<int>(surface.loose.size());

  openvdb::FloatGrid::Ptr grid = openvdb::createLevelSet<openvdb::FloatGrid>(voxel, kHalfWidth);
  {
    openvdb::tools::ParticlesToLevelSet<openvdb::FloatGrid> raster(*grid);
    raster.rasterizeSpheres(ParticleList{&s.position, &kept, radius}, radius);
    raster.finalize(true);
  }
  if (settings.smoothing > 0 || settings.erode != 0) {
    openvdb::tools::LevelSetFilter<openvdb::FloatGrid> filter(*grid);
    // Each step renormalises the band: once, to first order, instead of OpenVDB's three fifth-order
    // passes, which took most of a frame's surface.
    filter.setSpatialScheme(openvdb::math::FIRST_BIAS);
    filter.setNormCount(1);
    for (int i = 0; i < settings.smoothing; ++i) {
      if (settings.filter == SurfaceFilter::Gaussian) filter.gaussian(1);
      if (settings.filter == SurfaceFilter::MeanCurvature) filter.meanCurvature();
    }
    if (settings.erode != 0) filter.offset(static_cast<float>(settings.erode * spacing));
  }

  // Grains the smoothing and erosion left outside the surface: farther out than their sphere's
  // radius, so that the sphere the surface was built from no longer reaches it. Nearer, the
  // surface stands for them (a coarse ball's lattice corners stick out of it by about a spacing).
  {
    const openvdb::tools::GridSampler<openvdb::FloatGrid::ConstAccessor, openvdb::tools::BoxSampler>
        phi(grid->getConstAccessor(), grid->transform());
    std::vector<std::uint32_t> outside;
    for (std::uint32_t p : kept) {
      const auto& x = s.position[p];
      if (phi.wsSample(openvdb::Vec3R(x[0], x[1], x[2])) > radius) outside.push_back(p);
    }
    surface.smoothed_away = static_cast<int>(outside.size());
    std::vector<std::uint32_t> loose(surface.loose.size() + outside.size());
    std::merge(surface.loose.begin(), surface.loose.end(), outside.begin(), outside.end(),
               loose.begin());
    surface.loose = std::move(loose);
  }

  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> triangles;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*grid, points, triangles, quads, 0.0, settings.adaptivity);
  surface.vertices.resize(points.size());
  for (size_t i = 0; i < points.size(); ++i)
    surface.vertices[i] = {points[i].x(), points[i].y(), points[i].z()};
  // OpenVDB winds its polygons clockwise seen from outside: reversed here.
  surface.triangles.reserve(triangles.size() + 2 * quads.size());
  for (const auto& t : triangles) surface.triangles.push_back({t[2], t[1], t[0]});
  for (const auto& q : quads) {
    surface.triangles.push_back({q[2], q[1], q[0]});
    surface.triangles.push_back({q[3], q[2], q[0]});
  }
  computeNormals(surface);

  surface.field.voxel_size = voxel;
  surface.field.background = grid->background();
  const auto active = grid->activeVoxelCount();
  surface.field.voxels.reserve(active);
  surface.field.values.reserve(active);
  for (auto v = grid->cbeginValueOn(); v; ++v) {
    const openvdb::Coord c = v.getCoord();
    surface.field.voxels.push_back({c.x(), c.y(), c.z()});
    surface.field.values.push_back(*v);
  }
}

}  // namespace

double voxelSize(const Snapshot& s, const SurfaceSettings& settings) {
  // OpenVDB leaves out spheres narrower than 1.5 voxels (its Nyquist limit).
  return std::min(settings.voxel * s.grid.cell_size, settings.radius * particleSpacing(s) / 1.5);
}

SnowSurface buildSnowSurface(const Snapshot& s, const SurfaceSettings& settings) {
  if (s.grid.dimension != 3)
    throw InputError("surface: frame " + std::to_string(s.frame) +
                     " is 2D; surfaces are built for 3D runs");
  validate(settings, "surface: ");
  static std::once_flag initialised;
  std::call_once(initialised, [] { openvdb::initialize(); });
  SnowSurface surface;
  tbb::task_arena arena(settings.threads > 0 ? settings.threads : tbb::task_arena::automatic);
  arena.execute([&] { buildInArena(s, settings, surface); });
  return surface;
}

std::vector<float> averageAtVertices(const SnowSurface& surface,
                                     const std::vector<std::array<float, 3>>& positions,
                                     const std::vector<float>& values, int components,
                                     double reach) {
  std::vector<float> out(surface.vertices.size() * components, 0.f);
  if (positions.empty() || surface.vertices.empty()) return out;
  // The particles sorted into cells of side `reach` over their bounds (a counting sort).
  std::array<float, 3> low = positions[0], high = positions[0];
  for (const auto& x : positions)
    for (int a = 0; a < 3; ++a) low[a] = std::min(low[a], x[a]), high[a] = std::max(high[a], x[a]);
  std::array<int, 3> n{};
  for (int a = 0; a < 3; ++a) n[a] = static_cast<int>((high[a] - low[a]) / reach) + 1;
  auto cellOf = [&](const std::array<float, 3>& x, int a) {
    return std::clamp(static_cast<int>(std::floor((x[a] - low[a]) / reach)), 0, n[a] - 1);
  };
  auto index = [&](int i, int j, int k) { return (static_cast<size_t>(k) * n[1] + j) * n[0] + i; };
  std::vector<std::uint32_t> start(static_cast<size_t>(n[0]) * n[1] * n[2] + 1, 0);
  for (const auto& x : positions) ++start[index(cellOf(x, 0), cellOf(x, 1), cellOf(x, 2)) + 1];
  for (size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
  std::vector<std::uint32_t> sorted(positions.size()), next(start.begin(), start.end() - 1);
  for (size_t p = 0; p < positions.size(); ++p) {
    const auto& x = positions[p];
    sorted[next[index(cellOf(x, 0), cellOf(x, 1), cellOf(x, 2))]++] = static_cast<std::uint32_t>(p);
  }

  const double reach2 = reach * reach;
  for (size_t v = 0; v < surface.vertices.size(); ++v) {
    const auto& x = surface.vertices[v];
    const int ci = cellOf(x, 0), cj = cellOf(x, 1), ck = cellOf(x, 2);
    double weight = 0, nearest2 = 1e300;
    std::uint32_t nearest = 0;
    float* o = &out[v * components];
    for (int k = std::max(ck - 1, 0); k <= std::min(ck + 1, n[2] - 1); ++k)
      for (int j = std::max(cj - 1, 0); j <= std::min(cj + 1, n[1] - 1); ++j)
        for (int i = std::max(ci - 1, 0); i <= std::min(ci + 1, n[0] - 1); ++i)
          for (std::uint32_t s = start[index(i, j, k)]; s < start[index(i, j, k) + 1]; ++s) {
            const std::uint32_t p = sorted[s];
            double d2 = 0;
            for (int a = 0; a < 3; ++a)
              d2 += double(positions[p][a] - x[a]) * (positions[p][a] - x[a]);
            if (d2 < nearest2) nearest2 = d2, nearest = p;
            if (d2 >= reach2) continue;
            const double w = (1 - d2 / reach2) * (1 - d2 / reach2);
            weight += w;
            for (int c = 0; c < components; ++c)
              o[c] += static_cast<float>(w * values[p * components + c]);
          }
    if (weight > 0)
      for (int c = 0; c < components; ++c) o[c] = static_cast<float>(o[c] / weight);
    else if (nearest2 < 1e300)
      for (int c = 0; c < components; ++c) o[c] = values[nearest * components + c];
  }
  return out;
}

}  // namespace snowsim
