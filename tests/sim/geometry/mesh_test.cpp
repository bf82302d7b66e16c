// Meshes as bodies and colliders: loading and checking mesh files, their signed distance, the
// snow that fills them, and snow resting on a mesh collider as on the analytic box it matches.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <string>

#include "sim/core/errors.h"
#include "sim/geometry/level_set.h"
#include "sim/geometry/triangle_mesh.h"
#include "sim/mpm/mpm_solver.h"
#include "sim/scene/json_fields.h"
#include "sim/scene/sampling.h"
#include "sim/scene/scene.h"
#include "sim/scene/scene_colliders.h"
#include "tests/support/temp_dir.h"

using namespace snowsim;
namespace fs = std::filesystem;

namespace {

const std::string kMeshes = std::string(SNOWSIM_SOURCE_DIR) + "/scenes/meshes/";

fs::path tempDir() {
  const fs::path dir = snowsim_test::processTempDir() / "mesh";
  fs::create_directories(dir);
  return dir;
}

fs::path writeFile(const std::string& name, const std::string& text) {
  const fs::path path = tempDir() / name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// The unit cube's OBJ text without its last `drop` faces.
std::string cubeObj(int drop = 0) {
  std::ifstream in(kMeshes + "cube.obj");
  std::string line, text;
  std::vector<std::string> faces;
  while (std::getline(in, line)) {
    if (line.rfind("f ", 0) == 0)
      faces.push_back(line);
    else
      text += line + "\n";
  }
  for (size_t f = 0; f + drop < faces.size(); ++f) text += faces[f] + "\n";
  return text;
}

// A 3D scene with one body filling `mesh` (a path) at `position`, scaled.
Json meshScene(const std::string& mesh, double scale, std::array<double, 3> position) {
  return Json{
      {"name", "mesh"},
      {"dimension", 3},
      {"solver", "mpm"},
      {"grid", {{"cells", {20, 20, 20}}, {"cell_size", 0.01}}},
      {"particles_per_cell", 27},
      {"bodies", {{{"shape", "mesh"}, {"mesh", mesh}, {"position", position}, {"scale", scale}}}}};
}

std::string errorOf(const Json& scene) {
  try {
    parseScene(scene, (tempDir() / "scene.json").string());
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(TriangleMesh, TheShippedMeshesAreClosedAndFaceOutwards) {
  for (const char* name : {"cube.obj", "sphere.obj", "rock.obj", "torus.stl"}) {
    const TriangleMesh mesh = loadTriangleMesh(kMeshes + name);
    EXPECT_GT(mesh.signedVolume(), 0) << name;
  }
  EXPECT_DOUBLE_EQ(loadTriangleMesh(kMeshes + "cube.obj").signedVolume(), 1);
  // The icosphere is inscribed in the unit sphere: a little less than 4 pi / 3.
  EXPECT_NEAR(loadTriangleMesh(kMeshes + "sphere.obj").signedVolume(), 4 * M_PI / 3, 0.03 * 4);
  // The torus: 2 pi^2 R r^2 with R = 0.35, r = 0.15, less what its 32 x 16 polygons cut off.
  EXPECT_NEAR(loadTriangleMesh(kMeshes + "torus.stl").signedVolume(),
              2 * M_PI * M_PI * 0.35 * 0.15 * 0.15, 0.05 * 0.155);
}

TEST(TriangleMesh, PlacementScalesThenRotatesThenMoves) {
  TriangleMesh point;
  point.vertices = {{1, 0, 0}};
  // 90 degrees about z takes x to y; then about nothing else.
  const auto p = placed(point, {{1, 2, 3}, {0, 0, 90}, 2}).vertices[0];
  EXPECT_NEAR(p[0], 1, 1e-12);
  EXPECT_NEAR(p[1], 4, 1e-12);
  EXPECT_NEAR(p[2], 3, 1e-12);
  // x first, then y: (0, 1, 0) about x by 90 is (0, 0, 1), about y by 90 is (1, 0, 0).
  point.vertices = {{0, 1, 0}};
  const auto q = placed(point, {{0, 0, 0}, {90, 90, 0}, 1}).vertices[0];
  EXPECT_NEAR(q[0], 1, 1e-12);
  EXPECT_NEAR(q[1], 0, 1e-12);
  EXPECT_NEAR(q[2], 0, 1e-12);
}

// The 84 bytes that open a binary STL of `triangles` triangles; its text starts with "solid", as
// some exporters write it.
std::string binaryStlHeader(std::uint32_t triangles) {
  std::string header = "solid exported";
  header.resize(80, ' ');
  for (int b = 0; b < 4; ++b) header += char((triangles >> (8 * b)) & 0xff);
  return header;
}

// The unit tetrahedron's four faces, outward, as corner indices into kTetrahedron.
constexpr std::array<std::array<float, 3>, 4> kTetrahedron = {
    {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
constexpr int kTetrahedronFaces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};

// Each bad mesh stops the scene with the mesh file named and what is wrong with it.

TEST(TriangleMesh, BadMeshesAreRefusedNamingTheFileAndTheProblem) {
  struct Case {
    std::string file, text, problem;
  };
  const std::vector<Case> cases = {
      {"garbage.obj", std::string("\x7f\x01\x02 not a mesh \xff\xfe\n", 18),
       "the mesh has no triangles"},
      {"garbage.stl", "solid x\nthis is not\nendsolid\n", "cannot read it as a mesh"},
      {"open.obj", cubeObj(1), "not watertight: 3 edge(s) belong to one triangle only"},
      {"empty.obj", "", "the file is empty"},
      {"no_faces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", "the mesh has no triangles"},
      {"degenerate.obj", cubeObj() + "v 2 2 2\nv 3 3 3\nv 4 4 4\nf 9 10 11\n", "degenerate"},
      {"nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
       "a vertex is at (nan, 0, 0): each coordinate must be a finite number between -1e9 and 1e9"},
      {"huge.obj", "v 1e30 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "is at (1e+30, 0, 0)"},
      // Cut short: a binary STL whose header counts 12 triangles and holds 2, one shorter than
      // its header; and a file that is no STL.
      {"cut.stl", binaryStlHeader(12) + std::string(100, '\0'),
       "a binary STL of 12 triangles (its header's count) takes 84 + 50 x 12 = 684 bytes and the "
       "file has 184: it ends early"},
      {"stub.stl", std::string(60, '\0'), "a binary STL starts with an 84-byte header"},
      {"page.stl", "<html><body>" + std::string(200, '\x01') + "</body></html>",
       "neither an ASCII STL (text starting with \"solid\") nor a binary STL"},
  };
  for (const Case& c : cases) {
    const fs::path path = writeFile(c.file, c.text);
    const std::string error = errorOf(meshScene(path.string(), 0.05, {0.1, 0.1, 0.1}));
    EXPECT_NE(error.find(path.string()), std::string::npos) << c.file << ": " << error;
    EXPECT_NE(error.find("bodies[0].mesh"), std::string::npos) << c.file << ": " << error;
    EXPECT_NE(error.find(c.problem), std::string::npos) << c.file << ": " << error;
  }
  const std::string missing = errorOf(meshScene("no_such.obj", 1, {0.1, 0.1, 0.1}));
  EXPECT_NE(missing.find("no_such.obj: no such mesh file"), std::string::npos) << missing;
  const std::string folder = errorOf(meshScene(kMeshes, 1, {0.1, 0.1, 0.1}));
  EXPECT_NE(folder.find("meshes/: is a directory; give a mesh file"), std::string::npos) << folder;
  // Larger than the 0.2 m grid: the unit cube at scale 0.3.
  const std::string large = errorOf(meshScene(kMeshes + "cube.obj", 0.3, {0.1, 0.1, 0.1}));
  EXPECT_NE(large.find("bodies[0].scale"), std::string::npos) << large;
  EXPECT_NE(large.find("cube.obj: the mesh is larger than the grid: 0.3 m along x"),
            std::string::npos)
      << large;
  const std::string outside = errorOf(meshScene(kMeshes + "cube.obj", 0.1, {0.02, 0.1, 0.1}));
  EXPECT_NE(outside.find("bodies[0].position"), std::string::npos) << outside;
  EXPECT_NE(outside.find("reaches outside the grid along axis x"), std::string::npos) << outside;
  Json flat = meshScene(kMeshes + "cube.obj", 0.05, {0.1, 0.1, 0.1});
  flat["dimension"] = 2;
  flat["grid"]["cells"] = {20, 20};
  flat["bodies"][0]["position"] = {0.1, 0.1};
  EXPECT_NE(errorOf(flat).find("\"mesh\" needs a 3D scene"), std::string::npos) << errorOf(flat);
}

// STL files as exporters write them load: binary with a header starting "solid", ASCII with a
// byte-order mark, CRLF line ends, trailing blank lines and an upper-case extension.
TEST(TriangleMesh, StlFilesOfEitherKindLoad) {
  std::string binary = binaryStlHeader(4);
  for (const auto& face : kTetrahedronFaces) {
    binary += std::string(12, '\0');  // the normal, which the loader does not read
    for (const int corner : face)
      binary.append(reinterpret_cast<const char*>(kTetrahedron[corner].data()), 12);
    binary += std::string(2, '\0');
  }
  std::string ascii = "\xEF\xBB\xBFsolid tetrahedron\r\n";
  for (const auto& face : kTetrahedronFaces) {
    ascii += "facet normal 0 0 0\r\nouter loop\r\n";
    for (const int corner : face)
      ascii += "vertex " + std::to_string(kTetrahedron[corner][0]) + " " +
               std::to_string(kTetrahedron[corner][1]) + " " +
               std::to_string(kTetrahedron[corner][2]) + "\r\n";
    ascii += "endloop\r\nendfacet\r\n";
  }
  ascii += "endsolid tetrahedron\r\n" + std::string(300, '\n');
  for (const auto& [file, text] : {std::pair{"binary.stl", binary}, {"ascii.STL", ascii}}) {
    const fs::path path = writeFile(file, text);
    EXPECT_EQ(errorOf(meshScene(path.string(), 0.05, {0.1, 0.1, 0.1})), "") << file;
    EXPECT_EQ(loadTriangleMesh(path.string()).triangles.size(), 4u) << file;
  }
}

// A body that holds no particles is refused before the run writes anything: one narrower than
// its particle spacing as the scene runs (a mesh in millimetres read as metres), naming the
// field; a thin plate turned across the axes, as wide as it likes along them, when it is filled.
TEST(TriangleMesh, ABodyThatHoldsNoParticlesIsRefused) {
  const auto narrowError = [](const Json& json) -> std::string {
    try {
      refuseBodiesNarrowerThanTheirParticles(parseScene(json, (tempDir() / "scene.json").string()));
    } catch (const FieldError& e) {
      return e.what();
    }
    return "";
  };
  // 27 particles a cell of 0.01 m: a spacing of 0.0033 m; the unit cube at 0.003 m is narrower.
  const std::string tiny = narrowError(meshScene(kMeshes + "cube.obj", 0.003, {0.1, 0.1, 0.1}));
  EXPECT_NE(tiny.find("bodies[0].scale: the body is 0.003 m across along x, less than its "
                      "particle spacing of 0.00333333 m"),
            std::string::npos)
      << tiny;
  EXPECT_EQ(narrowError(meshScene(kMeshes + "cube.obj", 0.004, {0.1, 0.1, 0.1})), "");
  // A box 4 mm thick holds particles 3.3 mm apart, not 5 mm apart (8 a cell).
  Json box = meshScene(kMeshes + "cube.obj", 0.05, {0.1, 0.1, 0.1});
  box["bodies"][0] = {{"shape", "box"}, {"center", {0.1, 0.1, 0.1}}, {"size", {0.1, 0.004, 0.1}}};
  EXPECT_EQ(narrowError(box), "");
  box["particles_per_cell"] = 8;
  EXPECT_NE(narrowError(box).find("bodies[0].size: the body is 0.004 m across along y"),
            std::string::npos)
      << narrowError(box);
  Json ball = box;
  ball["bodies"][0] = {{"shape", "ball"}, {"center", {0.1, 0.1, 0.1}}, {"radius", 0.001}};
  EXPECT_NE(narrowError(ball).find("bodies[0].radius: the body is 0.002 m across along x"),
            std::string::npos)
      << narrowError(ball);
  // A plate 1 micrometre thick turned 45 degrees about z: 0.07 m across along x and y, yet no
  // lattice point falls inside it.
  std::string plate;
  for (int corner = 0; corner < 8; ++corner)
    plate += "v " + std::to_string(corner & 4 ? 0.5 : -0.5) + " " +
             std::to_string(corner & 2 ? 0.000005 : -0.000005) + " " +
             std::to_string(corner & 1 ? 0.5 : -0.5) + "\n";
  std::ifstream in(kMeshes + "cube.obj");  // the unit cube's faces, on the same corners
  for (std::string line; std::getline(in, line);)
    if (line.rfind("f ", 0) == 0) plate += line + "\n";
  Json turned = meshScene(writeFile("plate.obj", plate).string(), 0.1, {0.1, 0.1, 0.1});
  turned["bodies"][0]["rotation"] = {0, 0, 45};
  const Scene scene = parseScene(turned, (tempDir() / "scene.json").string());
  EXPECT_EQ(narrowError(turned), "");
  try {
    sampleBodies<3>(scene);
    ADD_FAILURE() << "the plate was filled";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bodies[0] holds no particles"), std::string::npos)
        << e.what();
  }
}

TEST(LevelSet, IsTheSignedDistanceToTheCube) {
  const TriangleMesh cube = placed(loadTriangleMesh(kMeshes + "cube.obj"), {{0, 0, 0}, {}, 0.1});
  const LevelSet phi(cube, 0.005, 0.02);
  // Exact on the voxels, trilinear between them: off by at most about a voxel's curvature error.
  EXPECT_NEAR(phi.phi({0, 0, 0}), -0.05, 1e-3);
  EXPECT_NEAR(phi.phi({0.03, 0.01, -0.02}), -0.02, 1e-3);
  EXPECT_NEAR(phi.phi({0.06, 0, 0}), 0.01, 1e-3);
  EXPECT_NEAR(phi.phi({0, -0.065, 0}), 0.015, 1e-3);
  EXPECT_GT(phi.phi({0.5, 0.5, 0.5}), 0.3) << "far beyond the voxels: still outside";
  const auto n = phi.gradient({0.049, 0.01, 0.0});
  EXPECT_NEAR(n[0], 1, 0.05);
  EXPECT_NEAR(n[1], 0, 0.05);
  const auto down = phi.gradient({0.01, -0.051, 0.02});
  EXPECT_NEAR(down[1], -1, 0.05);
  EXPECT_NEAR(phi.depth(), 0.05, 1e-3) << "the cube's centre, half its side deep";
}

// The grid meets a collider mpm.collider_inset cells inside it (0.1 by default), at most half as
// deep as its deepest point, and the walls that close a 2D scene's slab in 3D on their surface.
TEST(MeshCollider, TheGridMeetsEachColliderItsInsetInside) {
  Json j = Json::parse(R"({
    "name": "inset", "dimension": 2, "solver": "mpm", "material": {"preset": "paper"},
    "grid": {"cells": [20, 20], "cell_size": 0.01},
    "bodies": [{"shape": "ball", "center": [0.1, 0.15], "radius": 0.02}],
    "colliders": [{"shape": "sphere", "position": [0.1, 0.05], "radius": 0.02},
                  {"shape": "sphere", "position": [0.05, 0.05], "radius": 0.001},
                  {"shape": "box", "position": [0.15, 0.05], "size": [0.04, 0.0016]}]
  })");
  const std::vector<Collider<3>> slab = makeColliders<3>(parseScene(j, "inset.json"));
  ASSERT_EQ(slab.size(), 6u + 3u);
  for (int wall = 0; wall < 4; ++wall) EXPECT_DOUBLE_EQ(slab[wall].grid_inset, 0.001);
  EXPECT_EQ(slab[4].grid_inset, 0) << "the slab's near end";
  EXPECT_EQ(slab[5].grid_inset, 0) << "the slab's far end";
  EXPECT_DOUBLE_EQ(slab[6].grid_inset, 0.001);
  EXPECT_DOUBLE_EQ(slab[7].grid_inset, 0.0005) << "half the small sphere's radius";
  EXPECT_DOUBLE_EQ(slab[8].grid_inset, 0.0004) << "half the thin box's half height";
  j["mpm"] = {{"collider_inset", 0.2}};
  EXPECT_DOUBLE_EQ(makeColliders<2>(parseScene(j, "inset.json"))[0].grid_inset, 0.002);
  const Scene again = parseScene(sceneToJson(parseScene(j, "inset.json")), "inset.json");
  EXPECT_EQ(again.mpm.collider_inset, 0.2);
  j["mpm"] = {{"collider_inset", 0.25}};
  try {
    parseScene(j, "inset.json");
    ADD_FAILURE() << "an inset past 0.2 cells is refused";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mpm.collider_inset"), std::string::npos) << e.what();
  }
}

// A mesh whose box needs more than kMaxVoxels voxels of the size asked for gets larger ones, as
// few larger as keep it within the cap; a small one keeps the size asked for.
TEST(LevelSet, VoxelsGrowOnlyPastTheCap) {
  const TriangleMesh cube = placed(loadTriangleMesh(kMeshes + "cube.obj"), {{0, 0, 0}, {}, 1});
  const auto [lo, hi] = cube.bounds();
  EXPECT_EQ(LevelSet::voxelFor(cube, 0.01, 0.05), 0.01);
  for (const double margin : {0.05, 0.3}) {
    // Voxels along each axis: from the one below lo - margin to the one above hi + margin.
    auto voxels = [&](double side) {
      double n = 1;
      for (int a = 0; a < 3; ++a)
        n *= std::ceil((hi[a] + margin) / side) - std::floor((lo[a] - margin) / side) + 1;
      return n;
    };
    const double grown = LevelSet::voxelFor(cube, 0.001, margin);
    EXPECT_GT(grown, 0.001) << margin;
    EXPECT_LE(voxels(grown), LevelSet::kMaxVoxels) << margin;
    EXPECT_GT(voxels(grown / 1.25), LevelSet::kMaxVoxels)
        << margin << ": no larger than it must be";
  }
}

// The solver screens a mesh collider by its level set's box: every point a turned torus holds
// (phi <= 0) lies in its bounding box, and the solid's box is the voxels' for a closed mesh.
TEST(LevelSet, AMeshColliderLiesInsideItsBoundingBox) {
  const TriangleMesh torus = placed(loadTriangleMesh(kMeshes + "torus.stl"), {{0, 0, 0}, {}, 0.1});
  Collider<3> c;
  c.shape = ColliderShape::Mesh;
  c.level_set = std::make_shared<const LevelSet>(torus, 0.01, 0.02);
  c.position = Vec<3>(0.4, 0.3, 0.2);
  c.rotation = Eigen::AngleAxisd(0.6, Vec<3>(1, 2, 3).normalized()).toRotationMatrix();
  const auto [lo, hi] = torus.bounds();
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(c.level_set->solidLower()[a], lo[a] - 0.02 + 1e-12);
    EXPECT_GT(c.level_set->solidLower()[a], lo[a] - 0.02 - 0.01 - 1e-12) << "one voxel at most";
    EXPECT_GE(c.level_set->solidUpper()[a], hi[a] + 0.02 - 1e-12);
  }
  const Eigen::AlignedBox<Real, 3> box = boundingBox(c, 1e-12);
  std::mt19937 random(4);
  std::uniform_real_distribution<double> offset(-0.15, 0.15);
  int held = 0;
  for (int k = 0; k < 20000; ++k) {
    const Vec<3> x = c.position + Vec<3>(offset(random), offset(random), offset(random));
    if (c.phi(x) > 0) continue;
    ++held;
    EXPECT_TRUE(box.contains(x)) << x.transpose();
  }
  EXPECT_GT(held, 100);
  EXPECT_LT(box.volume(), 0.1) << "bounded, a little more than the torus";
}

// A filled sphere has volume x ppc / h^3 particles (to 3%: the lattice's staircase at the surface
// and the icosphere's facets), every one inside the sphere; the fill repeats for a seed.
TEST(MeshBody, FillsTheMeshAtTheScenesParticlesPerCell) {
  const Scene scene = parseScene(meshScene(kMeshes + "sphere.obj", 0.06, {0.1, 0.1, 0.1}),
                                 (tempDir() / "scene.json").string());
  const Particles<3> p = sampleBodies<3>(scene);
  const double volume = loadTriangleMesh(kMeshes + "sphere.obj").signedVolume() * std::pow(0.06, 3);
  const double expected = volume * 27 / std::pow(0.01, 3);
  EXPECT_NEAR(p.size(), expected, 0.03 * expected);
  for (const Vec<3>& x : p.x) EXPECT_LT((x - Vec<3>(0.1, 0.1, 0.1)).norm(), 0.06);
  EXPECT_EQ(sampleBodies<3>(scene).x, p.x) << "the same seed, the same particles";
  Scene other = scene;
  other.seed = 2;
  EXPECT_NE(sampleBodies<3>(other).x, p.x);

  // The cube, turned 45 degrees about y: every particle inside the turned cube.
  Json turned = meshScene(kMeshes + "cube.obj", 0.08, {0.1, 0.1, 0.1});
  turned["bodies"][0]["rotation"] = {0, 45, 0};
  const Scene cube_scene = parseScene(turned, (tempDir() / "scene.json").string());
  const Particles<3> c = sampleBodies<3>(cube_scene);
  const double cube_expected = std::pow(0.08, 3) * 27 / std::pow(0.01, 3);
  EXPECT_NEAR(c.size(), cube_expected, 0.03 * cube_expected);
  for (const Vec<3>& x : c.x) {
    const Vec<3> r = x - Vec<3>(0.1, 0.1, 0.1);
    const double u = (r[0] - r[2]) / std::sqrt(2.0), w = (r[0] + r[2]) / std::sqrt(2.0);
    EXPECT_LT(std::max({std::abs(u), std::abs(r[1]), std::abs(w)}), 0.04);
  }
}

// v = v0 + w x (x - c), c the centre of mass: the spin adds no momentum.
TEST(MeshBody, SpinsAboutItsCentreOfMass) {
  Json j = meshScene(kMeshes + "rock.obj", 0.08, {0.1, 0.1, 0.1});
  j["bodies"][0]["velocity"] = {1, 0, 0};
  j["bodies"][0]["angular_velocity"] = {0, 0, 10};
  const Particles<3> p = sampleBodies<3>(parseScene(j, (tempDir() / "scene.json").string()));
  Vec<3> centre = Vec<3>::Zero(), momentum = Vec<3>::Zero();
  for (int i = 0; i < p.size(); ++i) centre += p.x[i] / p.size(), momentum += p.v[i] / p.size();
  EXPECT_NEAR((momentum - Vec<3>(1, 0, 0)).norm(), 0, 1e-12);
  for (int i = 0; i < p.size(); ++i) {
    const Vec<3> expected = Vec<3>(1, 0, 0) + Vec<3>(0, 0, 10).cross(p.x[i] - centre);
    EXPECT_NEAR((p.v[i] - expected).norm(), 0, 1e-12);
  }
}

TEST(MeshBody, WritesBackToTheSameScene) {
  Json j = meshScene(kMeshes + "rock.obj", 0.08, {0.1, 0.1, 0.1});
  j["bodies"][0]["rotation"] = {10, 20, 30};
  j["bodies"][0]["angular_velocity"] = {1, 2, 3};
  j["colliders"] = {{{"shape", "mesh"},
                     {"mesh", kMeshes + "torus.stl"},
                     {"position", {0.1, 0, 0.1}},
                     {"scale", 0.1}}};
  const Scene scene = parseScene(j, (tempDir() / "scene.json").string());
  const Json written = sceneToJson(scene);
  const Scene again = parseScene(written, "elsewhere/run.json");
  EXPECT_EQ(sceneToJson(again), written);
  EXPECT_EQ(again.bodies[0].mesh.rotation, (Vec3{10, 20, 30}));
  EXPECT_EQ(sampleBodies<3>(again).x, sampleBodies<3>(scene).x);
}

// Snow dropped on a box collider given as a mesh comes to rest on it as on the analytic box: no
// particle ends inside, and the heights agree to a tenth of a cell.
TEST(MeshCollider, SnowRestsOnAMeshBoxAsOnTheAnalyticBox) {
  const Json base = Json::parse(R"({
    "name": "drop", "dimension": 3, "solver": "mpm", "material": {"preset": "paper"},
    "grid": {"cells": [12, 16, 12], "cell_size": 0.01},
    "particles_per_cell": 8,
    "bodies": [{"shape": "box", "center": [0.06, 0.11, 0.06], "size": [0.03, 0.03, 0.03]}]
  })");
  Json analytic = base, mesh = base;
  analytic["colliders"] = {
      {{"shape", "box"}, {"position", {0.06, 0.025, 0.06}}, {"size", {0.08, 0.04, 0.08}}}};
  // The unit cube scaled to 0.08, its centre low enough that its top is the box's top. The top
  // lies between two planes of grid nodes: on one, rounding alone would decide which collider
  // the nodes touch.
  mesh["colliders"] = {{{"shape", "mesh"},
                        {"mesh", kMeshes + "cube.obj"},
                        {"position", {0.06, 0.005, 0.06}},
                        {"scale", 0.08}}};
  double heights[2] = {0, 0};
  int k = 0;
  for (const Json* j : {&analytic, &mesh}) {
    const Scene scene = parseScene(*j, (tempDir() / "scene.json").string());
    MpmSolver<3> solver(scene, sampleBodies<3>(scene), 1);
    for (double t = 0; t < 0.15;) {
      const double dt = std::min(solver.stableTimeStep(), 0.15 - t);
      solver.step(dt);
      t += dt;
    }
    const Collider<3> box = makeColliders<3>(parseScene(analytic, "a.json")).back();
    double sum = 0;
    for (const Vec<3>& x : solver.particles().x) {
      EXPECT_GE(box.phi(x), -1e-3) << "inside the box";
      sum += x[1];
    }
    heights[k++] = sum / solver.particles().size();
  }
  EXPECT_GT(heights[0], 0.045) << "resting on the box top at 0.045";
  EXPECT_NEAR(heights[1], heights[0], 0.001);
}
