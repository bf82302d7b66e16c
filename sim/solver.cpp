#include "sim/solver.h"

#include "sim/io/checkpoint.h"

namespace snowsim {

template <int D>
void Solver<D>::saveState(StateWriter& out) const {
  out.value(steps_);
  out.value(time_);
  out.value(chosen_);
  saveSolverState(out);
}

template <int D>
void Solver<D>::loadState(StateReader& in) {
  in.value(steps_);
  in.value(time_);
  in.value(chosen_);
  loadSolverState(in);
}

template class Solver<2>;
template class Solver<3>;

}  // namespace snowsim
