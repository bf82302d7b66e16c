#include "sim/simulation_memory.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <type_traits>

#include "sim/core/grid.h"
#include "sim/core/math.h"
#include "sim/mpm/stress_differential.h"
#include "sim/parallel/row_binning.h"

namespace snowsim {

namespace {

// The capacity push_back leaves a vector grown from empty to n elements: the next power of two.
double grownCapacity(long n) {
  return n > 0 ? double(std::bit_ceil(static_cast<unsigned long>(n))) : 0;
}

// Bytes of the common particle arrays (Particles<D, T>: x, v, mass, volume, body, id).
template <int D, class T>
constexpr double commonParticleBytes = 2 * sizeof(Vec<D, T>) + 2 * sizeof(T) + 2 * sizeof(int);

// The MPM solver in precision T (MpmSolver<D, T>, its schedule and its parts).
template <int D, class T>
void mpmMemory(const Scene& scene, long n, long nodes, SimulationMemory& m) {
  using V = Vec<D, T>;
  const MpmParams& mpm = scene.mpm;
  const bool sleep = mpm.auto_sleep.enabled;
  constexpr int colours = RowBinning<D>::colours;
  // The sampled particles in double: a double state keeps their arrays (grown by push_back), a
  // float one converts them and frees them.
  const bool kept = std::is_same_v<T, double>;
  double particles = (kept ? grownCapacity(n) : double(n)) * commonParticleBytes<D, T>;
  // F_E, C, tau, J_P, hardening; auto-sleep's calm steps; the binning's block and order and the
  // sort's spare.
  double per_particle = 2 * sizeof(Mat<D, T>) + sizeof(Symmetric<D, T>) + 2 * sizeof(T) +
                        (sleep ? sizeof(int) : 0) + 2 * sizeof(int) + sizeof(T);
  // The grid's fields (mass, velocity, its rasterised copy, force), then one partial grid per
  // colour (mass, momentum, force for transfers other than MLS), twice with auto-sleep (its
  // still blocks' scratch).
  double per_node = sizeof(T) + 3 * sizeof(V);
  const double partial = sizeof(T) + sizeof(V) * (mpm.transfer == MpmTransfer::Mls ? 1 : 2);
  per_node += colours * partial * (sleep ? 2 : 1);
  if (mpm.open_cracks) {
    per_particle += sizeof(V) + sizeof(char);  // the damage gradient, near damage
    // Per colour: damage mass, damage, reference norm, two masses; reference, two normals, two
    // momenta. Per node: damage; reference and two velocities.
    per_node += colours * (5 * sizeof(T) + 5 * sizeof(V)) + sizeof(T) + 3 * sizeof(V);
  }
  if (mpm.integrator == MpmIntegrator::SemiImplicit) {  // in double (ImplicitVelocitySolve)
    const int stencil = std::pow(scene.mpm.kernel == KernelType::Cubic ? 4 : 3, D);
    per_particle += stencil * (sizeof(int) + sizeof(Vec<D>)) + sizeof(Mat<D>) + sizeof(Tangent<D>);
    // The nodes' free components; per active node (at most every node) its index both ways,
    // mass, stiffness block, preconditioner block and projection.
    per_node += sizeof(Mat<D>) + 2 * sizeof(int) + sizeof(Real) + 3 * sizeof(Mat<D>);
  }
  m.parts.push_back({"particles", particles + n * per_particle});
  m.parts.push_back({"grid", nodes * per_node});
  // While the float solver is built, the sampled double particles it converts.
  m.parts.push_back({"setup", kept ? 0 : grownCapacity(n) * commonParticleBytes<D, double>});
}

// The report's density-hybrid solver (DensityHybridSolver<D>, double).
template <int D>
void densityHybridMemory(long n, long nodes, SimulationMemory& m) {
  m.parts.push_back({"particles", grownCapacity(n) * commonParticleBytes<D, Real>});
  // Its grid fields, the node densities and step 4's scratch velocities.
  m.parts.push_back(
      {"grid", nodes * double(sizeof(Real) + 3 * sizeof(Vec<D>) + sizeof(Real) + sizeof(Vec<D>))});
  m.parts.push_back({"setup", 0});
}

}  // namespace

long gridNodeCount(const Scene& scene) {
  long nodes = 1;
  for (int a = 0; a < scene.dimension; ++a)
    nodes *= scene.cells[a] + 1 + 2 * GridGeometry<3>::ghost;
  return nodes;
}

double SimulationMemory::bytes() const {
  double sum = 0;
  for (const MemoryPart& p : parts) sum += p.bytes;
  return sum;
}

SimulationMemory simulationMemory(const Scene& scene, long particles) {
  SimulationMemory m;
  m.particles = particles;
  m.nodes = gridNodeCount(scene);
  const bool mpm = scene.solver == SolverType::Mpm;
  const bool single = mpm && scene.mpm.precision == MpmPrecision::Float;
  if (scene.dimension == 2) {
    if (!mpm)
      densityHybridMemory<2>(particles, m.nodes, m);
    else if (single)
      mpmMemory<2, float>(scene, particles, m.nodes, m);
    else
      mpmMemory<2, double>(scene, particles, m.nodes, m);
  } else {
    if (!mpm)
      densityHybridMemory<3>(particles, m.nodes, m);
    else if (single)
      mpmMemory<3, float>(scene, particles, m.nodes, m);
    else
      mpmMemory<3, double>(scene, particles, m.nodes, m);
  }
  // A frame's snapshot: position, velocity, density, mass, radius and (MPM) J_P in float per
  // particle; in 2D the node densities of the domain.
  double snapshot = particles * 4.0 * (3 + 3 + 3 + (mpm ? 1 : 0));
  if (scene.dimension == 2) snapshot += 4.0 * (scene.cells[0] + 1) * (scene.cells[1] + 1);
  // What exists only while the solver is built, or only once it steps: whichever is larger.
  MemoryPart& setup = m.parts.back();
  if (snapshot >= setup.bytes) setup = {"snapshot", snapshot};
  return m;
}

}  // namespace snowsim
