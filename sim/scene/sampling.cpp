#include "sim/scene/sampling.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "sim/core/errors.h"
#include "sim/geometry/level_set.h"
#include "sim/scene/json_fields.h"

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

void refuseBodiesNarrowerThanTheirParticles(const Scene& scene) {
  for (size_t i = 0; i < scene.bodies.size(); ++i) {
    const Body& b = scene.bodies[i];
    if (b.shape == BodyShape::Points) continue;
    const double spacing = particleSpacing(scene, b);
    const auto [lo, hi] = b.shape == BodyShape::Mesh ? b.mesh.placedAt(b.center).bounds()
                                                     : std::array<std::array<double, 3>, 2>{};
    for (int a = 0; a < scene.authored_dimension; ++a) {
      const double across = b.shape == BodyShape::Mesh  ? hi[a] - lo[a]
                            : b.shape == BodyShape::Box ? b.size[a]
                                                        : 2 * b.radius;
      if (across >= spacing) continue;
      std::ostringstream s;
      s << "the body is " << across << " m across along "
        << "xyz"[a] << ", less than its particle spacing of " << spacing
        << " m (grid.cell_size over the particles per cell along an axis), so it would hold no "
           "particles or a single layer; make it larger, or the cells finer";
      throw FieldError(scene.file,
                       "bodies[" + std::to_string(i) + "]." +
                           (b.shape == BodyShape::Mesh  ? "scale"
                            : b.shape == BodyShape::Box ? "size"
                                                        : "radius"),
                       s.str());
    }
  }
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

// Calls visit(x) for the points of the body's lattice within [from, to] (m, per axis) that lie
// in the domain and for which `inside(p)` holds, jittered when the body asks for it.
template <int D, typename Inside, typename Visit>
void forEachLatticePoint(const Scene& scene, int b, Seeding seeding, const Vec3& from,
                         const Vec3& to, Inside inside, Visit visit) {
  const double spacing = particleSpacing(scene, scene.bodies[b]);
  int lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (int a = 0; a < D; ++a) {
    lo[a] = static_cast<int>(std::floor(std::max(0.0, from[a]) / spacing));
    hi[a] =
        static_cast<int>(std::ceil(std::min(scene.cells[a] * scene.cell_size, to[a]) / spacing));
  }
  std::array<int, 3> k{};
  for (k[2] = lo[2]; k[2] <= (D == 3 ? hi[2] : 0); ++k[2])
    for (k[1] = lo[1]; k[1] <= hi[1]; ++k[1])
      for (k[0] = lo[0]; k[0] <= hi[0]; ++k[0]) {
        Vec3 p{0, 0, 0};
        Vec<D> x;
        bool inside_domain = true;
        for (int a = 0; a < D; ++a) {
          const double jitter =
              seeding == Seeding::Jittered ? latticeJitter(scene.seed, b, k, a) : 0.0;
          p[a] = (k[a] + 0.5 + jitter) * spacing;
          x[a] = p[a];
          inside_domain &= k[a] >= 0 && p[a] < scene.cells[a] * scene.cell_size;
        }
        if (inside_domain && inside(p)) visit(x);
      }
}

// A stream of uniform numbers in [0, 1) from SplitMix64 steps: the same for the same start on
// every platform (std's distributions are not).
class UniformStream {
 public:
  explicit UniformStream(std::uint64_t start) : state_(start) {}
  double next() {
    state_ += 0x9e3779b97f4a7c15ull;
    return static_cast<double>(splitMix64(state_) >> 11) * 0x1.0p-53;
  }

 private:
  std::uint64_t state_;
};

// Poisson-disk points in the box [lo, hi) at least `radius` apart (Bridson 2007): each accepted
// point tries `kCandidates` random points in the shell [radius, 2 radius) around it, keeping those
// far enough from every point so far, until no point has room left around it. Sequential from one
// stream of numbers, so the points depend on the seed alone.
template <int D>
std::vector<Vec<D>> poissonDiskPoints(const Vec<D>& lo, const Vec<D>& hi, double radius,
                                      std::uint64_t seed) {
  constexpr int kCandidates = 30;
  // A background grid of side radius / sqrt(D) holds at most one point per cell.
  const double side = radius / std::sqrt(static_cast<double>(D));
  std::array<int, 3> cells{1, 1, 1};
  for (int a = 0; a < D; ++a)
    cells[a] = std::max(1, static_cast<int>(std::ceil((hi[a] - lo[a]) / side)));
  std::vector<int> owner(static_cast<size_t>(cells[0]) * cells[1] * cells[2], -1);
  auto cellOf = [&](const Vec<D>& x) {
    std::array<int, 3> c{0, 0, 0};
    for (int a = 0; a < D; ++a)
      c[a] = std::min(cells[a] - 1, static_cast<int>((x[a] - lo[a]) / side));
    return c;
  };
  auto indexOf = [&](const std::array<int, 3>& c) {
    return (static_cast<size_t>(c[2]) * cells[1] + c[1]) * cells[0] + c[0];
  };

  std::vector<Vec<D>> points;
  std::vector<int> active;
  UniformStream uniform(seed);
  auto accept = [&](const Vec<D>& x) {
    owner[indexOf(cellOf(x))] = static_cast<int>(points.size());
    active.push_back(static_cast<int>(points.size()));
    points.push_back(x);
  };
  auto hasRoom = [&](const Vec<D>& x) {
    for (int a = 0; a < D; ++a)
      if (!(x[a] >= lo[a] && x[a] < hi[a])) return false;
    const std::array<int, 3> c = cellOf(x);
    // Points closer than radius lie at most ceil(sqrt(D)) = 2 background cells away.
    std::array<int, 3> from{0, 0, 0}, to{0, 0, 0};
    for (int a = 0; a < D; ++a)
      from[a] = std::max(0, c[a] - 2), to[a] = std::min(cells[a] - 1, c[a] + 2);
    std::array<int, 3> n{};
    for (n[2] = from[2]; n[2] <= to[2]; ++n[2])
      for (n[1] = from[1]; n[1] <= to[1]; ++n[1])
        for (n[0] = from[0]; n[0] <= to[0]; ++n[0]) {
          const int other = owner[indexOf(n)];
          if (other >= 0 && (points[other] - x).squaredNorm() < radius * radius) return false;
        }
    return true;
  };

  Vec<D> first;
  for (int a = 0; a < D; ++a) first[a] = lo[a] + uniform.next() * (hi[a] - lo[a]);
  accept(first);
  while (!active.empty()) {
    const size_t slot =
        std::min(active.size() - 1, static_cast<size_t>(uniform.next() * active.size()));
    const Vec<D> centre = points[active[slot]];
    bool placed = false;
    for (int attempt = 0; attempt < kCandidates && !placed; ++attempt) {
      // A direction uniform on the sphere (circle), by rejection from the cube, at a distance
      // whose density grows as r^(D-1), so the shell is covered evenly.
      Vec<D> direction;
      double length2 = 0;
      do {
        for (int a = 0; a < D; ++a) direction[a] = 2 * uniform.next() - 1;
        length2 = direction.squaredNorm();
      } while (length2 > 1 || length2 < 1e-12);
      const double u = uniform.next();
      const double distance =
          radius * std::pow(1 + u * (std::pow(2.0, D) - 1), 1.0 / D);  // in [r, 2r)
      const Vec<D> candidate = centre + direction * (distance / std::sqrt(length2));
      if (hasRoom(candidate)) {
        accept(candidate);
        placed = true;
      }
    }
    if (!placed) {
      active[slot] = active.back();
      active.pop_back();
    }
  }
  return points;
}

// The Poisson-disk radius, in lattice spacings, at which Bridson's sampling puts as many points in
// a volume as the lattice does (measured on large boxes: tests/sim/scene/scene_test.cpp).
template <int D>
constexpr double kPoissonRadius = D == 2 ? 0.785 : 0.833;

// Adds the body's particles within [from, to] (m, per axis) for which `inside(p)` holds, placed by
// its seeding. Every particle carries an equal share of the mass the body's lattice holds there,
// so a Poisson-disk body, whose count differs from the lattice's by a few percent, weighs the same.
template <int D, typename Inside, typename Sink>
void fillBody(const Scene& scene, int b, const Vec3& from, const Vec3& to, Inside inside,
              Sink& particles) {
  const Body& body = scene.bodies[b];
  const double spacing = particleSpacing(scene, body);
  Vec<D> velocity;
  for (int a = 0; a < D; ++a) velocity[a] = a < scene.authored_dimension ? body.velocity[a] : 0.0;
  if (body.seeding != Seeding::Poisson) {
    const double mass = particleMass<D>(body, spacing);
    forEachLatticePoint<D>(scene, b, body.seeding, from, to, inside,
                           [&](const Vec<D>& x) { particles.add(x, velocity, mass, b); });
    return;
  }
  long long lattice_count = 0;
  forEachLatticePoint<D>(scene, b, Seeding::Lattice, from, to, inside,
                         [&](const Vec<D>&) { ++lattice_count; });
  if (lattice_count == 0) return;  // no mass to share: the body holds no particle
  if constexpr (Sink::counts_only) {
    particles.addCount(lattice_count, b);  // Bridson's count is within a few percent of it
    return;
  }
  Vec<D> lo, hi;
  for (int a = 0; a < D; ++a) {
    lo[a] = std::max(0.0, from[a]);
    hi[a] = std::min(scene.cells[a] * scene.cell_size, to[a]);
  }
  const std::uint64_t seed =
      splitMix64(static_cast<std::uint64_t>(scene.seed)) ^ static_cast<std::uint64_t>(b) << 58;
  std::vector<Vec<D>> kept;
  for (const Vec<D>& x : poissonDiskPoints<D>(lo, hi, kPoissonRadius<D> * spacing, seed)) {
    Vec3 p{0, 0, 0};
    for (int a = 0; a < D; ++a) p[a] = x[a];
    if (inside(p)) kept.push_back(x);
  }
  const double mass = particleMass<D>(body, spacing) * static_cast<double>(lattice_count) /
                      static_cast<double>(std::max<size_t>(1, kept.size()));
  for (const Vec<D>& x : kept) particles.add(x, velocity, mass, b);
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

// A sink of fillBodies that keeps no particle: their number, by body.
struct ParticleCounter {
  static constexpr bool counts_only = true;
  std::vector<long> per_body;
  template <class V>
  void add(const V&, const V&, double, int b) {
    ++per_body[b];
  }
  void addCount(long n, int b) { per_body[b] += n; }
};

// Particles<D> as a sink of fillBodies.
template <int D>
struct ParticleKeeper {
  static constexpr bool counts_only = false;
  Particles<D> particles;
  std::vector<long> per_body;
  void add(const Vec<D>& x, const Vec<D>& v, double mass, int b) {
    particles.add(x, v, mass, b);
    ++per_body[b];
  }
};

// Fills every body into the sink (add(x, v, mass, body) per particle). A counting sink is told
// a points body's count and a Poisson-disk body's lattice count at once.
template <int D, class Sink>
void fillBodies(const Scene& scene, Sink& sink) {
  sink.per_body.assign(scene.bodies.size(), 0);
  const int shape_dim = scene.authored_dimension;
  for (size_t b = 0; b < scene.bodies.size(); ++b) {
    const Body& body = scene.bodies[b];
    const int index = static_cast<int>(b);
    const double spacing = particleSpacing(scene, body);
    if (body.shape == BodyShape::Points) {
      if constexpr (!Sink::counts_only)
        addPoints(*body.points, particleMass<D>(body, spacing), index, sink.particles);
      sink.per_body[b] += static_cast<long>(body.points->size());
      continue;
    }
    if (body.shape == BodyShape::Mesh) {
      const TriangleMesh mesh = body.mesh.placedAt(body.center);
      // Voxels no coarser than the particles, so the filled shape keeps the mesh's detail.
      const LevelSet level_set(mesh, std::min(spacing, scene.cell_size / 2), 2 * spacing);
      const auto [from, to] = mesh.bounds();
      fillBody<D>(
          scene, index, from, to, [&](const Vec3& p) { return level_set.phi(p) < 0; }, sink);
      if constexpr (!Sink::counts_only)
        spin<D>(body.angular_velocity, sink.particles.size() - sink.per_body[b], sink.particles);
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
    fillBody<D>(
        scene, index, from, to, [&](const Vec3& p) { return bodyContains(body, p, shape_dim); },
        sink);
  }
}

}  // namespace

template <int D>
Particles<D> sampleBodies(const Scene& scene) {
  ParticleKeeper<D> keeper;
  fillBodies<D>(scene, keeper);
  // A body wider than its spacing may still hold none (a thin plate turned across the axes).
  for (size_t b = 0; b < keeper.per_body.size(); ++b)
    if (keeper.per_body[b] == 0) {
      std::ostringstream s;
      s << scene.file << ": bodies[" << b
        << "] holds no particles: no point of its particle lattice falls inside it (is it thinner "
           "than its particle spacing of "
        << particleSpacing(scene, scene.bodies[b])
        << " m?); make it larger or thicker, or the cells finer";
      throw InputError(s.str());
    }
  return std::move(keeper.particles);
}

long countBodyParticles(const Scene& scene) {
  ParticleCounter counter;
  if (scene.dimension == 2)
    fillBodies<2>(scene, counter);
  else
    fillBodies<3>(scene, counter);
  long total = 0;
  for (long n : counter.per_body) total += n;
  return total;
}

template Particles<2> sampleBodies<2>(const Scene&);
template Particles<3> sampleBodies<3>(const Scene&);

}  // namespace snowsim
