// Scene files: every kind of bad input gets a message naming the file, the field and what is
// allowed; the generator reproduces the report's particle counts.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "sim/core/errors.h"
#include "sim/scene/sampling.h"
#include "sim/scene/scene.h"
#include "tests/support/temp_dir.h"

// The scene is plain structs: its header keeps the JSON library to itself.
#ifdef NLOHMANN_JSON_VERSION_MAJOR
#error "sim/scene/scene.h includes nlohmann/json"
#endif

namespace snowsim {
namespace {

const std::string kMinimal = R"({
  "name": "test",
  "material": {"preset": "paper"},
  "grid": {"cells": [10, 12], "cell_size": 0.01},
  "bodies": [{"shape": "ball", "center": [0.05, 0.06], "radius": 0.01}]
})";

std::string writeTemp(const std::string& text) {
  static int counter = 0;
  const auto path =
      snowsim_test::processTempDir() / ("scene_" + std::to_string(counter++) + ".json");
  std::ofstream(path) << text;
  return path.string();
}

// The InputError message for a scene text with overrides, or "" when it loads.
std::string errorOf(const std::string& text, const std::vector<std::string>& overrides = {}) {
  const std::string path = writeTemp(text);
  try {
    loadScene(path, overrides);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Scene, MinimalSceneGetsTheReportDefaults) {
  const Scene s = loadScene(writeTemp(kMinimal));
  EXPECT_EQ(s.dimension, 2);
  EXPECT_EQ(s.cells[0], 10);
  EXPECT_EQ(s.cells[1], 12);
  EXPECT_DOUBLE_EQ(s.cell_size, 0.01);
  EXPECT_DOUBLE_EQ(s.dt, 0.001);
  EXPECT_DOUBLE_EQ(s.density_hybrid.flip_alpha, 0.95);
  EXPECT_DOUBLE_EQ(s.density_hybrid.critical_multiplier, 4.0);
  EXPECT_EQ(s.bodies[0].particles_per_cell, 9);
}

// Float where it pays (an explicit 3D step), double elsewhere; the scene's own choice wins.
TEST(Scene, PrecisionDefaultsToFloatForExplicit3D) {
  const auto precision = [](const std::vector<std::string>& overrides) {
    return loadScene(writeTemp(kMinimal), overrides).mpm.precision;
  };
  EXPECT_EQ(precision({"solver=mpm"}), MpmPrecision::Double);
  EXPECT_EQ(precision({"solver=mpm", "dimension=3"}), MpmPrecision::Float);
  EXPECT_EQ(precision({"solver=mpm", "dimension=3", "mpm.integrator=semi_implicit"}),
            MpmPrecision::Double);
  EXPECT_EQ(precision({"solver=mpm", "dimension=3", "mpm.precision=double"}), MpmPrecision::Double);
  EXPECT_EQ(precision({"solver=mpm", "mpm.precision=float"}), MpmPrecision::Float);
  // Asked for both, float and the semi-implicit integrator: the assignment that asked is named.
  const std::string both =
      errorOf(kMinimal, {"solver=mpm", "mpm.integrator=semi_implicit", "mpm.precision=float"});
  EXPECT_NE(both.find("--set mpm.precision=float"), std::string::npos) << both;
  EXPECT_NE(both.find("mpm.precision: \"float\" runs only mpm.integrator \"explicit\""),
            std::string::npos)
      << both;
}

TEST(Scene, MalformedJsonNamesFileLineAndColumn) {
  const std::string message = errorOf("{\n  \"name\": \"x\",\n  \"grid\": {\"cells\": [10 12]}\n}");
  EXPECT_NE(message.find(".json:3:"), std::string::npos) << message;
  EXPECT_NE(message.find("malformed JSON"), std::string::npos) << message;
}

TEST(Scene, UnknownFieldSuggestsTheClosestName) {
  std::string text = kMinimal;
  text.replace(text.find("\"radius\""), 8, "\"raduis\"");
  const std::string message = errorOf(text);
  EXPECT_NE(message.find("bodies[0].raduis: unknown field; did you mean \"radius\"?"),
            std::string::npos)
      << message;
}

TEST(Scene, WrongTypeIsNamed) {
  const std::string message = errorOf(kMinimal, {"time.dt=\"fast\""});
  EXPECT_NE(message.find("time.dt: expected a number, found a string"), std::string::npos)
      << message;
}

// --set time.dt=nan gives the string "nan" (JSON holds no NaN): said to be what it is, also for
// infinities, whole numbers and the elements of a vector.
TEST(Scene, ANonFiniteNumberIsNamedSo) {
  const struct {
    std::string set, says;
  } cases[] = {
      {"time.dt=nan", "time.dt: nan is not a finite number; allowed: (0, 10]"},
      {"time.dt=-Infinity", "time.dt: -Infinity is not a finite number; allowed: (0, 10]"},
      {"time.dt=inf", "time.dt: inf is not a finite number"},
      {"particles_per_cell=nan", "particles_per_cell: nan is not a finite number; allowed: 1 to"},
      {"bodies.0.velocity=[\"nan\", 0]",
       "bodies[0].velocity: nan is not a finite number; allowed: finite numbers"},
  };
  for (const auto& c : cases) {
    const std::string message = errorOf(kMinimal, {c.set});
    EXPECT_NE(message.find(c.says), std::string::npos) << c.set << ": " << message;
  }
}

TEST(Scene, NegativeTimeStepIsOutOfRange) {
  const std::string message = errorOf(kMinimal, {"time.dt=-0.001"});
  EXPECT_NE(message.find("time.dt: -0.001 is out of range; allowed: (0, 10]"), std::string::npos)
      << message;
}

TEST(Scene, HardeningBoundsAreReadAndChecked) {
  const Scene s =
      loadScene(writeTemp(kMinimal), {"material.hardening_min=0.2", "material.hardening_max=5"});
  EXPECT_DOUBLE_EQ(s.material.hardening_min, 0.2);
  EXPECT_DOUBLE_EQ(s.material.hardening_max, 5);
  EXPECT_NE(errorOf(kMinimal, {"material.hardening_min=2"})
                .find("material.hardening_min: 2 is out of range; allowed: [0, 1]"),
            std::string::npos);
  EXPECT_NE(errorOf(kMinimal, {"material.hardening_max=0.5"})
                .find("material.hardening_max: 0.5 is out of range"),
            std::string::npos);
}

TEST(Scene, ViscosityIsReadAndChecked) {
  EXPECT_DOUBLE_EQ(loadScene(writeTemp(kMinimal), {"material.viscosity=16"}).material.viscosity,
                   16);
  EXPECT_DOUBLE_EQ(loadScene(writeTemp(kMinimal)).material.viscosity, 0) << "the paper has none";
  EXPECT_NE(errorOf(kMinimal, {"material.viscosity=-1"})
                .find("material.viscosity: -1 is out of range; allowed: [0, 1e+06]"),
            std::string::npos)
      << errorOf(kMinimal, {"material.viscosity=-1"});
  EXPECT_NE(errorOf(kMinimal, {"solver=mpm", "material.viscosity=16", "mpm.precision=double",
                               "mpm.integrator=semi_implicit"})
                .find("material.viscosity runs only mpm.integrator \"explicit\""),
            std::string::npos);
}

TEST(Scene, BodyOutsideTheGridIsRejected) {
  const std::string message = errorOf(kMinimal, {"bodies.0.center=[0.095,0.06]"});
  EXPECT_NE(message.find("bodies[0].center: the body (its center and radius) reaches outside the "
                         "grid along axis x"),
            std::string::npos)
      << message;
}

TEST(Scene, ZeroCellsAreRejected) {
  const std::string message = errorOf(kMinimal, {"grid.cells=[0,12]"});
  EXPECT_NE(message.find("grid.cells: each entry must be a whole number from 1 to 4096"),
            std::string::npos)
      << message;
}

TEST(Scene, ParticlesPerCellMustFillALattice) {
  const std::string message = errorOf(kMinimal, {"particles_per_cell=8"});
  EXPECT_NE(message.find("particles_per_cell: 8 is not a square"), std::string::npos) << message;
}

TEST(Scene, UnknownSolverListsTheAllowedOnes) {
  const std::string message = errorOf(kMinimal, {"solver=sph"});
  EXPECT_NE(message.find("solver: \"sph\" is not allowed; allowed: \"density_hybrid\""),
            std::string::npos)
      << message;
}

TEST(Scene, OverridesReachNestedFieldsAndArrayElements) {
  const Scene s =
      loadScene(writeTemp(kMinimal), {"time.dt=0.0005", "bodies.0.velocity=[1,2]", "name=renamed"});
  EXPECT_DOUBLE_EQ(s.dt, 0.0005);
  EXPECT_DOUBLE_EQ(s.bodies[0].velocity[1], 2);
  EXPECT_EQ(s.name, "renamed");
  const std::string message = errorOf(kMinimal, {"bodies.3.radius=0.01"});
  EXPECT_NE(message.find("no element 3 (the array has 1)"), std::string::npos) << message;
}

TEST(Scene, OverridesTakeIndicesInBrackets) {
  const Scene s =
      loadScene(writeTemp(kMinimal), {"bodies[0].radius=0.02", "bodies[0].velocity=[1,2]"});
  EXPECT_DOUBLE_EQ(s.bodies[0].radius, 0.02);
  EXPECT_DOUBLE_EQ(s.bodies[0].velocity[1], 2);
  EXPECT_NE(errorOf(kMinimal, {"bodies[3].radius=0.01"}).find("no element 3 (the array has 1)"),
            std::string::npos);
  for (const char* bad : {"bodies[0.radius=1", "bodies]0[.radius=1", "bodies..radius=1", ".dt=1"})
    EXPECT_NE(errorOf(kMinimal, {bad}).find(std::string("--set ") + bad), std::string::npos) << bad;
}

// An invalid value set by --set is blamed on the assignment (the last one to the field, or to an
// object holding it); a bad value in the file is blamed on the file alone.
TEST(Scene, ErrorsOfAnOverrideNameTheAssignment) {
  std::string message = errorOf(kMinimal, {"time.dt=-0.001"});
  EXPECT_EQ(message.rfind("--set time.dt=-0.001 on ", 0), 0u) << message;
  EXPECT_NE(message.find("time.dt: -0.001 is out of range; allowed: (0, 10]"), std::string::npos)
      << message;

  message = errorOf(kMinimal, {"time.dt=-1", "name=x", "time.dt=-2"});
  EXPECT_NE(message.find("--set time.dt=-2 on"), std::string::npos) << message;
  message = errorOf(kMinimal, {R"(time={"dt": -1})"});
  EXPECT_NE(message.find(R"(--set time={"dt": -1} on)"), std::string::npos) << message;
  message = errorOf(kMinimal, {"bodies[0].raduis=0.01"});
  EXPECT_NE(message.find("--set bodies[0].raduis=0.01 on"), std::string::npos) << message;
  EXPECT_NE(message.find("bodies[0].raduis: unknown field; did you mean \"radius\"?"),
            std::string::npos)
      << message;

  std::string text = kMinimal;
  text.replace(text.find("\"cell_size\": 0.01"), 17, "\"cell_size\": -1");
  message = errorOf(text, {"time.dt=0.002"});
  EXPECT_NE(message.find("grid.cell_size: -1 is out of range"), std::string::npos) << message;
  EXPECT_EQ(message.find("--set"), std::string::npos) << message;
}

// A default particle count that fills no lattice is the top level's fault, not the body's.
TEST(Scene, DefaultParticlesPerCellIsBlamedWhereItIsWritten) {
  const std::string message = errorOf(kMinimal, {"particles_per_cell=8"});
  EXPECT_NE(message.find(": particles_per_cell: 8 is not a square"), std::string::npos) << message;
  EXPECT_EQ(message.find("bodies[0]"), std::string::npos) << message;
}

TEST(Scene, OverridesFieldSeesTheFieldItsParentsAndItsParts) {
  const std::vector<std::string> set = {"grid.cell_size=0.005", "mpm={}", "bodies[0].radius=1",
                                        "time.dt.x=1"};
  EXPECT_TRUE(overridesField(set, "grid.cell_size"));
  EXPECT_FALSE(overridesField(set, "grid.cells"));
  EXPECT_FALSE(overridesField(set, "grid.cell"));
  EXPECT_TRUE(overridesField(set, "mpm.cfl"));
  EXPECT_TRUE(overridesField(set, "bodies.0.radius"));
  EXPECT_FALSE(overridesField(set, "bodies.1.radius"));
  EXPECT_TRUE(overridesField(set, "time.dt"));
  EXPECT_FALSE(overridesField(set, "time.duration"));
}

TEST(Scene, RenderObjectIsParsedWithTheScene) {
  std::string text = kMinimal;
  text.insert(text.rfind('}'), R"(, "render": {"width": 640, "color_by": "speed", "grid": false,
    "camera": {"eye": [0.1, 0.3, 0.4], "target": [0.1, 0.05, 0.1], "fov": 50}})");
  const Scene s = loadScene(writeTemp(text));
  EXPECT_EQ(s.render.width, 640);
  EXPECT_FALSE(s.render.height.has_value());
  EXPECT_EQ(s.render.color_by, "speed");
  EXPECT_EQ(s.render.grid, false);
  EXPECT_FALSE(s.render.density_cells.has_value());
  ASSERT_TRUE(s.render.camera.has_value());
  EXPECT_DOUBLE_EQ(s.render.camera->eye[1], 0.3);
  EXPECT_DOUBLE_EQ(s.render.camera->up[1], 1);
  EXPECT_EQ(s.render.camera->fov, 50);
  EXPECT_FALSE(loadScene(writeTemp(kMinimal)).render.camera.has_value());

  EXPECT_NE(errorOf(kMinimal, {"render.widht=100"})
                .find("render.widht: unknown field; did you mean \"width\"?"),
            std::string::npos);
  EXPECT_NE(errorOf(kMinimal, {"render.width=8"})
                .find("render.width: 8 is out of range; allowed: 16 to 8192"),
            std::string::npos);
  EXPECT_NE(errorOf(kMinimal, {"render.color_by=temperature"})
                .find(R"(render.color_by: "temperature" is not allowed; allowed: "white")"),
            std::string::npos);
  EXPECT_NE(errorOf(kMinimal, {R"(render.camera={"eye": [1, 1, 1], "target": [1, 1, 1]})"})
                .find("render.camera.target: must differ from eye"),
            std::string::npos);
  EXPECT_NE(errorOf(kMinimal, {R"(render.camera={"eye": [1, 1, 1]})"})
                .find("render.camera.target: missing"),
            std::string::npos);
  EXPECT_NE(errorOf(kMinimal, {R"(render.camera={"eye": [1, 1, 1], "target": [0, 0, 0]})",
                               "render.camera.fov=180"})
                .find("render.camera.fov: 180 is out of range; allowed: (0, 180)"),
            std::string::npos);
}

// The checkpoint cadence: optional, each field checked, the file and field named.
TEST(Scene, OutputObjectSetsTheCheckpointCadence) {
  EXPECT_FALSE(loadScene(writeTemp(kMinimal)).output.checkpoint_minutes.has_value());
  std::string text = kMinimal;
  text.insert(text.rfind('}'),
              R"(, "output": {"checkpoint_minutes": 0.5, "checkpoint_every_frames": 10})");
  const Scene s = loadScene(writeTemp(text));
  EXPECT_EQ(s.output.checkpoint_minutes, 0.5);
  EXPECT_EQ(s.output.checkpoint_every_frames, 10);

  std::string negative = kMinimal;
  negative.insert(negative.rfind('}'), R"(, "output": {"checkpoint_minutes": -1})");
  const std::string path = writeTemp(negative);
  std::string message;
  try {
    loadScene(path);
  } catch (const InputError& e) {
    message = e.what();
  }
  EXPECT_NE(message.find(path + ": output.checkpoint_minutes: -1 is out of range; allowed: "),
            std::string::npos)
      << message;
  EXPECT_NE(errorOf(kMinimal, {"output.checkpoint_every_frames=2.5"})
                .find("output.checkpoint_every_frames: "),
            std::string::npos);
  EXPECT_NE(errorOf(kMinimal, {"output.checkpoint_every_frames=-3"})
                .find("output.checkpoint_every_frames: -3 is out of range; allowed: 0 to 1000000"),
            std::string::npos);
  EXPECT_NE(errorOf(kMinimal, {"output.checkpoint_minute=3"})
                .find("output.checkpoint_minute: unknown field; did you mean "
                      "\"checkpoint_minutes\"?"),
            std::string::npos);
}

TEST(Scene, RenderLookBackgroundShadowsAndOcclusion) {
  const Scene s =
      loadScene(writeTemp(kMinimal), {"render.look=figure", "render.background=[1, 0.5, 0]",
                                      "render.shadows=false", "render.occlusion=true"});
  EXPECT_EQ(s.render.look, "figure");
  ASSERT_TRUE(s.render.background.has_value());
  EXPECT_DOUBLE_EQ((*s.render.background)[1], 0.5);
  EXPECT_EQ(s.render.shadows, false);
  EXPECT_EQ(s.render.occlusion, true);
  EXPECT_FALSE(loadScene(writeTemp(kMinimal)).render.look.has_value());

  EXPECT_NE(
      errorOf(kMinimal, {"render.look=noir"})
          .find(R"(render.look: "noir" is not allowed; allowed: "studio", "figure", "surface")"),
      std::string::npos);
  EXPECT_NE(errorOf(kMinimal, {"render.background=[1, 2, 0]"})
                .find("render.background: each of red, green, blue must be in [0, 1]"),
            std::string::npos);
  EXPECT_NE(errorOf(kMinimal, {"render.background=[1, 0]"}).find("render.background"),
            std::string::npos);
  EXPECT_NE(errorOf(kMinimal, {"render.shadows=3"}).find("render.shadows"), std::string::npos);
}

TEST(Scene, RenderCameraPresetAndColourRange) {
  std::string text = kMinimal;
  text.insert(text.rfind('}'), R"(, "render": {"camera": {"preset": "side", "fov": 40},
    "color_range": [0, 3.5]})");
  const Scene s = loadScene(writeTemp(text));
  ASSERT_TRUE(s.render.camera.has_value());
  EXPECT_EQ(s.render.camera->preset, "side");
  EXPECT_EQ(s.render.camera->fov, 40);
  ASSERT_TRUE(s.render.color_range.has_value());
  EXPECT_DOUBLE_EQ((*s.render.color_range)[1], 3.5);

  EXPECT_NE(errorOf(kMinimal, {R"(render.camera={"preset": "below"})"})
                .find(R"(render.camera.preset: "below" is not allowed; allowed: "front")"),
            std::string::npos);
  EXPECT_NE(errorOf(kMinimal, {R"(render.camera={"preset": "top", "eye": [1, 1, 1]})"})
                .find("render.camera.eye: a camera has a preset or is placed"),
            std::string::npos);
  EXPECT_NE(errorOf(kMinimal, {"render.color_range=[2, 1]"})
                .find("render.color_range: must be [low, high] with low < high"),
            std::string::npos);
}

// Typed changes keep every digit: a third of a centimetre halved is exactly half of it.
TEST(Scene, RefiningTheGridKeepsTheDomainAndEveryDigit) {
  const double h = 0.01 / 3;
  char cell_size[64];
  std::snprintf(cell_size, sizeof cell_size, "grid.cell_size=%.17g", h);
  Scene s = loadScene(writeTemp(kMinimal),
                      {"grid.cells=[30,36]", cell_size, "dimension=3", "grid.depth_cells=2"});
  ASSERT_EQ(s.cell_size, h);
  const Vec3 extent = s.extent();
  refineGrid(s, 2);
  EXPECT_EQ(s.cell_size, h / 2);
  EXPECT_EQ(s.cells[0], 60);
  EXPECT_EQ(s.cells[1], 72);
  EXPECT_EQ(s.cells[2], 2) << "a 2D scene's slab keeps its depth in cells";
  EXPECT_EQ(s.extent()[0], extent[0]);
  EXPECT_EQ(s.extent()[1], extent[1]);
  EXPECT_THROW(refineGrid(s, 100), InputError);
}

// Scaling keeps the domain along every axis the scene runs in, a 2D scene's slab depth included,
// and refuses a factor that leaves a fraction of a cell.
TEST(Scene, ScalingTheGridKeepsTheDomainAlongEveryAxis) {
  Scene s = loadScene(writeTemp(kMinimal), {"dimension=3", "grid.depth_cells=2"});
  const Vec3 extent = s.extent();
  scaleGrid(s, 1.5);
  EXPECT_EQ(s.cells[0], 15);
  EXPECT_EQ(s.cells[1], 18);
  EXPECT_EQ(s.cells[2], 3);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(s.extent()[a], extent[a], 1e-15) << a;
  scaleGrid(s, 1.0 / 3);
  EXPECT_EQ(s.cells[0], 5);
  EXPECT_EQ(s.cells[2], 1);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(s.extent()[a], extent[a], 1e-15) << a;

  for (const double bad : {1.1, 0.0, -2.0, 1000.0}) {
    Scene t = loadScene(writeTemp(kMinimal));
    try {
      scaleGrid(t, bad);
      ADD_FAILURE() << bad << " leaves no whole grid";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("grid.cells: "), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("allowed: a whole number from 1 to 4096"),
                std::string::npos)
          << e.what();
    }
    EXPECT_EQ(t.cells[0], 10) << "a refused factor changes nothing";
  }
}

TEST(Scene, ParticlesPerCellChangesTheBodiesWithoutTheirOwn) {
  std::string text = kMinimal;
  text.replace(text.find("}]"), 2,
               R"(}, {"shape": "box", "center": [0.05, 0.02], "size": [0.02, 0.02],
                       "particles_per_cell": 16}])");
  Scene s = loadScene(writeTemp(text));
  EXPECT_FALSE(s.bodies[0].own_particles_per_cell);
  EXPECT_TRUE(s.bodies[1].own_particles_per_cell);
  setParticlesPerCell(s, 4);
  EXPECT_EQ(s.particles_per_cell, 4);
  EXPECT_EQ(s.bodies[0].particles_per_cell, 4);
  EXPECT_EQ(s.bodies[1].particles_per_cell, 16);
  try {
    setParticlesPerCell(s, 8);
    ADD_FAILURE() << "8 fills no 2D lattice";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("particles_per_cell: 8 is not a square"),
              std::string::npos)
        << e.what();
  }
}

TEST(Scene, ThreeDimensionalScenesCannotRunIn2D) {
  const std::string message = errorOf(R"({"name": "t", "grid": {"cells": [4, 4, 4]},
                  "bodies": [{"shape": "ball", "center": [0.02, 0.02, 0.02], "radius": 0.01}]})");
  EXPECT_NE(message.find("grid.cells: has 3 entries but the scene's dimension is 2"),
            std::string::npos)
      << message;
}

TEST(Scene, CollidersMoveByVelocitiesOrByKeyframes) {
  const std::string keyed = R"({"name": "t", "grid": {"cells": [10, 12], "cell_size": 0.01},
    "bodies": [{"shape": "ball", "center": [0.05, 0.06], "radius": 0.01}],
    "colliders": [{"shape": "box", "size": [0.02, 0.01], "keyframes": [
      {"time": 0, "position": [0.02, 0.02]}, {"time": 1, "position": [0.08, 0.02], "rotation": 45}
    ]}]})";
  const Scene scene = loadScene(writeTemp(keyed));
  ASSERT_EQ(scene.colliders[0].keyframes.size(), 2u);
  EXPECT_EQ(scene.colliders[0].keyframes[1].rotation, (Vec3{0, 0, 45}));  // 2D: about z
  EXPECT_EQ(scene.colliders[0].position, (Vec3{0.02, 0.02, 0}));          // the first key's

  const std::pair<std::string, std::string> mistakes[] = {
      {"colliders.0.keyframes.1.time=0",
       "colliders[0].keyframes[1].time: must be later than the key before"},
      {"colliders.0.velocity=[1,0]", "colliders[0].velocity: cannot be given with keyframes"},
      {"colliders.0.keyframes=[]", "colliders[0].keyframes: must hold at least one key"},
      {"colliders.0.keyframes.0.rotation=[0,0,45]",
       "colliders[0].keyframes[0].rotation: expected a number"},
      {"colliders.0.shape=\"drum\"", "colliders[0].radius"}};
  for (const auto& [assignment, expected] : mistakes) {
    const std::string message = errorOf(keyed, {assignment});
    EXPECT_NE(message.find(expected), std::string::npos) << assignment << ": " << message;
  }
}

// Table 1 of the report: particle counts on its 10x12x1 grid at 27 particles per cell.
struct TableRow {
  const char* scene;
  int report_count;
};

class Table1Counts : public ::testing::TestWithParam<TableRow> {};

TEST_P(Table1Counts, SlabReproducesTheReportWithinFivePercent) {
  const TableRow row = GetParam();
  const std::string path = std::string(SNOWSIM_SOURCE_DIR) + "/scenes/" + row.scene + ".json";
  const Scene slab = loadScene(path, {"dimension=3"});
  ASSERT_EQ(slab.cells[2], 1);
  const int count = sampleBodies<3>(slab).size();
  EXPECT_NEAR(count, row.report_count, 0.05 * row.report_count) << row.scene;

  // The same scene in true 2D has a third of the particles: one lattice layer instead of three.
  const Scene flat = loadScene(path);
  EXPECT_EQ(3 * sampleBodies<2>(flat).size(), count) << row.scene;
}

INSTANTIATE_TEST_SUITE_P(Report, Table1Counts,
                         ::testing::Values(TableRow{"snowball_drop", 76},
                                           TableRow{"snow_column", 216},
                                           TableRow{"column_with_ball", 290},
                                           TableRow{"column_thrown_ball", 290},
                                           TableRow{"column_thrown_half_ball", 290},
                                           TableRow{"colliding_snowballs", 148}),
                         [](const auto& info) { return std::string(info.param.scene); });

TEST(Scene, EveryShippedSceneLoads) {
  int scenes = 0;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::string(SNOWSIM_SOURCE_DIR) + "/scenes")) {
    if (entry.path().extension() != ".json" || entry.path().stem() == "figures") continue;
    EXPECT_NO_THROW(loadScene(entry.path().string())) << entry.path();
    ++scenes;
  }
  EXPECT_GE(scenes, 12);
}

const std::string kBall3d = R"({
  "name": "ball3d", "dimension": 3,
  "grid": {"cells": [10, 10, 10], "cell_size": 0.01},
  "particles_per_cell": 8,
  "bodies": [{"shape": "ball", "center": [0.05, 0.05, 0.05], "radius": 0.03}]
})";

// 3D scenes are seeded jittered by default: each particle at a random point of its lattice cell,
// the same for the same seed, inside the body, as many as the lattice gives (to a few percent),
// the offsets spread evenly over the cell.
TEST(Scene, JitteredSeedingIsRepeatableAndStaysInItsCells) {
  const std::string path = writeTemp(kBall3d);
  const Scene scene = loadScene(path);
  EXPECT_EQ(scene.bodies[0].seeding, Seeding::Jittered);
  const Particles<3> a = sampleBodies<3>(scene), b = sampleBodies<3>(loadScene(path));
  EXPECT_EQ(a.x, b.x) << "the same seed, the same particles";
  const Particles<3> other = sampleBodies<3>(loadScene(path, {"seed=2"}));
  EXPECT_NE(a.x, other.x);
  const Scene lattice_scene = loadScene(path, {"seeding=lattice"});
  EXPECT_EQ(lattice_scene.bodies[0].seeding, Seeding::Lattice);
  const Particles<3> lattice = sampleBodies<3>(lattice_scene);
  EXPECT_NEAR(a.size(), lattice.size(), 0.03 * lattice.size());

  const double spacing = particleSpacing(scene, scene.bodies[0]);
  double sum = 0, squares = 0;
  for (const auto& x : a.x) {
    EXPECT_TRUE(bodyContains(scene.bodies[0], {x[0], x[1], x[2]}, 3));
    for (int axis = 0; axis < 3; ++axis) {
      const double u = x[axis] / spacing - std::floor(x[axis] / spacing) - 0.5;
      sum += u;
      squares += u * u;
    }
  }
  const double n = 3.0 * a.size();
  EXPECT_NEAR(sum / n, 0, 0.02) << "offsets centred in the cell";
  EXPECT_NEAR(squares / n, 1.0 / 12, 0.01) << "spread as a uniform over the cell";

  EXPECT_EQ(loadScene(writeTemp(kMinimal)).bodies[0].seeding, Seeding::Lattice) << "2D: lattice";
  EXPECT_NE(errorOf(kBall3d, {"bodies.0.seeding=random"})
                .find(R"(bodies[0].seeding: "random" is not allowed; allowed: "lattice")"),
            std::string::npos);
}

// Poisson-disk seeding: the same particles for the same seed (it is sequential, so no thread count
// or rank can change it), inside the body, no two closer than the disk radius, as many as the
// ball's volume holds at the lattice's density to 3%, and the body's mass that of its lattice.
template <int D>
void expectPoissonDiskBody(const std::string& text, double ball_volume) {
  const std::string path = writeTemp(text);
  const Scene scene = loadScene(path, {"bodies.0.seeding=poisson"});
  const Body& body = scene.bodies[0];
  ASSERT_EQ(body.seeding, Seeding::Poisson);
  const Particles<D> a = sampleBodies<D>(scene);
  EXPECT_EQ(a.x, sampleBodies<D>(loadScene(path, {"bodies.0.seeding=poisson"})).x);
  EXPECT_NE(a.x, sampleBodies<D>(loadScene(path, {"bodies.0.seeding=poisson", "seed=2"})).x);

  const double spacing = particleSpacing(scene, body);
  const double expected_count = ball_volume / std::pow(spacing, D);
  EXPECT_NEAR(a.size(), expected_count, 0.03 * expected_count);

  const Particles<D> lattice = sampleBodies<D>(loadScene(path, {"bodies.0.seeding=lattice"}));
  double mass = 0, lattice_mass = 0;
  for (double m : a.mass) mass += m;
  for (double m : lattice.mass) lattice_mass += m;
  EXPECT_NEAR(mass, lattice_mass, 1e-12 * lattice_mass) << "the lattice's mass";
  EXPECT_NEAR(mass, body.density * ball_volume, 0.03 * body.density * ball_volume);

  // Closest pair by brute force: Bridson's points keep at least 0.78 spacings apart, the
  // lattice's one spacing, a uniform random set of this size would have pairs far closer.
  double closest = 1e300;
  for (int i = 0; i < a.size(); ++i) {
    Vec3 p{0, 0, 0};
    for (int k = 0; k < D; ++k) p[k] = a.x[i][k];
    EXPECT_TRUE(bodyContains(body, p, D));
    for (int j = i + 1; j < a.size(); ++j) closest = std::min(closest, (a.x[i] - a.x[j]).norm());
  }
  EXPECT_GE(closest, 0.78 * spacing);
  EXPECT_LT(closest, 0.9 * spacing) << "not a lattice";
}

TEST(Scene, PoissonDiskSeedingFillsTheBodyWithItsMass) {
  expectPoissonDiskBody<3>(kBall3d, 4.0 / 3 * M_PI * std::pow(0.03, 3));
  expectPoissonDiskBody<2>(R"({
    "name": "disk", "grid": {"cells": [10, 10], "cell_size": 0.01}, "particles_per_cell": 9,
    "bodies": [{"shape": "ball", "center": [0.05, 0.05], "radius": 0.04}]
  })",
                           M_PI * 0.04 * 0.04);
}

// A Poisson-disk body too small to hold a lattice point has no mass to share: it holds no
// particle (and is refused), whatever points the disks put inside it, never particles of no mass.
TEST(Scene, APoissonDiskBodyWithoutLatticePointsHoldsNoParticle) {
  // Radius 0.45 spacings about a lattice cell's corner: the nearest points are 0.71 away.
  const std::string path = writeTemp(R"({
    "name": "speck", "grid": {"cells": [10, 10], "cell_size": 0.01}, "particles_per_cell": 9,
    "bodies": [{"shape": "ball", "center": [0.05, 0.05], "radius": 0.0015, "seeding": "poisson"}]
  })");
  for (int seed = 1; seed <= 40; ++seed) {
    const Scene scene = loadScene(path, {"seed=" + std::to_string(seed)});
    try {
      const Particles<2> particles = sampleBodies<2>(scene);
      ADD_FAILURE() << "seed " << seed << ": " << particles.size()
                    << " particle(s), the first of mass " << particles.mass[0];
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("bodies[0] holds no particles"), std::string::npos)
          << e.what();
    }
  }
}

TEST(Scene, SeedingIsChosenPerBodyAndChecked) {
  const Scene scene = loadScene(writeTemp(kBall3d), {"seeding=poisson"});
  EXPECT_EQ(scene.seeding, Seeding::Poisson);
  EXPECT_EQ(scene.bodies[0].seeding, Seeding::Poisson) << "the scene's default";
  EXPECT_EQ(loadScene(writeTemp(kBall3d), {"seeding=poisson", "bodies.0.seeding=lattice"})
                .bodies[0]
                .seeding,
            Seeding::Lattice);
  EXPECT_NE(
      errorOf(kBall3d, {"bodies.0.seeding=poison"})
          .find(
              R"(bodies[0].seeding: "poison" is not allowed; allowed: "lattice", "jittered", "poisson")"),
      std::string::npos)
      << errorOf(kBall3d, {"bodies.0.seeding=poison"});
}

}  // namespace
}  // namespace snowsim
