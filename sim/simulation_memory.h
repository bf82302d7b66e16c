// The memory a run's simulation takes, from its scene alone: the particles' arrays and the
// grid's as the solvers lay them out, counted without building either.
#pragma once

#include <string>
#include <vector>

#include "sim/scene/scene.h"

namespace snowsim {

struct MemoryPart {
  std::string what;  // "particles", "grid", ...
  double bytes;
};

struct SimulationMemory {
  long particles = 0;  // as sampleBodies makes them (countBodyParticles)
  long nodes = 0;      // stored grid nodes, the ghost layers included
  // The peak, part by part: the solver's arrays over the run, then the larger of what exists
  // only while it is built (the sampled particles) and what a frame adds (its snapshot).
  std::vector<MemoryPart> parts;
  double bytes() const;
};

// The stored grid nodes of the scene's grid, the ghost layers included (GridGeometry).
long gridNodeCount(const Scene& scene);

// The grid-sized arrays are counted whole, as if the snow touched every page of them over the
// run (those of zero pages take memory only where it does): an upper bound for snow that stays
// in a corner of its grid.
SimulationMemory simulationMemory(const Scene& scene, long particles);

}  // namespace snowsim
