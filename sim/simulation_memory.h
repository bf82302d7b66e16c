// The memory a run's simulation takes, from its scene alone: the particles' arrays and the
// grid's as the solvers lay them out, counted without building either.
#pragma once

#include <algorithm>

#include "sim/scene/scene.h"

namespace snowsim {

// The bytes of each part; the peak comes once the solver steps (the arrays it keeps, then the
// pages near the snow and a frame's snapshot), or while it is built, when the sampled particles
// it converts take more than those pages and the snapshot (and whatever else the run adds then).
struct SimulationMemory {
  long particles = 0;  // as sampleBodies makes them (countBodyParticles)
  long nodes = 0;      // stored grid nodes, the ghost layers included
  double state = 0;    // the particles' arrays and the schedule's per particle
  double dense = 0;    // the grid's arrays written whole when the solver is built
  // The grid-sized arrays of zero pages (the partial grids, sim/parallel/zero_page_allocator.h)
  // take memory only where the snow reaches: `touched` over the pages the bodies' box falls on,
  // `spread` what they take besides once the snow has reached every node.
  double touched = 0, spread = 0;
  double snapshot = 0;  // a frame's, from the solver's arrays
  double setup = 0;     // the sampled particles in double that a float solver converts
  // The peak, with `later` bytes more once the solver steps (the frames' drawing).
  double peak(double later = 0) const {
    return state + dense + std::max(setup, touched + snapshot + later);
  }
};

// The stored grid nodes of the scene's grid, the ghost layers included (GridGeometry).
long gridNodeCount(const Scene& scene);

// InputError naming the scene and grid.cells when its grid holds more nodes than the grid's int
// index reaches; makeSimulation calls it first, and a run before it allocates anything.
void refuseGridTooLarge(const std::string& scene_name, long nodes);

SimulationMemory simulationMemory(const Scene& scene, long particles);

}  // namespace snowsim
