#include "sim/scene/sampling.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

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

template <int D>
Particles<D> sampleBodies(const Scene& scene) {
  Particles<D> particles;
  const double h = scene.cell_size;
  const int shape_dim = scene.authored_dimension;
  for (size_t b = 0; b < scene.bodies.size(); ++b) {
    const Body& body = scene.bodies[b];
    const double spacing = particleSpacing(scene, body);
    // Every particle stands for an equal share of its cell's volume (for 2D, per metre of depth).
    const double mass = body.density * std::pow(spacing, D);
    if (body.shape == BodyShape::Points) {
      addPoints(*body.points, mass, static_cast<int>(b), particles);
      continue;
    }

    // Lattice range covering the body's bounding box (the whole slab depth when extruded).
    int lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    for (int a = 0; a < D; ++a) {
      double from = 0, to = scene.cells[a] * h;
      if (a < shape_dim) {
        const double half = body.shape == BodyShape::Box ? body.size[a] / 2 : body.radius;
        from = std::max(from, body.center[a] - half);
        to = std::min(to, body.center[a] + half);
      }
      lo[a] = static_cast<int>(std::floor(from / spacing));
      hi[a] = static_cast<int>(std::ceil(to / spacing));
    }
    Vec<D> velocity;
    for (int a = 0; a < D; ++a) velocity[a] = a < shape_dim ? body.velocity[a] : 0.0;

    std::array<int, 3> k{};
    for (k[2] = lo[2]; k[2] <= (D == 3 ? hi[2] : 0); ++k[2])
      for (k[1] = lo[1]; k[1] <= hi[1]; ++k[1])
        for (k[0] = lo[0]; k[0] <= hi[0]; ++k[0]) {
          Vec3 p{0, 0, 0};
          Vec<D> x;
          bool inside_domain = true;
          for (int a = 0; a < D; ++a) {
            const double jitter = body.seeding == Seeding::Jittered
                                      ? latticeJitter(scene.seed, static_cast<int>(b), k, a)
                                      : 0.0;
            p[a] = (k[a] + 0.5 + jitter) * spacing;
            x[a] = p[a];
            inside_domain &= k[a] >= 0 && p[a] < scene.cells[a] * h;
          }
          if (inside_domain && bodyContains(body, p, shape_dim))
            particles.add(x, velocity, mass, static_cast<int>(b));
        }
  }
  return particles;
}

template Particles<2> sampleBodies<2>(const Scene&);
template Particles<3> sampleBodies<3>(const Scene&);

}  // namespace snowsim
