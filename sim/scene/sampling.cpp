#include "sim/scene/sampling.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "sim/geometry/level_set.h"

namespace snowsim {

bool bodyContains(const Body& body, const Vec3& p, int shape_dimension) {
  double r2 = 0, along_cut = 0;
  for (int a = 0; a < shape_dimension; ++a) {
    const double d = p[a] - body.center[a];
    if (body.shape == BodyShape::Box && std::abs(d) > body.size[a] / 2) return false;
    r2 += d * d;
    along_cut += d * body.cut_normal[a];
  }
  switch (body.shape) {
    case BodyShape::Box:
      return true;
    case BodyShape::Ball:
      return r2 <= body.radius * body.radius;
    case BodyShape::HalfBall:
      return r2 <= body.radius * body.radius && along_cut >= 0;
    case BodyShape::Points:  // a set of points holds no volume
    case BodyShape::Mesh:    // filled from its level set by sampleBodies
      return false;
  }
  return false;
}

double particleSpacing(const Scene& scene, const Body& body) {
  const double per_axis =
      std::round(std::pow(body.particles_per_cell, 1.0 / scene.authored_dimension));
  return scene.cell_size / per_axis;
}

namespace {

// Every particle stands for an equal share of its cell's volume (for 2D, per metre of depth).
template <int D>
double particleMass(const Body& body, double spacing) {
  return body.density * std::pow(spacing, D);
}

// SplitMix64 (Steele, Lea and Flood 2014): a well-mixed 64-bit hash of a counter.
std::uint64_t splitMix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// A points body's particles as the file gives them; `mass` for each unless the file has masses.
template <int D>
void addPoints(const Snapshot& points, double mass, int body, Particles<D>& particles) {
  for (int i = 0; i < points.size(); ++i) {
    Vec<D> x, v;
    for (int a = 0; a < D; ++a) x[a] = points.position[i][a], v[a] = points.velocity[i][a];
    particles.add(x, v, points.mass.empty() ? mass : points.mass[i], body);
  }
}

}  // namespace

double latticeJitter(int seed, int body, const std::array<int, 3>& k, int axis) {
  // Lattice indices stay below 2^16 (4096 cells of at most 10 points a side).
  const std::uint64_t key = (((static_cast<std::uint64_t>(k[2]) << 16 | k[1]) << 16 | k[0]) << 2 |
                             static_cast<std::uint64_t>(axis)) ^
                            static_cast<std::uint64_t>(body) << 58;
  const std::uint64_t hash = splitMix64(splitMix64(static_cast<std::uint64_t>(seed)) ^ key);
  return static_cast<double>(hash >> 11) * 0x1.0p-53 - 0.5;
}

namespace {

// Adds the points of the body's lattice within [from, to] (m, per axis) for which `inside(p)`
// holds.
template <int D, typename Inside>
void fillLattice(const Scene& scene, int b, const Vec3& from, const Vec3& to, Inside inside,
                 Particles<D>& particles) {
  const Body& body = scene.bodies[b];
  const double spacing = particleSpacing(scene, body);
  const double mass = particleMass<D>(body, spacing);
  int lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (int a = 0; a < D; ++a) {
    lo[a] = static_cast<int>(std::floor(std::max(0.0, from[a]) / spacing));
    hi[a] =
        static_cast<int>(std::ceil(std::min(scene.cells[a] * scene.cell_size, to[a]) / spacing));
  }
  Vec<D> velocity;
  for (int a = 0; a < D; ++a) velocity[a] = a < scene.authored_dimension ? body.velocity[a] : 0.0;

  std::array<int, 3> k{};
  for (k[2] = lo[2]; k[2] <= (D == 3 ? hi[2] : 0); ++k[2])
    for (k[1] = lo[1]; k[1] <= hi[1]; ++k[1])
      for (k[0] = lo[0]; k[0] <= hi[0]; ++k[0]) {
        Vec3 p{0, 0, 0};
        Vec<D> x;
        bool inside_domain = true;
        for (int a = 0; a < D; ++a) {
          const double jitter =
              body.seeding == Seeding::Jittered ? latticeJitter(scene.seed, b, k, a) : 0.0;
          p[a] = (k[a] + 0.5 + jitter) * spacing;
          x[a] = p[a];
          inside_domain &= k[a] >= 0 && p[a] < scene.cells[a] * scene.cell_size;
        }
        if (inside_domain && inside(p)) particles.add(x, velocity, mass, b);
      }
}

// Adds w x (x - c) to the velocities of particles [first, end), c their centre of mass, so the
// spin adds no momentum.
template <int D>
void spin(const Vec3& w, int first, Particles<D>& particles) {
  if constexpr (D == 3) {
    const int end = particles.size();
    if (first == end) return;
    Vec<3> centre = Vec<3>::Zero();
    for (int p = first; p < end; ++p) centre += particles.x[p];
    centre /= static_cast<double>(end - first);
    const Vec<3> omega(w[0], w[1], w[2]);
    for (int p = first; p < end; ++p) particles.v[p] += omega.cross(particles.x[p] - centre);
  }
}

}  // namespace

template <int D>
Particles<D> sampleBodies(const Scene& scene) {
  Particles<D> particles;
  const int shape_dim = scene.authored_dimension;
  for (size_t b = 0; b < scene.bodies.size(); ++b) {
    const Body& body = scene.bodies[b];
    const int index = static_cast<int>(b);
    const double spacing = particleSpacing(scene, body);
    if (body.shape == BodyShape::Points) {
      addPoints(*body.points, particleMass<D>(body, spacing), index, particles);
      continue;
    }
    if (body.shape == BodyShape::Mesh) {
      const TriangleMesh mesh = body.mesh.placedAt(body.center);
      // Voxels no coarser than the particles, so the filled shape keeps the mesh's detail.
      const LevelSet level_set(mesh, std::min(spacing, scene.cell_size / 2), 2 * spacing);
      const auto [from, to] = mesh.bounds();
      const int first = particles.size();
      fillLattice<D>(
          scene, index, from, to, [&](const Vec3& p) { return level_set.phi(p) < 0; }, particles);
      spin<D>(body.angular_velocity, first, particles);
      continue;
    }
    // Lattice range covering the body's bounding box (the whole slab depth when extruded).
    Vec3 from{0, 0, 0}, to{0, 0, 0};
    for (int a = 0; a < D; ++a) {
      from[a] = 0, to[a] = scene.cells[a] * scene.cell_size;
      if (a < shape_dim) {
        const double half = body.shape == BodyShape::Box ? body.size[a] / 2 : body.radius;
        from[a] = body.center[a] - half;
        to[a] = body.center[a] + half;
      }
    }
    fillLattice<D>(
        scene, index, from, to, [&](const Vec3& p) { return bodyContains(body, p, shape_dim); },
        particles);
  }
  return particles;
}

template Particles<2> sampleBodies<2>(const Scene&);
template Particles<3> sampleBodies<3>(const Scene&);

}  // namespace snowsim
