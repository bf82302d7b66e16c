// Particles buried in dense snow. Seen from the camera (a point) or from the key light (a
// direction), a particle behind enough snow cannot show in the image or cast a shadow that shows,
// so the 3D renderer leaves it out of that pass: in a packed pile most particles are inside
// (docs/rendering.md). How much snow lies in front is estimated on a grid of cells about two
// particle spacings wide over the particles' bounding box: a ray crossing a cell of side c that
// holds n spheres of radius r meets on average n pi r^2 / c^2 of them (the cell's optical depth);
// a cell whose summed depth towards the viewer exceeds kBuriedDepth lets through a share of about
// e^-kBuriedDepth of its rays, and its particles are left out. Below the ground (y < 0) counts as
// opaque; colliders count as transparent. Plain geometry, no OpenGL.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace snowsim {

// Optical depth beyond which a cell counts as hidden: e^-9, about 1 ray in 8000, gets through.
constexpr float kBuriedDepth = 9;

class BuriedParticles {
 public:
  // Bins the particles (spheres of `radius`) into cells of about two `spacing`s, coarser when
  // the particles spread so far that the grid would hold many more cells than particles.
  BuriedParticles(const std::vector<std::array<float, 3>>& positions, float spacing, float radius);

  // Appends to `visible` the indices, in increasing order, of the particles not buried as seen
  // from the point `eye`.
  void visibleFromPoint(glm::vec3 eye, std::vector<std::uint32_t>& visible) const;
  // The same seen from infinitely far away in the direction `towards` (a light's direction).
  void visibleFromDirection(glm::vec3 towards, std::vector<std::uint32_t>& visible) const;

 private:
  // Whether the cell's optical depth along the ray from its centre exceeds kBuriedDepth before
  // the ray leaves the grid or (max_distance) reaches the viewer.
  bool buried(const glm::ivec3& cell, glm::vec3 direction, float max_distance) const;
  template <typename DirectionOf>
  void collectVisible(DirectionOf direction_of, std::vector<std::uint32_t>& visible) const;

  glm::vec3 origin_{0};
  float cell_ = 1;
  glm::ivec3 cells_{0};
  float depth_per_particle_ = 0;        // a particle's share of its cell's optical depth
  std::vector<std::uint32_t> count_;    // particles per cell, x fastest
  std::vector<std::uint32_t> cell_of_;  // each particle's cell
};

}  // namespace snowsim
