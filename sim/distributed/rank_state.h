// A rank's part in one simulation split across MPI ranks (slab_decomposition.h, docs/scale-out.md):
// what a particle-grid solver asks of the other ranks, its state in a checkpoint, and the gather
// of every rank's particles for output. In one process each call returns at once, and a solver
// calls them the same way either way. P: the particle container (forEachArray, x, id).
#pragma once

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "sim/core/grid.h"
#include "sim/distributed/rank_exchange.h"
#include "sim/distributed/slab_decomposition.h"
#include "sim/io/checkpoint.h"

namespace snowsim {

template <int D, class P>
class RankState {
 public:
  RankState(RankExchange& world, const GridGeometry<D>& grid) : slabs_(world, grid) {}

  const SlabDecomposition<D>& slabs() const { return slabs_; }
  bool distributed() const { return slabs_.distributed(); }
  int ranks() const { return slabs_.ranks(); }

  // Every rank built the whole scene alike: each keeps its slab's particles. Returns whether the
  // particles changed.
  bool keepOwn(P& particles) {
    if (!distributed()) return false;
    slabs_.keepOwn(particles);
    return true;
  }
  // The grid update (the schedule's updateNodes) with the nodes shared with the neighbour ranks
  // summed first. force: whether the scatter wrote a force per node; sumOwn(): the sum of the
  // solver's own node fields shared with the neighbours, after the grid's (exchangeRecords).
  template <class Schedule, class Fields, class F, class SumOwn>
  void updateNodes(Schedule& schedule, Fields& fields, F&& update, bool force, SumOwn&& sumOwn) {
    if (!distributed()) return schedule.updateNodes(fields, update);
    schedule.updateNodes(fields, update, [&] {
      slabs_.sumHalo(fields, schedule.activeNodes(), force);
      sumOwn();
    });
  }
  // Node values this rank shares with its neighbours beside the grid's (SlabDecomposition::
  // exchangeBand), as records of plain data (sent as their bytes) whose k is the node: pack(k,
  // record) fills node k's and returns whether to send it, unpack(record) takes each neighbour's.
  // Nothing in one process.
  template <class Record, class Pack, class Unpack>
  void exchangeRecords(const NodeBox<D>& active, Pack&& pack, Unpack&& unpack) {
    using Slabs = SlabDecomposition<D>;
    slabs_.exchangeBand(
        active,
        [&](int k, std::string& bytes) {
          Record record;
          // Its padding too: the same bytes on the wire, run after run.
          std::memset(static_cast<void*>(&record), 0, sizeof record);
          if (pack(k, record)) Slabs::append(bytes, record);
        },
        [&](const std::string& bytes, size_t& at) {
          unpack(Slabs::template take<Record>(bytes, at));
        });
  }
  // Whether node k lies in box.
  bool contains(const NodeBox<D>& box, int k) const { return slabs_.contains(box, k); }
  // Whether any rank's value is true, on every rank.
  bool anyOverRanks(bool mine) { return distributed() ? sum(mine ? 1 : 0) > 0 : mine; }
  // After a step: the particles that left this rank's slab move to their new rank. Returns
  // whether this rank's particles changed.
  bool migrate(P& particles, long step) { return slabs_.migrate(particles, step); }
  // The same with records of plain data that the leaving particles carry (SlabDecomposition::
  // migrate): carry(leaving, send) calls send(record) for each of those for particles `leaving`,
  // and arrive(record) takes each at their new rank once they are stored there.
  template <class Record, class Carry, class Arrive>
  bool migrateWithRecords(P& particles, long step, Carry&& carry, Arrive&& arrive) {
    using Slabs = SlabDecomposition<D>;
    return slabs_.migrate(
        particles, step,
        [&](const std::vector<int>& leaving, std::string& bytes) {
          carry(leaving, [&](const Record& record) { Slabs::append(bytes, record); });
        },
        [&](std::string_view bytes) {
          for (size_t at = 0; at < bytes.size();) arrive(Slabs::template take<Record>(bytes, at));
        });
  }

  // The whole snow's measures, alike on every rank: the largest speeds and every rank's energy.
  void combineMeasures(Real& speed, Real& signal, bool& finite, Real& energy) {
    if (!distributed()) return;
    std::vector<Real> largest = {speed, signal, finite ? 0.0 : 1.0};
    energy = slabs_.maxAndSum(largest, energy);
    speed = largest[0];
    signal = largest[1];
    finite = largest[2] == 0;
  }
  long sum(long count) {
    if (!distributed()) return count;
    std::vector<double> none;
    return std::lround(slabs_.maxAndSum(none, double(count)));
  }
  // Every rank's value of a plain type, in rank order, on every rank.
  template <class V>
  std::vector<V> gatherEach(const V& mine) const {
    return slabs_.gatherEach(mine);
  }
  // 2D node values of the domain from every rank (SlabDecomposition::combineNodeValues).
  void combineNodeValues(std::vector<float>& values) const { slabs_.combineNodeValues(values); }

  // Every rank's particles in the order of their ids on rank 0, once per step that asks, none on
  // the other ranks; this process's own when not distributed: what the output sees.
  const P& output(const P& mine, long step) const {
    if (!distributed()) return mine;
    if (gathered_at_step_ != step) {
      slabs_.gatherById(mine, gathered_);
      gathered_at_step_ = step;
    }
    return gathered_;
  }

  // A checkpoint: saveRank(out) writes what this rank holds; across ranks, each rank's state in
  // rank order, on rank 0, which writes the file (the others' writers discard what they are
  // given), so that a resume under as many ranks takes the very steps the run would have.
  template <class SaveRank>
  void save(StateWriter& out, SaveRank&& saveRank) const {
    if (!distributed()) return saveRank(out);
    StateWriter mine;
    saveRank(mine);
    const std::vector<std::string> ranks = slabs_.gatherToFirst(mine.bytes());
    out.value(static_cast<std::uint32_t>(ranks.size()));
    for (const std::string& bytes : ranks) {  // as an array of chars, without copying it into one
      out.value(static_cast<std::uint64_t>(bytes.size()));
      out.append(bytes);
    }
  }
  template <class LoadRank>
  void load(StateReader& in, LoadRank&& loadRank) {
    gathered_at_step_ = -1;
    if (!distributed()) return loadRank(in);
    const auto ranks = in.value<std::uint32_t>();
    if (static_cast<int>(ranks) != slabs_.ranks())
      in.fail("a run across " + std::to_string(ranks) +
              " MPI ranks resumes across as many (mpirun -np " + std::to_string(ranks) + "), not " +
              std::to_string(slabs_.ranks()));
    std::vector<char> mine;
    for (int r = 0; r < slabs_.ranks(); ++r) {
      std::vector<char> bytes;
      in.array(bytes);
      if (r == slabs_.rank()) mine.swap(bytes);
    }
    StateReader rank_state(std::string_view(mine.data(), mine.size()), in.file());
    loadRank(rank_state);
    rank_state.finish();
  }
  // This rank's particles in its checkpoint: across ranks as many as the rank had, of any ids of
  // the scene's total. Returns whether their count or order may have changed.
  bool loadParticles(StateReader& in, P& particles, int total) {
    if (!distributed()) {
      loadParticleArrays(in, particles);
      return false;
    }
    particles.forEachArray([&](auto& a) {
      in.array(a);
      if (!a.empty() && a.size() != particles.x.size()) in.fail("arrays of unequal lengths");
    });
    for (const int id : particles.id)
      if (id < 0 || id >= total) in.fail("particle id " + std::to_string(id));
    return true;
  }
  // The slabs' cut, last in a rank's state.
  void saveSlabs(StateWriter& out) const {
    if (distributed()) slabs_.saveState(out);
  }
  void loadSlabs(StateReader& in) {
    if (distributed()) slabs_.loadState(in);
  }

 private:
  mutable SlabDecomposition<D> slabs_;  // a gather for output reads every rank, also in const
  mutable P gathered_;
  mutable long gathered_at_step_ = -1;
};

}  // namespace snowsim
