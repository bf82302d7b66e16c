// The material presets on a small 2D smash into a sticky wall: what each is said to do
// (docs/materials.md) holds at two cells and two seedings, measured with the clumps
// metric of `snowsim clumps`.
#include <gtest/gtest.h>

#include <string>

#include "sim/scene/json_fields.h"
#include "sim/scene/scene.h"
#include "sim/simulation.h"
#include "study/metrics.h"

namespace snowsim {
namespace {

// A ball of radius 0.1 m thrown at 4 m/s into a sticky wall, as the flagship smash, in 2D.
ClumpStats smashAt03s(const std::string& preset, double cell, const std::string& seeding) {
  Json j = Json::parse(R"({"name": "smash2d", "dimension": 2, "solver": "mpm",
    "time": {"dt": 0.002, "duration": 0.3, "fps": 20}, "particles_per_cell": 4, "seed": 2,
    "bodies": [{"shape": "ball", "center": [0.3, 0.2], "radius": 0.1, "velocity": [4, 0]}],
    "colliders": [{"shape": "box", "position": [0.55, 0.2], "size": [0.1, 0.4],
                   "type": "sticky"}]})");
  j["grid"] = {{"cells", {int(0.6 / cell + 0.5), int(0.4 / cell + 0.5)}}, {"cell_size", cell}};
  j["material"] = {{"preset", preset}};
  j["seeding"] = seeding;
  const Scene scene = parseScene(j, "smash2d.json");
  auto simulation = makeSimulation(scene);
  simulation->advanceTo(0.3);
  const Snapshot s = simulation->snapshot(6);
  return findClumps(s, 1.5 * s.grid.particle_spacing, 8);
}

double largestShare(const ClumpStats& c) {
  return double(c.largest) / c.clump_of.size();
}

struct Resolution {
  double cell;
  const char* seeding;
};

class PresetSmash : public ::testing::TestWithParam<Resolution> {};

TEST_P(PresetSmash, ChunkyBreaksIntoChunksWhereWetSnowStaysOnePiece) {
  const auto [cell, seeding] = GetParam();
  const ClumpStats chunky = smashAt03s("chunky", cell, seeding);
  EXPECT_LT(largestShare(chunky), 0.85);
  EXPECT_GT(chunky.chunks, 2) << "pieces beside the largest";
  EXPECT_LT(chunky.single_share, 0.08) << "chunks, not dust";
  const ClumpStats wet = smashAt03s("wet", cell, seeding);
  EXPECT_GT(largestShare(wet), 0.99);
}

INSTANTIATE_TEST_SUITE_P(CellsAndSeedings, PresetSmash,
                         ::testing::Values(Resolution{0.01, "lattice"},
                                           Resolution{0.01, "jittered"},
                                           Resolution{0.005, "lattice"}));

}  // namespace
}  // namespace snowsim
