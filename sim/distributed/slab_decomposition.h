// One simulation split across ranks (docs/scale-out.md): each rank owns a slab of cell layers
// along one axis and the particles whose cell lies in it. A particle of cell c reaches the nodes
// c-1 .. c+2, so the ranks on either side of a cut at layer c share the four node layers c-1 ..
// c+2: after the scatter each sends the other its partial sums there and adds what it receives,
// which gives both the same node values (a + b == b + a in floating point) and no second exchange.
// A slab is at least four cells wide, so no node is shared by three ranks. After the advection the
// particles that left their slab move to their new rank with every per-particle array; every
// rebalance_interval steps the slabs are cut anew from a histogram of all ranks' particles along
// the axis where the snow is longest. With one rank every operation returns at once.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "sim/core/errors.h"
#include "sim/core/grid.h"
#include "sim/core/solver_statistics.h"
#include "sim/distributed/rank_exchange.h"
#include "sim/io/checkpoint.h"

namespace snowsim {

template <int D>
class SlabDecomposition {
 public:
  static constexpr int min_slab_cells = 4;
  static constexpr int rebalance_interval = 20;  // steps between re-cuts of the slabs

  SlabDecomposition(RankExchange& world, const GridGeometry<D>& grid)
      : world_(world), grid_(grid) {}

  bool distributed() const { return world_.ranks() > 1; }
  int rank() const { return world_.rank(); }
  int ranks() const { return world_.ranks(); }
  int axis() const { return axis_; }
  // The first cell layer of each slab after the first, ascending.
  const std::vector<int>& cuts() const { return cuts_; }
  const RankTraffic& traffic() const { return traffic_; }
  // Every rank's bytes, in rank order, on rank 0 (empty on the others).
  std::vector<std::string> gatherToFirst(std::string_view mine) const {
    return world_.gatherToFirst(mine);
  }

  // particles: the whole scene, alike on every rank; cuts the slabs and keeps this rank's.
  template <class P>
  void keepOwn(P& particles) {
    if (!distributed()) return;
    particles.forEachArray([&](auto& array) { used_.push_back(!array.empty()); });
    cut(particles.x, false);
    std::vector<char> mine(particles.size());
    for (int p = 0; p < particles.size(); ++p) mine[p] = slabOf(particles.x[p]) == rank();
    keepOnly(particles, mine);
  }

  // After the step `step` moved the particles: the slabs cut anew every rebalance_interval steps,
  // then the particles outside this rank's slab sent to their own, with what carry(which, bytes)
  // appends for them (which: their indices), which arrive(bytes) reads at their new rank, in rank
  // order, once they are stored there. Returns whether this rank's particles changed (their order
  // too).
  template <class P, class Carry, class Arrive>
  bool migrate(P& particles, long step, Carry&& carry, Arrive&& arrive) {
    if (!distributed()) return false;
    ++traffic_.steps;
    step_axis_ = axis_;
    step_cuts_ = cuts_;
    if (step % rebalance_interval == 0) cut(particles.x, true);
    std::vector<std::vector<int>> leaving(ranks());
    std::vector<char> stays(particles.size());
    for (int p = 0; p < particles.size(); ++p) {
      const int owner = slabOf(particles.x[p]);
      stays[p] = owner == rank();
      if (!stays[p]) leaving[owner].push_back(p);
    }
    std::vector<std::string> to(ranks());
    long sent = 0;
    for (int r = 0; r < ranks(); ++r) {  // to each rank: nothing, or the particles' length,
      if (leaving[r].empty()) continue;  // their bytes, what they carry
      const std::string bytes = pack(particles, leaving[r]);
      append(to[r], static_cast<std::uint64_t>(bytes.size()));
      to[r] += bytes;
      carry(leaving[r], to[r]);
      sent += static_cast<long>(leaving[r].size());
      traffic_.particle_bytes += static_cast<long>(to[r].size());
    }
    traffic_.particles_sent += sent;
    const std::vector<std::string> from = world_.allToAll(to);
    bool received = false;
    for (const std::string& bytes : from) received = received || !bytes.empty();
    if (sent == 0 && !received) return false;
    keepOnly(particles, stays);
    std::vector<std::string_view> carried;
    for (const std::string& bytes : from) {  // in rank order
      if (bytes.empty()) continue;
      size_t at = 0;
      const auto length = take<std::uint64_t>(bytes, at);
      unpack(std::string_view(bytes).substr(at, length), particles);
      carried.push_back(std::string_view(bytes).substr(at + length));
    }
    for (const std::string_view bytes : carried)
      if (!bytes.empty()) arrive(bytes);
    return true;
  }
  template <class P>
  bool migrate(P& particles, long step) {
    return migrate(
        particles, step, [](const std::vector<int>&, std::string&) {}, [](std::string_view) {});
  }
  // Whether this rank's particles could reach node k (flat index) in the step before the last
  // migrate (before any, under the present cuts): the nodes c-1 .. c+2 of its slab's cell layers
  // c under that step's cuts.
  bool reachedInLastStep(int k) const {
    if (!distributed()) return true;
    const bool migrated = step_cuts_.size() == cuts_.size();
    const int a = migrated ? step_axis_ : axis_;
    const std::vector<int>& cuts = migrated ? step_cuts_ : cuts_;
    const int layer = (k / grid_.stride[a]) % grid_.nodes[a] - GridGeometry<D>::ghost;
    const int first = rank() == 0 ? 0 : cuts[rank() - 1];
    const int end = rank() + 1 < ranks() ? cuts[rank()] : grid_.cells[a];
    return layer >= first - 1 && layer <= end + 1;
  }

  // Between the sum of the scatter's partial grids and the node update: the partial sums of the
  // nodes this rank shares with its neighbours (mass, momentum in fields.velocity, the force when
  // the scatter writes one), exchanged and added within this rank's active nodes.
  template <class T>
  void sumHalo(GridFields<D, T>& fields, const NodeBox<D>& active, bool force) {
    using V = Vec<D, T>;
    exchangeBand(
        active,
        [&](int k, std::string& bytes) {
          const bool written = fields.mass[k] != 0 || (fields.velocity[k].array() != 0).any() ||
                               (force && (fields.force[k].array() != 0).any());
          if (!written) return;
          append(bytes, k);
          append(bytes, fields.mass[k]);
          append(bytes, fields.velocity[k]);
          if (force) append(bytes, fields.force[k]);
        },
        [&](const std::string& bytes, size_t& at) {
          const int k = take<int>(bytes, at);
          const T mass = take<T>(bytes, at);
          const V momentum = take<V>(bytes, at);
          const V node_force = force ? take<V>(bytes, at) : V::Zero();
          if (!contains(active, k)) return;  // no particle of this rank reaches it
          fields.mass[k] += mass;
          fields.velocity[k] += momentum;
          if (force) fields.force[k] += node_force;
        });
  }

  // What the ranks on either side of a cut exchange of the nodes they share: to each neighbour
  // the records pack(k, bytes) appends (each starting with its node, or none) for the shared band's
  // nodes k within this rank's active box, storage coordinates; then unpack(bytes, at) reads one
  // record at a time of what the neighbours sent, in rank order.
  template <class Pack, class Unpack>
  void exchangeBand(const NodeBox<D>& active, Pack&& pack, Unpack&& unpack) {
    if (!distributed()) return;
    std::vector<std::string> to(ranks());
    const auto packBand = [&](int neighbour, int cut_layer) {
      std::string& bytes = to[neighbour];
      NodeBox<D> band = active;  // storage coordinates: node i at i + ghost
      band.lo[axis_] = std::max(band.lo[axis_], cut_layer - 1 + GridGeometry<D>::ghost);
      band.hi[axis_] = std::min(band.hi[axis_], cut_layer + 3 + GridGeometry<D>::ghost);
      if (band.lo[axis_] >= band.hi[axis_]) return;
      for (int n = 0, count = band.count(); n < count; ++n) {
        const size_t before = bytes.size();
        pack(band.flatIndex(grid_, n), bytes);
        traffic_.halo_nodes += bytes.size() > before;
      }
      traffic_.halo_bytes += static_cast<long>(bytes.size());
    };
    if (rank() > 0) packBand(rank() - 1, cuts_[rank() - 1]);
    if (rank() + 1 < ranks()) packBand(rank() + 1, cuts_[rank()]);
    for (const std::string& bytes : world_.allToAll(to))
      for (size_t at = 0; at < bytes.size();) unpack(bytes, at);
  }
  // Whether node k (a flat index) lies in box.
  bool contains(const NodeBox<D>& box, int k) const {
    for (int a = 0; a < D; ++a) {
      const int i = (k / grid_.stride[a]) % grid_.nodes[a];
      if (i < box.lo[a] || i >= box.hi[a]) return false;
    }
    return true;
  }
  // A record's values, appended to bytes and taken back from `at` on.
  template <class T>
  static void append(std::string& bytes, const T& value) {
    bytes.append(reinterpret_cast<const char*>(&value), sizeof value);
  }
  template <class T>
  static T take(std::string_view bytes, size_t& at) {
    T value;
    std::memcpy(static_cast<void*>(&value), bytes.data() + at, sizeof value);
    at += sizeof value;
    return value;
  }

  // The largest of each rank's values and the sum of its `sum` added in rank order (the same on
  // every rank, run after run): what the time step and the blow-up check follow, in one exchange.
  double maxAndSum(std::vector<double>& values, double sum) {
    if (!distributed()) return sum;
    values.push_back(sum);
    sum = 0;
    const size_t n = values.size();
    for (const std::string& bytes : world_.allGather(asBytes(values))) {
      const std::vector<double> theirs = fromBytes<double>(bytes);
      for (size_t i = 0; i + 1 < n; ++i) values[i] = std::max(values[i], theirs[i]);
      sum += theirs[n - 1];
    }
    values.pop_back();
    return sum;
  }
  // Every rank's value of a plain type, in rank order, on every rank.
  template <class V>
  std::vector<V> gatherEach(const V& mine) const {
    if (!distributed()) return {mine};
    return snowsim::gatherEach(world_, mine);
  }
  // Each rank's values, every rank getting the largest.
  std::vector<double> maxOverRanks(std::vector<double> values) {
    if (!distributed()) return values;
    for (const std::string& bytes : world_.allGather(asBytes(values))) {
      const std::vector<double> theirs = fromBytes<double>(bytes);
      for (size_t i = 0; i < values.size(); ++i) values[i] = std::max(values[i], theirs[i]);
    }
    return values;
  }

  // Every rank's particles, in the order of their ids (the order of creation), on rank 0, which
  // alone writes the frames; none on the others.
  template <class P>
  void gatherById(const P& mine, P& all) {
    std::vector<int> every(mine.size());
    for (int p = 0; p < mine.size(); ++p) every[p] = p;
    all = P();
    // forEachArray hands out the arrays to change them; pack only reads them.
    for (const std::string& bytes : world_.gatherToFirst(pack(const_cast<P&>(mine), every)))
      unpack(bytes, all);
    const std::vector<int> id = all.id;
    all.forEachArray([&](auto& array) {
      if (array.empty()) return;
      auto by_id = array;
      for (size_t p = 0; p < id.size(); ++p) by_id[id[p]] = array[p];
      array.swap(by_id);
    });
  }

  // 2D node values of the domain (domainNodeValues) from every rank: a rank holds the whole sum
  // of each node its active box covers and zero at the others, so the largest is the node's.
  void combineNodeValues(std::vector<float>& values) {
    if (!distributed()) return;
    for (const std::string& bytes : world_.allGather(asBytes(values))) {
      const std::vector<float> theirs = fromBytes<float>(bytes);
      for (size_t i = 0; i < values.size(); ++i) values[i] = std::max(values[i], theirs[i]);
    }
  }

  // The cut, for a checkpoint of this rank's state.
  void saveState(StateWriter& out) const {
    out.value(axis_);
    out.array(cuts_);
    out.value(traffic_);
  }
  void loadState(StateReader& in) {
    in.value(axis_);
    in.array(cuts_, ranks() - 1);
    in.value(traffic_);
  }

 private:
  template <class T>
  static std::string asBytes(const std::vector<T>& values) {
    return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
  }
  template <class T>
  static std::vector<T> fromBytes(const std::string& bytes) {
    std::vector<T> values(bytes.size() / sizeof(T));
    // An empty vector's data() may be null, which memcpy must not get even for 0 bytes.
    if (!values.empty()) std::memcpy(values.data(), bytes.data(), values.size() * sizeof(T));
    return values;
  }
  // The cell layer of position x along the axis, as the stencils find it, within the domain.
  template <class T>
  int layerOf(const Vec<D, T>& x) const {
    const int cell = static_cast<int>(std::floor(x[axis_] * T(1 / grid_.h)));
    return std::clamp(cell, 0, grid_.cells[axis_] - 1);
  }
  template <class T>
  int slabOf(const Vec<D, T>& x) const {
    const int layer = layerOf(x);
    return static_cast<int>(std::upper_bound(cuts_.begin(), cuts_.end(), layer) - cuts_.begin());
  }

  // The slabs along the axis where the particles (every rank's when `gather`) spread farthest,
  // cut so that each holds about the same count, and at least min_slab_cells layers.
  template <class T>
  void cut(const std::vector<Vec<D, T>>& x, bool gather) {
    std::vector<double> reach(2 * D, -std::numeric_limits<double>::infinity());
    for (const Vec<D, T>& p : x)
      for (int a = 0; a < D; ++a) {
        reach[a] = std::max(reach[a], -double(p[a]));
        reach[D + a] = std::max(reach[D + a], double(p[a]));
      }
    if (gather) reach = maxOverRanks(reach);
    int axis = -1;
    for (int a = 0; a < D; ++a) {
      if (grid_.cells[a] < min_slab_cells * ranks()) continue;
      if (axis < 0 || reach[D + a] + reach[a] > reach[D + axis] + reach[axis]) axis = a;
    }
    if (axis < 0)
      throw InputError("the grid has fewer than " + std::to_string(min_slab_cells * ranks()) +
                       " cells along every axis: too few for " + std::to_string(ranks()) +
                       " ranks, whose slabs take " + std::to_string(min_slab_cells) +
                       " cells each at least");
    axis_ = axis;
    const int layers = grid_.cells[axis_];
    std::vector<long> count(layers, 0);
    for (const Vec<D, T>& p : x) ++count[layerOf(p)];
    if (gather) {
      const std::vector<std::string> all = world_.allGather(asBytes(count));
      std::fill(count.begin(), count.end(), 0);
      for (const std::string& bytes : all) {
        const std::vector<long> theirs = fromBytes<long>(bytes);
        for (int l = 0; l < layers; ++l) count[l] += theirs[l];
      }
    }
    long total = 0;
    for (const long c : count) total += c;
    const std::vector<int> before = cuts_;
    cuts_.assign(ranks() - 1, 0);
    long below = 0;
    int layer = 0;
    for (int r = 1; r < ranks(); ++r) {
      // The first layer with at least r/N of the particles below it, keeping every slab wide.
      while (layer < layers && below * ranks() < total * r) below += count[layer++];
      const int lowest = (r == 1 ? 0 : cuts_[r - 2]) + min_slab_cells;
      const int highest = layers - (ranks() - r) * min_slab_cells;
      cuts_[r - 1] = std::clamp(layer, lowest, highest);
    }
    ++traffic_.rebalances;
    if (!before.empty() && before != cuts_) ++traffic_.moved_cuts;
  }

  // The bytes of particles `which`, each used array's elements in turn.
  template <class P>
  std::string pack(P& particles, const std::vector<int>& which) const {
    std::string bytes;
    int a = 0;
    particles.forEachArray([&](auto& array) {
      if (!used_[a++]) return;
      for (const int p : which) append(bytes, array[p]);
    });
    return bytes;
  }
  template <class P>
  void unpack(std::string_view bytes, P& particles) const {
    size_t per_particle = 0;
    int a = 0;
    particles.forEachArray([&]<class E>(std::vector<E>&) {
      if (used_[a++]) per_particle += sizeof(E);
    });
    const size_t count = bytes.size() / per_particle;
    size_t at = 0;
    a = 0;
    particles.forEachArray([&]<class E>(std::vector<E>& array) {
      if (!used_[a++]) return;
      for (size_t i = 0; i < count; ++i) array.push_back(take<E>(bytes, at));
    });
  }
  template <class P>
  static void keepOnly(P& particles, const std::vector<char>& keep) {
    particles.forEachArray([&](auto& array) {
      if (array.empty()) return;
      size_t kept = 0;
      for (size_t p = 0; p < keep.size(); ++p)
        if (keep[p]) array[kept++] = array[p];
      array.resize(kept);
    });
  }

  RankExchange& world_;
  GridGeometry<D> grid_;
  int axis_ = 0;
  std::vector<int> cuts_;
  int step_axis_ = 0;  // the axis and cuts of the step before the last migrate
  std::vector<int> step_cuts_;
  std::vector<char> used_;  // per array of forEachArray: whether the particles use it
  RankTraffic traffic_;
};

}  // namespace snowsim
