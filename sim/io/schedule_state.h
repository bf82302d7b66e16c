// A ParticleGridSchedule's state in a checkpoint: its binning, then its three counters, as they
// were written before the schedule exposed them as plain data (the format is unchanged).
#pragma once

#include <string>
#include <utility>

#include "sim/io/checkpoint.h"
#include "sim/parallel/particle_grid_schedule.h"

namespace snowsim {

// The fields of a schedule's state (S, const or not) in the checkpoint's order, one list for the
// writer and the reader: array(a) for its arrays, value(v) for the rest.
template <class S, class Array, class Value>
void forScheduleStateFields(S& s, Array&& array, Value&& value) {
  array(s.binning.order);
  array(s.binning.row_start);
  value(s.binning.binned_first_block);
  value(s.binning.binned_last_block);
  value(s.binning.must_bin);
  value(s.binning.binnings);
  value(s.binning.active);
  value(s.binning.updated);
  value(s.binned_since_stored);
  value(s.stored_step);
  value(s.steps);
}

template <int D, class P>
void saveScheduleState(StateWriter& out, const ParticleGridSchedule<D, P>& schedule) {
  const typename ParticleGridSchedule<D, P>::State s = schedule.state();
  forScheduleStateFields(
      s, [&](const auto& a) { out.array(a); }, [&](const auto& v) { out.value(v); });
}

// Into a schedule of the same grid and particle count; InputError when the state does not fit.
template <int D, class P>
void loadScheduleState(StateReader& in, ParticleGridSchedule<D, P>& schedule) {
  // Read into the schedule's own state, whose arrays have the lengths the stored ones must have.
  typename ParticleGridSchedule<D, P>::State s = schedule.state();
  forScheduleStateFields(
      s, [&](auto& a) { in.array(a, static_cast<long>(a.size())); }, [&](auto& v) { in.value(v); });
  const std::string misfit = schedule.restore(std::move(s));
  if (!misfit.empty()) in.fail(misfit);
}

}  // namespace snowsim
