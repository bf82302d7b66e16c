// Error metrics for the study; see study/metrics.h and docs/study.md.
#include "study/metrics.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <unordered_map>
#include <utility>

namespace snowsim {

namespace {

double distance(const Point3& a, const Point3& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                   (a[2] - b[2]) * (a[2] - b[2]));
}

// Both runs must sample the same instants, or the comparison means nothing.
size_t commonFrameCount(const Frames& run, const Frames& reference) {
  const size_t n = std::min(run.size(), reference.size());
  if (n == 0) throw std::invalid_argument("metrics: a run has no frames");
  for (size_t f = 0; f < n; ++f)
    if (std::abs(run[f].time - reference[f].time) > 1e-9)
      throw std::invalid_argument("metrics: the runs' frames are at different times");
  return n;
}

}  // namespace

Point3 centreOfMass(const Snapshot& s) {
  Point3 c{};
  for (const auto& p : s.position)
    for (int k = 0; k < 3; ++k) c[k] += p[k];
  for (double& v : c) v /= std::max(1, s.size());
  return c;
}

Point3 centreOfMass(const Snapshot& s, const std::vector<int>& members) {
  Point3 c{};
  for (int i : members)
    for (int k = 0; k < 3; ++k) c[k] += s.position[i][k];
  for (double& v : c) v /= std::max<size_t>(1, members.size());
  return c;
}

Point3 meanVelocity(const Snapshot& s) {
  Point3 v{};
  for (const auto& u : s.velocity)
    for (int k = 0; k < 3; ++k) v[k] += u[k];
  for (double& x : v) x /= std::max(1, s.size());
  return v;
}

double freeFallError(const Frames& frames, const Point3& gravity, double until) {
  if (frames.empty()) return 0;
  const Point3 x0 = centreOfMass(frames[0]);
  const Point3 v0 = meanVelocity(frames[0]);
  const double t0 = frames[0].time;
  double worst = 0;
  for (const Snapshot& s : frames) {
    if (s.time > until) break;
    const double t = s.time - t0;
    Point3 expected;
    for (int k = 0; k < 3; ++k) expected[k] = x0[k] + v0[k] * t + 0.5 * gravity[k] * t * t;
    worst = std::max(worst, distance(centreOfMass(s), expected));
  }
  return worst;
}

double momentumDrift(const Frames& frames, const Point3& gravity, double until) {
  if (frames.empty()) return 0;
  const Point3 v0 = meanVelocity(frames[0]);
  double worst = 0;
  for (const Snapshot& s : frames) {
    if (s.time > until) break;
    const double t = s.time - frames[0].time;
    Point3 expected;
    for (int k = 0; k < 3; ++k) expected[k] = v0[k] + gravity[k] * t;
    worst = std::max(worst, distance(meanVelocity(s), expected));
  }
  return worst;
}

std::vector<int> membersLeftOf(const Snapshot& first, double split_x) {
  std::vector<int> members;
  for (int i = 0; i < first.size(); ++i)
    if (first.position[i][0] < split_x) members.push_back(i);
  return members;
}

std::vector<int> membersRightOf(const Snapshot& first, double split_x) {
  std::vector<int> members;
  for (int i = 0; i < first.size(); ++i)
    if (first.position[i][0] >= split_x) members.push_back(i);
  return members;
}

double landingTime(const Frames& frames, const std::vector<int>& members, double ground_y,
                   double margin) {
  for (const Snapshot& s : frames) {
    for (int i : members)
      if (s.position[i][1] <= ground_y + margin) return s.time;
  }
  return -1;
}

double oscillationFrequency(const std::vector<double>& times, const std::vector<double>& values) {
  const size_t n = std::min(times.size(), values.size());
  if (n < 3) return 0;
  double mean = 0;
  for (size_t i = 0; i < n; ++i) mean += values[i];
  mean /= n;
  std::vector<double> crossings;
  for (size_t i = 1; i < n; ++i) {
    const double a = values[i - 1] - mean, b = values[i] - mean;
    if ((a < 0) != (b < 0) && a != b)
      crossings.push_back(times[i - 1] + (times[i] - times[i - 1]) * a / (a - b));
  }
  if (crossings.size() < 2) return 0;
  // Two crossings of the mean per period.
  const double half_periods = crossings.size() - 1;
  return half_periods / (2 * (crossings.back() - crossings.front()));
}

std::array<int, 3> FieldGrid::cells() const {
  const double h = cellSize();
  std::array<int, 3> n{1, 1, 1};
  for (int k = 0; k < dimension; ++k)
    n[k] = std::max(1, static_cast<int>(std::ceil(extent[k] / h - 1e-9)));
  return n;
}

double FieldGrid::cellSize() const {
  double longest = 0;
  for (int k = 0; k < dimension; ++k) longest = std::max(longest, extent[k]);
  return longest / cells_per_axis;
}

std::vector<double> rasteriseDensity(const Snapshot& s, const FieldGrid& grid) {
  const auto n = grid.cells();
  const double h = grid.cellSize();
  std::vector<double> field(static_cast<size_t>(n[0]) * n[1] * n[2], 0.0);
  if (s.size() == 0) return field;
  const double share = 1.0 / s.size();
  for (const auto& p : s.position) {
    // Tent weights on the two nearest cell centres per axis; cells outside clamp to the border.
    std::array<int, 3> base{0, 0, 0};
    std::array<std::array<double, 2>, 3> w{{{1, 0}, {1, 0}, {1, 0}}};
    for (int k = 0; k < grid.dimension; ++k) {
      const double u = p[k] / h - 0.5;
      const double f = std::floor(u);
      base[k] = static_cast<int>(f);
      w[k] = {1 - (u - f), u - f};
    }
    for (int c = 0; c < 2; ++c)
      for (int b = 0; b < (grid.dimension > 1 ? 2 : 1); ++b)
        for (int a = 0; a < 2; ++a) {
          if (grid.dimension < 3 && c > 0) continue;
          const double weight = w[0][a] * w[1][b] * w[2][c];
          if (weight == 0) continue;
          const int i = std::clamp(base[0] + a, 0, n[0] - 1);
          const int j = std::clamp(base[1] + b, 0, n[1] - 1);
          const int l = grid.dimension == 3 ? std::clamp(base[2] + c, 0, n[2] - 1) : 0;
          field[(static_cast<size_t>(l) * n[1] + j) * n[0] + i] += share * weight;
        }
  }
  return field;
}

std::vector<double> heightProfile(const Snapshot& s, const FieldGrid& grid) {
  const auto n = grid.cells();
  const double h = grid.cellSize();
  std::vector<double> height(static_cast<size_t>(n[0]) * n[2], 0.0);
  for (const auto& p : s.position) {
    const int i = std::clamp(static_cast<int>(std::floor(p[0] / h)), 0, n[0] - 1);
    const int l =
        grid.dimension == 3 ? std::clamp(static_cast<int>(std::floor(p[2] / h)), 0, n[2] - 1) : 0;
    double& column = height[static_cast<size_t>(l) * n[0] + i];
    column = std::max(column, static_cast<double>(p[1]));
  }
  return height;
}

double densityFieldError(const Frames& run, const Frames& reference, const FieldGrid& grid) {
  const size_t frames = commonFrameCount(run, reference);
  double total = 0;
  for (size_t f = 0; f < frames; ++f) {
    const auto a = rasteriseDensity(run[f], grid);
    const auto b = rasteriseDensity(reference[f], grid);
    double l1 = 0;
    for (size_t c = 0; c < a.size(); ++c) l1 += std::abs(a[c] - b[c]);
    total += 0.5 * l1;
  }
  return total / frames;
}

double heightProfileError(const Frames& run, const Frames& reference, const FieldGrid& grid) {
  const size_t frames = commonFrameCount(run, reference);
  double total = 0;
  for (size_t f = 0; f < frames; ++f) {
    const auto a = heightProfile(run[f], grid);
    const auto b = heightProfile(reference[f], grid);
    double l1 = 0;
    int occupied = 0;
    for (size_t c = 0; c < a.size(); ++c) {
      if (a[c] == 0 && b[c] == 0) continue;
      l1 += std::abs(a[c] - b[c]);
      ++occupied;
    }
    total += occupied ? l1 / occupied : 0;
  }
  return total / frames;
}

double centreOfMassPathError(const Frames& run, const Frames& reference) {
  const size_t frames = commonFrameCount(run, reference);
  double total = 0;
  for (size_t f = 0; f < frames; ++f)
    total += distance(centreOfMass(run[f]), centreOfMass(reference[f]));
  return total / frames;
}

double ballPastTower(const Frames& frames, double tower_left_x) {
  if (frames.empty()) return 0;
  const auto ball = membersLeftOf(frames.front(), tower_left_x);
  const auto tower = membersRightOf(frames.front(), tower_left_x);
  if (ball.empty() || tower.empty()) return 0;
  double far_face = -1e300;
  for (int i : tower) far_face = std::max(far_face, double(frames.back().position[i][0]));
  return centreOfMass(frames.back(), ball)[0] - far_face;
}

bool thrownBallStaysOutside(const Frames& frames, double tower_left_x) {
  return ballPastTower(frames, tower_left_x) < 0;
}

double pileHeight(const Snapshot& s) {
  if (s.size() == 0) return 0;
  std::vector<float> y(s.size());
  for (int i = 0; i < s.size(); ++i) y[i] = s.position[i][1];
  const size_t k = static_cast<size_t>(0.9 * (y.size() - 1));
  std::nth_element(y.begin(), y.begin() + k, y.end());
  return y[k];
}

bool pileHeightsOrdered(const Snapshot& x2, const Snapshot& x4, const Snapshot& x8) {
  return pileHeight(x2) > pileHeight(x4) && pileHeight(x4) > pileHeight(x8);
}

bool anyNonFinite(const Snapshot& s) {
  for (const auto& p : s.position)
    for (float v : p)
      if (!std::isfinite(v)) return true;
  for (const auto& p : s.velocity)
    for (float v : p)
      if (!std::isfinite(v)) return true;
  return false;
}

bool anyOutside(const Snapshot& s, const Point3& extent, double slack) {
  const int dims = s.grid.dimension;
  for (const auto& p : s.position)
    for (int k = 0; k < dims; ++k)
      if (p[k] < -slack || p[k] > extent[k] + slack) return true;
  return false;
}

namespace {

// Disjoint sets of particle indices, with path halving and union by size.
class DisjointSets {
 public:
  explicit DisjointSets(int n) : parent_(n), size_(n, 1) {
    std::iota(parent_.begin(), parent_.end(), 0);
  }
  int root(int i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  void join(int a, int b) {
    a = root(a), b = root(b);
    if (a == b) return;
    if (size_[a] < size_[b]) std::swap(a, b);
    parent_[b] = a;
    size_[a] += size_[b];
  }

 private:
  std::vector<int> parent_, size_;
};

}  // namespace

ClumpStats findClumps(const Snapshot& s, double link_distance, int min_size) {
  if (!(link_distance > 0)) throw std::invalid_argument("findClumps: link_distance must be > 0");
  if (min_size < 1) throw std::invalid_argument("findClumps: min_size must be >= 1");
  const int n = s.size();
  ClumpStats stats;
  stats.particles = n;
  if (n == 0) return stats;
  // Cells of side link_distance: linked particles lie in the same or a neighbouring cell.
  Point3 low{s.position[0][0], s.position[0][1], s.position[0][2]};
  for (const auto& p : s.position)
    for (int k = 0; k < 3; ++k) low[k] = std::min<double>(low[k], p[k]);
  constexpr int64_t kAxisCells = int64_t(1) << 20;  // a key packs three axes of 21 bits
  auto cellOf = [&](const std::array<float, 3>& p) {
    std::array<int64_t, 3> c;
    for (int k = 0; k < 3; ++k) {
      const double x = std::floor((p[k] - low[k]) / link_distance);
      if (!(x < kAxisCells))
        throw std::invalid_argument("findClumps: positions span too many link distances");
      c[k] = static_cast<int64_t>(x) + 1;  // + 1: a neighbour of cell 0 has a key too
    }
    return c;
  };
  auto key = [](int64_t x, int64_t y, int64_t z) { return uint64_t((x << 42) | (y << 21) | z); };
  // Each cell's particles as a linked list: first particle per cell, next particle per particle.
  std::unordered_map<uint64_t, int> first_in_cell;
  first_in_cell.reserve(n);
  std::vector<int> next(n, -1);
  std::vector<std::array<int64_t, 3>> cell(n);
  for (int p = 0; p < n; ++p) {
    cell[p] = cellOf(s.position[p]);
    auto [it, inserted] = first_in_cell.try_emplace(key(cell[p][0], cell[p][1], cell[p][2]), p);
    if (!inserted) next[p] = std::exchange(it->second, p);
  }
  DisjointSets sets(n);
  const double link2 = link_distance * link_distance;
  for (int p = 0; p < n; ++p) {
    const auto& x = s.position[p];
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto found =
              first_in_cell.find(key(cell[p][0] + dx, cell[p][1] + dy, cell[p][2] + dz));
          if (found == first_in_cell.end()) continue;
          for (int q = found->second; q >= 0; q = next[q]) {
            if (q >= p) continue;  // each pair once
            const auto& y = s.position[q];
            double d2 = 0;
            for (int k = 0; k < 3; ++k) d2 += double(x[k] - y[k]) * double(x[k] - y[k]);
            if (d2 <= link2) sets.join(p, q);
          }
        }
  }
  // Clumps numbered in the order of their first particle, so the labels do not depend on the hash.
  stats.clump_of.assign(n, -1);
  std::vector<int> label_of_root(n, -1);
  for (int p = 0; p < n; ++p) {
    int& label = label_of_root[sets.root(p)];
    if (label < 0) {
      label = stats.clumps++;
      stats.clump_sizes.push_back(0);
    }
    stats.clump_of[p] = label;
    ++stats.clump_sizes[label];
  }
  int clumped = 0, single = 0;
  for (int size : stats.clump_sizes) {
    stats.largest = std::max(stats.largest, size);
    if (size >= min_size) clumped += size, ++stats.chunks;
    if (size == 1) ++single;
  }
  stats.clumped_share = double(clumped) / n;
  stats.single_share = double(single) / n;
  return stats;
}

}  // namespace snowsim
