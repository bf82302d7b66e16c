// What a frame shows: the particles and the grid at one instant, in a dimension-free form that
// render/ and the file writers read. 2D runs have z = 0.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace snowsim {

struct GridInfo {
  int dimension = 2;
  std::array<int, 3> cells{1, 1, 1};  // cells along x, y, z (z = 1 in 2D)
  double cell_size = 0;
  double particle_spacing = 0;  // lattice spacing the particles were generated at (smallest body)
  double critical_density = 0;  // density at which a cell counts as packed (0: not defined)
  // 2D runs: density m_i / h^2 at each node of the domain ((cells[0]+1) x (cells[1]+1), x
  // fastest); node (i, j) sits at (i h, j h) and stands for the cell of side h centred there.
  // Empty for 3D runs.
  std::vector<float> node_density;
};

struct Snapshot {
  int frame = 0;
  double time = 0;
  GridInfo grid;
  std::vector<std::array<float, 3>> position;
  std::vector<std::array<float, 3>> velocity;
  std::vector<float> density;    // kg/m^D per particle (current, interpolated from the grid)
  std::vector<float> plastic_j;  // J_P, the plastic volume ratio (MPM only; empty otherwise)

  int size() const { return static_cast<int>(position.size()); }
};

}  // namespace snowsim
