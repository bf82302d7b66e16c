// What one 3D MPM simulation split across N processes by slabs would send between them, measured
// on a real run (docs/scale-out.md): the run steps in one process, and after each step the
// particles are cut, as a distributed step would cut them, into N slabs of cell layers along the
// snow's longest axis, balanced by particle counts and re-cut every `rebalance` steps. For each
// slab it counts the grid nodes whose partial sums go to a neighbour after the scatter (the
// nodes it touched in the three node layers both sides reach), the particles that leave it after
// the advection, and what that costs in bytes; and how far the heaviest slab is above the mean.
// Usage: decomposition_traffic [scene=scenes/flagship/smash_wall.json] [scale=0.5]
//                              [ranks=2,4,8,16] [rebalance=20]
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "sim/mpm/mpm_solver.h"
#include "sim/scene/sampling.h"

using namespace snowsim;

namespace {

constexpr int D = 3;
// Between neighbouring slabs cut at cell layer c, particles of either side reach node layers
// c - 1 to c + 1 (quadratic and cubic weights alike), so a slab at least three cells wide shares
// nodes with its two neighbours only.
constexpr int kSharedLayers = 3;
constexpr int kMinSlabCells = 3;

// The slabs' first cell layers along the axis, and one past the last: N + 1 cuts whose slabs
// hold about equal particle counts, each at least kMinSlabCells wide.
std::vector<int> balancedCuts(const std::vector<long>& per_layer, int slabs) {
  const int layers = static_cast<int>(per_layer.size());
  long total = 0;
  for (long n : per_layer) total += n;
  std::vector<int> cuts = {0};
  long seen = 0;
  int layer = 0;
  for (int s = 1; s < slabs; ++s) {
    const long target = total * s / slabs;
    const int lowest = cuts.back() + kMinSlabCells;
    const int highest = layers - (slabs - s) * kMinSlabCells;
    while (layer < highest && (layer < lowest || seen + per_layer[layer] <= target))
      seen += per_layer[layer++];
    cuts.push_back(layer);
  }
  cuts.push_back(layers);
  return cuts;
}

int slabOf(const std::vector<int>& cuts, int layer) {
  return static_cast<int>(std::upper_bound(cuts.begin() + 1, cuts.end() - 1, layer) -
                          cuts.begin()) -
         1;
}

// The axis along which the particles spread furthest.
int longestAxis(const std::vector<Vec<D>>& x) {
  Vec<D> lo = Vec<D>::Constant(1e300), hi = Vec<D>::Constant(-1e300);
  for (const Vec<D>& p : x) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  int axis = 0;
  for (int a = 1; a < D; ++a)
    if (hi[a] - lo[a] > hi[axis] - lo[axis]) axis = a;
  return axis;
}

// Per slab, over the steps: the largest and the summed value of one quantity.
struct Tally {
  double sum = 0, largest = 0;
  void add(double v) {
    sum += v;
    largest = std::max(largest, v);
  }
};

// One decomposition into `slabs` slabs followed through the run.
struct Decomposition {
  explicit Decomposition(int slabs_) : slabs(slabs_) {}
  int slabs;
  int axis = 0;
  std::vector<int> cuts;
  std::vector<int> owner;  // per particle id: its slab
  int too_few_layers = 0;  // the layers of an axis it was cut along, when fewer than 3 a slab
  Tally halo_nodes, migrants, rebalance_moves, imbalance;  // per step, the busiest slab's
};

// The cell layer of position x along the axis.
int layerOf(const GridGeometry<D>& grid, const Vec<D>& x, int axis) {
  return std::clamp(static_cast<int>(std::floor(x[axis] / grid.h)), 0, grid.cells[axis] - 1);
}

void recut(Decomposition& d, const GridGeometry<D>& grid, const Particles<D>& p) {
  d.axis = longestAxis(p.x);
  if (d.slabs * kMinSlabCells > grid.cells[d.axis]) d.too_few_layers = grid.cells[d.axis];
  std::vector<long> per_layer(grid.cells[d.axis], 0);
  for (const Vec<D>& x : p.x) ++per_layer[layerOf(grid, x, d.axis)];
  d.cuts = balancedCuts(per_layer, d.slabs);
}

// Each slab's particles by the current cuts; how many changed slab, the most from one slab.
long reassign(Decomposition& d, const GridGeometry<D>& grid, const Particles<D>& p) {
  std::vector<long> left(d.slabs, 0);
  const bool first = d.owner.empty();
  if (first) d.owner.assign(p.size(), 0);
  for (int i = 0; i < p.size(); ++i) {
    const int slab = slabOf(d.cuts, layerOf(grid, p.x[i], d.axis));
    int& owner = d.owner[p.id[i]];
    if (!first && owner != slab) ++left[owner];
    owner = slab;
  }
  return *std::max_element(left.begin(), left.end());
}

// The nodes each slab sends its neighbours after the scatter: those its particles touch in the
// shared layers of each of its cuts; the most any slab sends.
long haloNodes(const Decomposition& d, const GridGeometry<D>& grid, const Particles<D>& p) {
  std::vector<std::set<long>> sent(d.slabs);
  const int a = d.axis, b = (a + 1) % D, c = (a + 2) % D;
  for (int i = 0; i < p.size(); ++i) {
    const int slab = d.owner[p.id[i]];
    const Vec<D> cell = p.x[i] / grid.h;
    // Quadratic weights reach the nodes floor(x/h - 1/2) + 0..2 (cubic: floor(x/h) - 1 + 0..3,
    // the same layers at the cuts).
    const IVec<D> first = (cell.array() - 0.5).floor().cast<int>();
    for (int cut_index : {slab, slab + 1}) {
      if (cut_index == 0 || cut_index == d.slabs) continue;
      const int cut = d.cuts[cut_index];
      for (int la = std::max(first[a], cut - 1); la <= std::min(first[a] + 2, cut + 1); ++la)
        for (int lb = first[b]; lb <= first[b] + 2; ++lb)
          for (int lc = first[c]; lc <= first[c] + 2; ++lc)
            sent[slab].insert(((static_cast<long>(la + 8) * 8192 + lb + 8) * 8192 + lc + 8) * 2 +
                              (cut_index > slab));  // the same node to either neighbour
    }
  }
  size_t most = 0;
  for (const auto& nodes : sent) most = std::max(most, nodes.size());
  return static_cast<long>(most);
}

double heaviestOverMean(const Decomposition& d) {
  std::vector<long> count(d.slabs, 0);
  for (int slab : d.owner) ++count[slab];
  const double mean = static_cast<double>(d.owner.size()) / d.slabs;
  return *std::max_element(count.begin(), count.end()) / mean;
}

// Bytes of one particle's state as a distributed step would send it: every array of the MPM
// particles in the solver's precision, the id included.
size_t particleBytes() {
  MpmParticles<D, Real> one;
  size_t bytes = 0;
  one.forEachArray(
      [&](auto& array) { bytes += sizeof(typename std::decay_t<decltype(array)>::value_type); });
  return bytes;
}

std::vector<int> parseList(const std::string& text) {
  std::vector<int> values;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) values.push_back(std::stoi(item));
  return values;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string path =
      argc > 1 ? argv[1] : std::string(SNOWSIM_SOURCE_DIR) + "/scenes/flagship/smash_wall.json";
  const double scale = argc > 2 ? std::atof(argv[2]) : 0.5;
  const std::vector<int> ranks = parseList(argc > 3 ? argv[3] : "2,4,8,16");
  const int rebalance = argc > 4 ? std::atoi(argv[4]) : 20;

  Scene scene = loadScene(path);
  if (scene.dimension != D || scene.solver != SolverType::Mpm) {
    std::fprintf(stderr, "decomposition_traffic: %s is not a 3D MPM scene\n", path.c_str());
    return 2;
  }
  if (scale != 1) scaleGrid(scene, scale);
  // Every particle moves every step, as docs/scale-out.md measured: the worst case of the traffic.
  scene.mpm.auto_sleep.enabled = false;
  MpmSolver<D> solver(scene, sampleBodies<D>(scene), 1);
  const GridGeometry<D>& grid = solver.grid();
  const bool mls = scene.mpm.transfer == MpmTransfer::Mls;
  // A node: its index, the mass and the momentum (and the force but for MLS) in double.
  const size_t node_bytes = sizeof(int) + sizeof(Real) * (1 + D * (mls ? 1 : 2));
  const size_t particle_bytes = particleBytes();

  std::vector<Decomposition> decompositions;
  for (int n : ranks) decompositions.emplace_back(n);
  for (Decomposition& d : decompositions) {
    recut(d, grid, solver.particles());
    reassign(d, grid, solver.particles());
  }
  long steps = 0;
  while (solver.time() < scene.duration - 1e-9) {
    const Real dt = std::min({scene.dt, solver.stableTimeStep(), scene.duration - solver.time()});
    for (Decomposition& d : decompositions) {
      if (steps > 0 && steps % rebalance == 0) {
        recut(d, grid, solver.particles());
        d.rebalance_moves.add(reassign(d, grid, solver.particles()));
      }
      d.halo_nodes.add(haloNodes(d, grid, solver.particles()));
      d.imbalance.add(heaviestOverMean(d));
    }
    solver.step(dt);
    ++steps;
    for (Decomposition& d : decompositions) d.migrants.add(reassign(d, grid, solver.particles()));
  }

  std::printf("%s at scale %g: %d particles, %d x %d x %d cells of %g mm, %ld steps to %g s\n",
              scene.name.c_str(), scale, solver.particles().size(), grid.cells[0], grid.cells[1],
              grid.cells[2], grid.h * 1000, steps, scene.duration);
  std::printf(
      "slabs along the longest axis, re-cut every %d steps; per step, the busiest slab's "
      "mean (largest):\n",
      rebalance);
  std::printf("%5s %9s %20s %18s %20s %17s %14s %14s\n", "ranks", "particles", "halo nodes sent",
              "halo KB sent", "particles leaving", "migration KB", "heaviest/mean", "re-cut moves");
  const double n_steps = static_cast<double>(steps);
  for (const Decomposition& d : decompositions) {
    if (d.too_few_layers > 0) {
      std::printf(
          "%5d: more slabs than the %d cell layers of the axis cut allow, %d cells a slab\n",
          d.slabs, d.too_few_layers, kMinSlabCells);
      continue;
    }
    const double halo = d.halo_nodes.sum / n_steps, migrants = d.migrants.sum / n_steps;
    std::printf(
        "%5d %9d %10.0f (%7.0f) %8.1f (%6.1f) %11.1f (%6.0f) %7.2f (%6.1f) %5.2f (%5.2f) %14.0f\n",
        d.slabs, solver.particles().size() / d.slabs, halo, d.halo_nodes.largest,
        halo * node_bytes / 1024, d.halo_nodes.largest * node_bytes / 1024, migrants,
        d.migrants.largest, migrants * particle_bytes / 1024,
        d.migrants.largest * particle_bytes / 1024, d.imbalance.sum / n_steps, d.imbalance.largest,
        d.rebalance_moves.largest);
  }
  std::printf(
      "bytes: %zu a halo node (index, mass, momentum%s), %zu a particle (its whole "
      "state); re-cut moves: the most particles one slab hands over at a re-cut\n",
      node_bytes, mls ? "" : ", force", particle_bytes);
  return 0;
}
