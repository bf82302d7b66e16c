#include "sim/simulation_memory.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "sim/core/errors.h"
#include "sim/core/grid.h"
#include "sim/core/math.h"
#include "sim/mpm/stress_differential.h"
#include "sim/parallel/row_binning.h"

namespace snowsim {

namespace {

constexpr int kGhost = GridGeometry<3>::ghost;
constexpr long kPage = 4096;

// Bytes of the common particle arrays (Particles<D, T>: x, v, mass, volume, body, id).
template <int D, class T>
constexpr double commonParticleBytes = 2 * sizeof(Vec<D, T>) + 2 * sizeof(T) + 2 * sizeof(int);

// The stored nodes (per axis, [lo, hi)) within reach of the bodies as placed: their boxes, grown
// by the widest stencil's reach, in the grid's storage coordinates.
struct NodeRange {
  std::array<long, 3> lo{0, 0, 0}, hi{1, 1, 1};
};
NodeRange snowNodes(const Scene& scene) {
  std::array<double, 3> lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  const Vec3 extent = scene.extent();
  for (const Body& b : scene.bodies) {
    std::array<double, 3> from{}, to{};
    if (b.shape == BodyShape::Mesh) {
      const auto bounds = b.mesh.placedAt(b.center).bounds();
      from = bounds[0], to = bounds[1];
    } else if (b.shape == BodyShape::Points) {
      from = {INFINITY, INFINITY, INFINITY}, to = {-INFINITY, -INFINITY, -INFINITY};
      for (const auto& p : b.points->position)
        for (int a = 0; a < 3; ++a)
          from[a] = std::min(from[a], double(p[a])), to[a] = std::max(to[a], double(p[a]));
    } else {
      for (int a = 0; a < 3; ++a) {
        const double half = b.shape == BodyShape::Box ? b.size[a] / 2 : b.radius;
        from[a] = b.center[a] - half, to[a] = b.center[a] + half;
      }
    }
    for (int a = 0; a < 3; ++a) {
      // A 2D-authored body run in 3D fills the slab's depth.
      if (a >= scene.authored_dimension) from[a] = 0, to[a] = extent[a];
      lo[a] = std::min(lo[a], from[a]), hi[a] = std::max(hi[a], to[a]);
    }
  }
  NodeRange r;
  for (int a = 0; a < scene.dimension; ++a) {
    if (!(lo[a] <= hi[a])) lo[a] = hi[a] = 0;  // no body: no snow
    const long nodes = scene.cells[a] + 1 + 2 * kGhost;
    const auto node = [&](double x) { return long(std::floor(x / scene.cell_size)) + kGhost; };
    r.lo[a] = std::clamp(node(lo[a]) - kGhost, 0L, nodes - 1);
    r.hi[a] = std::clamp(node(hi[a]) + kGhost + 2, r.lo[a] + 1, nodes);
  }
  return r;
}

// The bytes of the pages an array of `element` bytes per node, in the grid's flat order (x
// fastest), has touched once every node of `range` is written.
double touchedPages(const Scene& scene, const NodeRange& range, double element) {
  std::array<long, 3> stride{1, 1, 1};
  for (int a = 1; a < scene.dimension; ++a)
    stride[a] = stride[a - 1] * (scene.cells[a - 1] + 1 + 2 * kGhost);
  long pages = 0, last = -1;  // rows come in increasing flat order: pages counted once each
  for (long k = range.lo[2]; k < range.hi[2]; ++k)
    for (long j = range.lo[1]; j < range.hi[1]; ++j) {
      const long row = j * stride[1] + k * stride[2];
      const long first = long((row + range.lo[0]) * element) / kPage;
      const long end = long((row + range.hi[0]) * element - 1) / kPage;
      pages += end - std::max(first, last + 1) + 1;
      last = end;
    }
  return double(pages) * kPage;
}

// The grid's arrays: `dense` bytes per node written whole when the solver is built, and arrays of
// these element sizes that take memory only where the snow is (zero pages, or the semi-implicit
// solve's active nodes).
struct GridArrays {
  double dense = 0;
  std::vector<double> zero_pages;
  void addZeroPages(int count, double element) {
    zero_pages.insert(zero_pages.end(), count, element);
  }
};

// The MPM solver in precision T (MpmSolver<D, T>, its schedule and its parts).
template <int D, class T>
double mpmParticleBytes(const Scene& scene, long n, GridArrays& grid, double& setup) {
  using V = Vec<D, T>;
  const MpmParams& mpm = scene.mpm;
  const bool sleep = mpm.auto_sleep.enabled;
  constexpr int colours = RowBinning<D>::colours;
  // The sampled particles in double: a double state keeps their arrays, a float one converts
  // them and frees them once it is built.
  setup = std::is_same_v<T, double> ? 0 : n * commonParticleBytes<D, double>;
  const double bytes = n * commonParticleBytes<D, T>;
  // F_E, C, tau, J_P, hardening; auto-sleep's calm steps; the binning's block and order and the
  // sort's spare.
  double per_particle = 2 * sizeof(Mat<D, T>) + sizeof(Symmetric<D, T>) + 2 * sizeof(T) +
                        (sleep ? sizeof(int) : 0) + 2 * sizeof(int) + sizeof(T);
  // The grid's fields (mass, velocity, its rasterised copy, force), then per colour a partial
  // grid (mass, momentum, force for transfers other than MLS), twice with auto-sleep (its still
  // blocks' scratch).
  grid.dense = sizeof(T) + 3 * sizeof(V);
  for (int copy = 0; copy < (sleep ? 2 : 1); ++copy) {
    grid.addZeroPages(colours, sizeof(T));
    grid.addZeroPages(colours * (mpm.transfer == MpmTransfer::Mls ? 1 : 2), sizeof(V));
  }
  if (mpm.open_cracks) {
    // The step's stamp and what it takes; a side bit per stencil node; with auto-sleep, what it
    // read of the damage field, kept while it sleeps (a gradient, side bits, flags).
    per_particle += sizeof(std::uint32_t) + sizeof(std::uint64_t);
    if (sleep) per_particle += sizeof(V) + sizeof(std::uint64_t) + sizeof(char);
    // Per colour: damage, reference norm, two masses; reference, two normals, two momenta;
    // touched; twice with auto-sleep (its still blocks' scratch). Per node: damage, grains;
    // reference and two velocities.
    const int partials = sleep ? 2 * colours : colours;
    grid.addZeroPages(4 * partials + 2, sizeof(T));
    grid.addZeroPages(5 * partials + 3, sizeof(V));
    grid.addZeroPages(partials, sizeof(char));
  }
  if (mpm.integrator == MpmIntegrator::SemiImplicit) {  // in double (ImplicitVelocitySolve)
    const int stencil = std::pow(mpm.kernel == KernelType::Cubic ? 4 : 3, D);
    per_particle += stencil * (sizeof(int) + sizeof(Vec<D>)) + sizeof(Mat<D>) + sizeof(Tangent<D>);
    // Per node its free components and its active index; per active node, near the snow, its
    // node, mass, stiffness block, preconditioner block and projection.
    grid.dense += sizeof(Mat<D>) + sizeof(int);
    grid.addZeroPages(1, sizeof(int) + sizeof(Real) + 3 * sizeof(Mat<D>));
  }
  return bytes + n * per_particle;
}

// The report's density-hybrid solver (DensityHybridSolver<D>, double): its grid fields, the node
// densities and step 4's scratch velocities.
template <int D>
double densityHybridParticleBytes(long n, GridArrays& grid) {
  grid.dense = sizeof(Real) + 3 * sizeof(Vec<D>) + sizeof(Real) + sizeof(Vec<D>);
  return n * commonParticleBytes<D, Real>;
}

}  // namespace

long gridNodeCount(const Scene& scene) {
  long nodes = 1;
  for (int a = 0; a < scene.dimension; ++a) nodes *= scene.cells[a] + 1 + 2 * kGhost;
  return nodes;
}

void refuseGridTooLarge(const std::string& scene_name, long nodes) {
  if (nodes > std::numeric_limits<int>::max())
    throw InputError(scene_name + ": grid.cells make " + std::to_string(nodes) +
                     " grid nodes (the ghost layers included), more than the " +
                     std::to_string(std::numeric_limits<int>::max()) + " a grid holds");
}

SimulationMemory simulationMemory(const Scene& scene, long particles) {
  SimulationMemory m;
  m.particles = particles;
  m.nodes = gridNodeCount(scene);
  const bool mpm = scene.solver == SolverType::Mpm;
  const bool single = mpm && scene.mpm.precision == MpmPrecision::Float;
  GridArrays grid;
  double setup = 0, state = 0;
  if (!mpm)
    state = scene.dimension == 2 ? densityHybridParticleBytes<2>(particles, grid)
                                 : densityHybridParticleBytes<3>(particles, grid);
  else if (scene.dimension == 2)
    state = single ? mpmParticleBytes<2, float>(scene, particles, grid, setup)
                   : mpmParticleBytes<2, double>(scene, particles, grid, setup);
  else
    state = single ? mpmParticleBytes<3, float>(scene, particles, grid, setup)
                   : mpmParticleBytes<3, double>(scene, particles, grid, setup);
  m.state = state;
  m.dense = m.nodes * grid.dense;
  m.setup = setup;
  const NodeRange snow = snowNodes(scene);
  double whole = 0;
  for (double element : grid.zero_pages) {
    m.touched += touchedPages(scene, snow, element);
    whole += m.nodes * element;
  }
  m.spread = std::max(0.0, whole - m.touched);
  // Position, velocity, density, mass, radius and (MPM) J_P in float per particle; in 2D the node
  // densities of the domain.
  m.snapshot = particles * 4.0 * (3 + 3 + 3 + (mpm ? 1 : 0));
  if (scene.dimension == 2) m.snapshot += 4.0 * (scene.cells[0] + 1) * (scene.cells[1] + 1);
  return m;
}

}  // namespace snowsim
