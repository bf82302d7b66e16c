#include "render/buried_particles.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace snowsim {

namespace {

constexpr float kPi = 3.14159265f;

// The cell index along one axis of coordinate `v` (in cells from the grid's origin), clamped to
// the grid; NaN lands in cell 0.
int clampedIndex(float v, int cells) {
  return v >= 0 ? std::min(static_cast<int>(v), cells - 1) : 0;
}

}  // namespace

BuriedParticles::BuriedParticles(const std::vector<std::array<float, 3>>& positions, float spacing,
                                 float radius) {
  glm::vec3 low(std::numeric_limits<float>::max()), high(std::numeric_limits<float>::lowest());
  for (const auto& p : positions)
    for (int a = 0; a < 3; ++a) {
      if (p[a] < low[a]) low[a] = p[a];
      if (p[a] > high[a]) high[a] = p[a];
    }
  if (!(low.x <= high.x && low.y <= high.y && low.z <= high.z)) low = high = glm::vec3(0);
  origin_ = low;
  const double most_cells = std::max(4096.0, 2.0 * positions.size());
  cell_ = std::max(2 * spacing, 1e-6f);
  for (;; cell_ *= 1.25f) {
    cells_ = glm::ivec3((high - low) / cell_) + 1;
    if (double(cells_.x) * cells_.y * cells_.z <= most_cells) break;
  }
  depth_per_particle_ = kPi * radius * radius / (cell_ * cell_);
  count_.assign(static_cast<size_t>(cells_.x) * cells_.y * cells_.z, 0);
  cell_of_.resize(positions.size());
  for (size_t i = 0; i < positions.size(); ++i) {
    const auto& p = positions[i];
    const int x = clampedIndex((p[0] - origin_.x) / cell_, cells_.x);
    const int y = clampedIndex((p[1] - origin_.y) / cell_, cells_.y);
    const int z = clampedIndex((p[2] - origin_.z) / cell_, cells_.z);
    cell_of_[i] =
        static_cast<std::uint32_t>((static_cast<size_t>(z) * cells_.y + y) * cells_.x + x);
    ++count_[cell_of_[i]];
  }
}

bool BuriedParticles::buried(const glm::ivec3& cell, glm::vec3 direction,
                             float max_distance) const {
  // Half-cell steps, starting a cell away: the cell's own particles may lie in front of or
  // behind the one asked about, so they never count.
  const float step = 0.5f * cell_;
  const glm::vec3 centre = origin_ + (glm::vec3(cell) + 0.5f) * cell_;
  float depth = 0;
  for (float t = cell_; t < max_distance; t += step) {
    const glm::vec3 q = centre + t * direction;
    if (q.y < 0) return true;  // the ray meets the ground
    const glm::vec3 in_cells = (q - origin_) / cell_;
    if (!(in_cells.x >= 0 && in_cells.y >= 0 && in_cells.z >= 0)) return false;
    const glm::ivec3 c(in_cells);
    if (c.x >= cells_.x || c.y >= cells_.y || c.z >= cells_.z) return false;
    depth += 0.5f * depth_per_particle_ *
             count_[(static_cast<size_t>(c.z) * cells_.y + c.y) * cells_.x + c.x];
    if (depth > kBuriedDepth) return true;
  }
  return false;
}

template <typename DirectionOf>
void BuriedParticles::collectVisible(DirectionOf direction_of,
                                     std::vector<std::uint32_t>& visible) const {
  // Each occupied cell is judged once: 0 not yet, 1 visible, 2 buried.
  std::vector<std::uint8_t> verdict(count_.size(), 0);
  for (std::uint32_t i = 0; i < cell_of_.size(); ++i) {
    const std::uint32_t index = cell_of_[i];
    if (verdict[index] == 0) {
      const glm::ivec3 cell(index % cells_.x, index / cells_.x % cells_.y,
                            index / cells_.x / cells_.y);
      const glm::vec3 centre = origin_ + (glm::vec3(cell) + 0.5f) * cell_;
      const auto [direction, distance] = direction_of(centre);
      verdict[index] = buried(cell, direction, distance) ? 2 : 1;
    }
    if (verdict[index] == 1) visible.push_back(i);
  }
}

void BuriedParticles::visibleFromPoint(glm::vec3 eye, std::vector<std::uint32_t>& visible) const {
  collectVisible(
      [eye](glm::vec3 centre) {
        const glm::vec3 to_eye = eye - centre;
        const float distance = glm::length(to_eye);
        return std::pair(distance > 0 ? to_eye / distance : glm::vec3(0, 1, 0), distance);
      },
      visible);
}

void BuriedParticles::visibleFromDirection(glm::vec3 towards,
                                           std::vector<std::uint32_t>& visible) const {
  const glm::vec3 direction = glm::normalize(towards);
  collectVisible(
      [direction](glm::vec3) {
        return std::pair(direction, std::numeric_limits<float>::infinity());
      },
      visible);
}

}  // namespace snowsim
