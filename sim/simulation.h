// Time stepping from frame to frame, independent of dimension and solver: the driver the command
// line, the benchmarks and the tests share.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "sim/core/snapshot.h"
#include "sim/core/solver_statistics.h"
#include "sim/distributed/rank_exchange.h"
#include "sim/scene/scene.h"
#include "sim/solver.h"

namespace snowsim {

// The state a caller reads as arrays (the Python module): the particles in the solver's own
// values, in creation order, and the grid's nodes, each a flat array, a vector's components and a
// matrix's rows one after the other. Copies: nothing in them reaches back into the solver.
struct StateArrays {
  int dimension = 2;
  std::vector<double> position, velocity, mass;  // N x D, N x D, N
  // MPM only (empty otherwise): the elastic deformation gradient F_E (N x D x D) and J_P (N).
  std::vector<double> elastic_gradient, plastic_j;
  // MPM only (zeros and empty otherwise): the nodes along each axis, two ghost layers beyond each
  // wall included (node i of axis a at (i - 2) h), and the mass and velocity (nodes x D) each node
  // had at the end of the last step, x fastest.
  std::array<int, 3> nodes{0, 0, 0};
  std::vector<double> node_mass, node_velocity;
};

class Simulation {
 public:
  virtual ~Simulation() = default;

  // Steps until the simulated time reaches t (the last step is shortened to land on it). Checks
  // stop_requested() before each step and returns false, short of t, once it says so. Throws
  // SimulationError when the state stops being finite.
  virtual bool advanceTo(double t, const std::function<bool()>& stop_requested = {}) = 0;
  // One step of the scene's dt, or less where stability asks (SimulationError as advanceTo).
  virtual void step() = 0;

  // Across MPI ranks each rank calls it at once, and rank 0 alone gets the particles.
  virtual Snapshot snapshot(int frame) const = 0;
  virtual double time() const = 0;
  virtual long steps() const = 0;
  // The smallest and largest step the time-step policy chose (none before the first step).
  virtual StepSizes chosenSteps() const = 0;
  virtual int particleCount() const = 0;
  // What the solver counted so far: its solves, auto-sleep, what this rank sent the others.
  virtual SolverStatistics statistics() const = 0;
  // The wall time of the steps so far.
  virtual double stepSeconds() const = 0;
  // The particles and the grid as arrays; across MPI ranks, each calls it at once and rank 0
  // alone gets the particles.
  virtual StateArrays stateArrays() const = 0;
  // What bounds the time step now (sim/solver.h); a look over every particle.
  virtual StepLimit stepLimit() const = 0;
  // Where the steps' wall time went: the solver's stages, then "rest of the step" (the step's
  // time in no stage; "step" for a solver that times no stages). Their sum is the steps' time.
  virtual std::vector<StageSeconds> stepStages() const = 0;

  // The solver's whole state as bytes (sim/io/checkpoint.h), and back into a simulation made from
  // the same scene: it then steps on exactly as the saved one would have. loadState throws
  // InputError naming `file` when the bytes do not fit this simulation.
  virtual void saveState(StateWriter& out) const = 0;
  virtual void loadState(std::string_view bytes, const std::string& file) = 0;
};

// Builds the particles and the solver the scene asks for, in the scene's dimension. `threads`
// bounds the solver's threads; 0 takes the OpenMP default (OMP_NUM_THREADS, else every core).
// world: the MPI ranks one MPM run is split across (worldExchange() under mpirun), each calling
// this alike.
std::unique_ptr<Simulation> makeSimulation(const Scene& scene, int threads = 0,
                                           RankExchange& world = oneProcess());

}  // namespace snowsim
