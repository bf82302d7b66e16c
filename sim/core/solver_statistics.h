// What a solver counts over a run for its summary and progress line, in one record: the
// semi-implicit solves, auto-sleep, and what this MPI rank sent the others. Plain values, so that
// a checkpoint can store them as bytes and ranks can exchange them.
#pragma once

#include "sim/core/krylov_result.h"

namespace snowsim {

// Auto-sleep over a run's steps (mpm.auto_sleep): the particle-steps taken, the share of them
// the particles slept through, and how many particles slept through the last step.
struct SleepTally {
  long particle_steps = 0, asleep_steps = 0;
  long asleep_now = 0, particles = 0;
};

// What a rank sent over the steps so far: the halo nodes, the particles that left its slab, and
// the bytes of both.
struct RankTraffic {
  long steps = 0;
  long halo_nodes = 0, halo_bytes = 0;
  long particles_sent = 0, particle_bytes = 0;
  long rebalances = 0;  // the slabs cut anew
  long moved_cuts = 0;  // ... of which so many moved a cut
};

struct SolverStatistics {
  SolveTally implicit_solves;  // none for an explicit solver
  SleepTally auto_sleep;       // nothing for a solver without it, or with it off
  RankTraffic rank_traffic;    // this rank's; nothing for a solver that runs in one process
};

}  // namespace snowsim
