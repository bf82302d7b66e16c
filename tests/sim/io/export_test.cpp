// Taking snow to other tools and back: the PLY's attributes, --z-up, the VDB volumes, the surface's
// mesh and level set, the Blender loader (run in Debian's Blender) and runs that start from a PLY
// frame.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>
#include <nlohmann/json.hpp>

#include "sim/io/ply.h"
#include "sim/io/up_axis.h"
#include "tests/support/run_snowsim.h"

namespace {

namespace fs = std::filesystem;

using namespace snowsim_test;

// A small 3D MPM snowball smashed into a wall: a few hundred particles, some compacted.
const std::string kSmash = std::string(SNOWSIM_SOURCE_DIR) + "/scenes/study_smash_3d.json";

std::string plyHeader(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::string header, line;
  while (std::getline(in, line) && line != "end_header") header += line + "\n";
  return header;
}

// A run of the smash scene for `duration` seconds into `out`, PLY frames only unless `extra` asks.
void runSmash(const fs::path& out, double duration, const std::string& extra = "") {
  const Result r = runSnowsim("run " + kSmash + " -o " + out.string() +
                              " --no-png --no-mp4 --set time.duration=" + std::to_string(duration) +
                              " " + extra);
  ASSERT_EQ(r.code, 0) << r.output;
}

TEST(Export, PlyFramesCarryTheAttributesDccToolsRead) {
  const fs::path out = freshDir("export_ply");
  runSmash(out, 0.04);
  const std::string header = plyHeader(out / "frame_00002.ply");
  for (const char* property :
       {"property float vx\n", "property float density\n", "property float plastic_j\n",
        "property float mass\n", "property float pscale\n", "property int id\n",
        "comment snowsim up y\n"})
    EXPECT_NE(header.find(property), std::string::npos) << property << "missing from\n" << header;
  const snowsim::Snapshot s = snowsim::readPly((out / "frame_00002.ply").string());
  ASSERT_EQ(s.radius.size(), s.position.size());
  // 8 particles per cell of 1 cm: spacing 5 mm, radius half of it.
  EXPECT_NEAR(s.radius.front(), 0.0025, 1e-7);
  EXPECT_NEAR(s.mass.front(), 400 * std::pow(0.005, 3), 1e-9) << "the scene's default density";
}

TEST(Export, ZUpTurnsPositionsAndVelocitiesAndReadsBack) {
  const fs::path y_up = freshDir("export_y_up"), z_up = freshDir("export_z_up");
  runSmash(y_up, 0.04);
  runSmash(z_up, 0.04, "--z-up");
  EXPECT_NE(plyHeader(z_up / "frame_00002.ply").find("comment snowsim up z\n"), std::string::npos);
  const snowsim::Snapshot a = snowsim::readPly((y_up / "frame_00002.ply").string());
  const snowsim::Snapshot b = snowsim::readPly((z_up / "frame_00002.ply").string());
  EXPECT_EQ(a.position, b.position) << "the reader turns z-up frames back";
  EXPECT_EQ(a.velocity, b.velocity);
  // The file itself holds (x, -z, y): the first particle's position, as floats after the header.
  std::ifstream in(z_up / "frame_00002.ply", std::ios::binary);
  in.seekg(static_cast<std::streamoff>(plyHeader(z_up / "frame_00002.ply").size() +
                                       std::string("end_header\n").size()));
  float raw[3];
  in.read(reinterpret_cast<char*>(raw), sizeof raw);
  EXPECT_EQ(raw[0], a.position[0][0]);
  EXPECT_EQ(raw[1], -a.position[0][2]);
  EXPECT_EQ(raw[2], a.position[0][1]);
  // snowsim render reads them as any frame.
  const Result r = runSnowsim("render " + z_up.string() + " --no-mp4 --width 64 --height 48");
  EXPECT_EQ(r.code, 0) << r.output;
}

TEST(Export, FramesOlderThanTheAttributesStillRead) {
  for (const char* name : {"mpm_2d.ply", "mpm_3d.ply", "report_2d.ply"}) {
    const snowsim::Snapshot s =
        snowsim::readPly(std::string(SNOWSIM_SOURCE_DIR) + "/fuzz/corpus/ply/" + name);
    EXPECT_GT(s.size(), 0) << name;
    EXPECT_TRUE(s.mass.empty() && s.radius.empty()) << name;
  }
}

TEST(Export, VdbIsRefusedFor2DRuns) {
  const fs::path out = freshDir("export_vdb_2d");
  const Result r = runSnowsim("run " + std::string(SNOWSIM_SOURCE_DIR) +
                              "/scenes/snowball_drop.json -o " + out.string() + " --vdb");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--vdb"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out / "frame_00000.ply"));
}

// A surface PLY as writeSurfacePly writes it: its comments, vertices (x y z nx ny nz) and faces.
struct SurfaceFile {
  std::string header;
  std::vector<std::array<float, 6>> vertices;
  std::vector<std::array<std::uint32_t, 3>> faces;
};

SurfaceFile readSurfaceFile(const fs::path& file) {
  SurfaceFile m;
  m.header = plyHeader(file);
  size_t vertices = 0, faces = 0;
  std::istringstream lines(m.header);
  for (std::string line; std::getline(lines, line);) {
    std::sscanf(line.c_str(), "element vertex %zu", &vertices);
    std::sscanf(line.c_str(), "element face %zu", &faces);
  }
  std::ifstream in(file, std::ios::binary);
  in.seekg(static_cast<std::streamoff>(m.header.size() + std::string("end_header\n").size()));
  m.vertices.resize(vertices);
  in.read(reinterpret_cast<char*>(m.vertices.data()), vertices * sizeof(m.vertices[0]));
  m.faces.resize(faces);
  for (auto& face : m.faces) {
    unsigned char count = 0;
    in.read(reinterpret_cast<char*>(&count), 1);
    EXPECT_EQ(count, 3);
    in.read(reinterpret_cast<char*>(face.data()), sizeof face);
  }
  EXPECT_TRUE(in) << file << " is shorter than its header says";
  EXPECT_EQ(in.peek(), EOF) << file << " is longer than its header says";
  return m;
}

// The surface's mesh and its level set grid, y up and z up, against the particles they come from.
TEST(Export, SurfaceMeshAndLevelSetSitOnTheSnow) {
  openvdb::initialize();
  for (const bool z_up : {false, true}) {
    const fs::path out = freshDir(z_up ? "export_surface_z" : "export_surface_y");
    runSmash(out, 0.02, std::string("--surface --vdb") + (z_up ? " --z-up" : ""));
    const SurfaceFile m = readSurfaceFile(out / "surface_00001.ply");
    const snowsim::Snapshot s = snowsim::readPly((out / "frame_00001.ply").string());
    EXPECT_NE(m.header.find("property list uchar uint vertex_indices\n"), std::string::npos);
    EXPECT_NE(m.header.find(z_up ? "comment snowsim up z\n" : "comment snowsim up y\n"),
              std::string::npos)
        << m.header;
    EXPECT_NE(m.header.find("comment snowsim loose_grains "), std::string::npos) << m.header;
    ASSERT_GT(m.faces.size(), 100u);
    for (const auto& face : m.faces)
      for (std::uint32_t v : face) ASSERT_LT(v, m.vertices.size());
    // Every vertex within two particle spacings (5 mm) of the particles' box, in the file's axes.
    std::array<float, 3> low{1e9f, 1e9f, 1e9f}, high{-1e9f, -1e9f, -1e9f};
    for (const auto& x : s.position) {
      const auto turned = snowsim::toUpAxis(x, z_up ? snowsim::UpAxis::Z : snowsim::UpAxis::Y);
      for (int a = 0; a < 3; ++a)
        low[a] = std::min(low[a], turned[a]), high[a] = std::max(high[a], turned[a]);
    }
    for (const auto& v : m.vertices)
      for (int a = 0; a < 3; ++a) {
        ASSERT_GT(v[a], low[a] - 0.01f) << "axis " << a;
        ASSERT_LT(v[a], high[a] + 0.01f) << "axis " << a;
      }

    // The VDB's `surface`: a level set on half-cell voxels, zero on the mesh, negative at the
    // snow's centre, where the file's axes put them.
    openvdb::io::File file((out / "frame_00001.vdb").string());
    file.open();
    const auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("surface"));
    file.close();
    ASSERT_TRUE(grid);
    EXPECT_EQ(grid->getGridClass(), openvdb::GRID_LEVEL_SET);
    EXPECT_DOUBLE_EQ(grid->voxelSize()[0], 0.005);
    const openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> phi(*grid);
    for (size_t v = 0; v < m.vertices.size(); v += 37)
      ASSERT_LT(std::abs(phi.wsSample({m.vertices[v][0], m.vertices[v][1], m.vertices[v][2]})),
                0.005)
          << "vertex " << v;
    std::array<double, 3> centre{};
    for (int a = 0; a < 3; ++a) centre[a] = 0.5 * (low[a] + high[a]);
    EXPECT_LT(phi.wsSample({centre[0], centre[1], centre[2]}), -0.005);
  }
}

// The loader script in Debian's Blender: the surface meshes as one object, each frame's vertices
// and triangles those of its file.
TEST(Export, BlenderLoadsTheSurfaceMeshesAsOneAnimatedObject) {
  if (runCommand("command -v blender").code != 0)
    GTEST_SKIP() << "blender is not installed (apt-get install blender; scripts/setup.sh does)";
  const fs::path out = freshDir("export_blender_surface");
  runSmash(out, 0.04, "--surface");
  const fs::path report = out.parent_path() / "blender_surface.json";
  const std::string check =
      "import bpy, json, numpy as np\n"
      "o = bpy.data.objects['snowsim_surface']\n"
      "frames = {}\n"
      "for f in (1, 2):\n"
      "    bpy.context.scene.frame_set(f)\n"
      "    co = np.zeros(len(o.data.vertices) * 3, dtype=np.float32)\n"
      "    o.data.vertices.foreach_get('co', co)\n"
      "    co = co.reshape(-1, 3)\n"
      "    frames[str(f)] = {'vertices': len(o.data.vertices), 'faces': len(o.data.polygons),\n"
      "                      'low': co.min(0).tolist(), 'high': co.max(0).tolist()}\n"
      "json.dump(frames, open('" +
      report.string() + "', 'w'))\n";
  const fs::path script = out.parent_path() / "blender_surface_check.py";
  std::ofstream(script) << check;
  const Result r = runCommand("blender -b --factory-startup --python-exit-code 1 --python " +
                              std::string(SNOWSIM_SOURCE_DIR) + "/scripts/blender_load_run.py " +
                              "--python " + script.string() + " -- " + out.string());
  ASSERT_EQ(r.code, 0) << r.output;
  const auto blender = nlohmann::json::parse(std::ifstream(report));
  for (int frame : {1, 2}) {
    const SurfaceFile m = readSurfaceFile(out / ("surface_0000" + std::to_string(frame) + ".ply"));
    const nlohmann::json& seen = blender[std::to_string(frame)];
    EXPECT_EQ(seen["vertices"].get<size_t>(), m.vertices.size()) << "frame " << frame;
    EXPECT_EQ(seen["faces"].get<size_t>(), m.faces.size()) << "frame " << frame;
    for (int a = 0; a < 3; ++a) {
      float low = 1e9f, high = -1e9f;
      for (const auto& v : m.vertices) low = std::min(low, v[a]), high = std::max(high, v[a]);
      EXPECT_FLOAT_EQ(seen["low"][a].get<float>(), low) << "frame " << frame << " axis " << a;
      EXPECT_FLOAT_EQ(seen["high"][a].get<float>(), high) << "frame " << frame << " axis " << a;
    }
  }
  EXPECT_NE(blender["1"]["high"][0], blender["2"]["high"][0]) << "one frame shown throughout";
}

TEST(Export, SurfaceIsRefusedFor2DRuns) {
  const fs::path out = freshDir("export_surface_2d");
  const Result r = runSnowsim("run " + std::string(SNOWSIM_SOURCE_DIR) +
                              "/scenes/snowball_drop.json -o " + out.string() + " --surface");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--surface"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out / "frame_00000.ply"));
}

// The loader script in Debian's Blender: one object animated through the frames, its attributes,
// and the VDB sequence as a volume where the particles are.
TEST(Export, BlenderLoadsTheRunAsOneAnimatedObjectAndAVolume) {
  if (runCommand("command -v blender").code != 0)
    GTEST_SKIP() << "blender is not installed (apt-get install blender; scripts/setup.sh does)";
  const fs::path out = freshDir("export_blender");
  runSmash(out, 0.06, "--vdb");
  ASSERT_TRUE(fs::exists(out / "frame_00003.vdb"));
  const fs::path report = out.parent_path() / "blender_report.json";
  const std::string source = SNOWSIM_SOURCE_DIR;
  const Result r = runCommand("SNOWSIM_BLENDER_REPORT=" + report.string() +
                              " blender -b --factory-startup --python-exit-code 1 --python " +
                              source + "/scripts/blender_load_run.py --python " + source +
                              "/scripts/blender_load_run.py --python " + source +
                              "/tests/sim/io/blender_check.py -- " + out.string() + " --vdb");
  ASSERT_EQ(r.code, 0) << r.output;
  const auto blender = nlohmann::json::parse(std::ifstream(report));

  int meshes = 0;
  for (const auto& object : blender["objects"]) {
    meshes += object["from_run"].get<bool>() && object["type"] == "MESH" &&
              object["name"] != "snowsim_ground";
    EXPECT_NE(object["name"], "Cube") << "the startup scene's cube hides the snow";
    EXPECT_EQ(object["name"].get<std::string>().find(".00"), std::string::npos)
        << object["name"] << ": loaded twice, made twice";
  }
  EXPECT_EQ(meshes, 1) << "one object for all the frames, loaded twice";
  EXPECT_EQ(blender["particles_modifiers"], nlohmann::json::array({"snowsim_points"}));
  EXPECT_EQ(blender["points_radius"], nlohmann::json::array({"pscale"}));
  EXPECT_EQ(blender["frame_start"], 0);
  EXPECT_EQ(blender["frame_end"], 3);
  EXPECT_DOUBLE_EQ(blender["fps"].get<double>(), 50);
  EXPECT_NEAR(blender["particles_rotation"][0].get<double>(), M_PI / 2, 1e-6) << "y up to z up";

  for (const int frame : {0, 3}) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.ply", frame);
    const snowsim::Snapshot ply = snowsim::readPly((out / name).string());
    const auto& shown = blender["frames"][std::to_string(frame)];
    ASSERT_EQ(shown["count"], ply.size()) << name;
    const auto& positions = shown["positions"];
    for (int i = 0; i < ply.size(); ++i)
      for (int a = 0; a < 3; ++a)
        ASSERT_EQ(positions[3 * i + a].get<float>(), ply.position[i][a])
            << name << " particle " << i;
    const auto& attributes = shown["attributes"];
    for (const char* attribute : {"velocity", "density", "plastic_j", "mass", "pscale", "id"})
      EXPECT_TRUE(attributes.contains(attribute)) << attribute << " at frame " << frame;
    if (frame == 3) {
      for (const char* varying : {"velocity", "density", "plastic_j", "id"})
        EXPECT_LT(attributes[varying]["min"].get<double>(),
                  attributes[varying]["max"].get<double>())
            << varying << " is constant at frame 3";
    }
  }
  EXPECT_EQ(blender["frames"]["3"]["attributes"]["id"]["type"], "INT");
  EXPECT_EQ(blender["frames"]["3"]["attributes"]["velocity"]["type"], "FLOAT_VECTOR");

  // The volume at the last frame: its file, its grids, and the voxels the particles' quadratic
  // B-splines reach, from floor(lo / h - 0.5) to floor(hi / h - 0.5) + 2 along each axis.
  // Blender's mesh of them runs from the lower face of the lowest voxel to one voxel past the
  // highest's upper face.
  const auto& volume = blender["volume"];
  EXPECT_EQ(volume["error"], "");
  EXPECT_NE(volume["file"].get<std::string>().find("frame_00003.vdb"), std::string::npos);
  EXPECT_EQ(volume["grids"]["density"], "FLOAT");
  EXPECT_EQ(volume["grids"]["velocity"], "VECTOR_FLOAT");
  const snowsim::Snapshot last = snowsim::readPly((out / "frame_00003.ply").string());
  const double h = last.grid.cell_size;
  EXPECT_GT(volume["surface_vertices"].get<int>(), 0) << "the density grid is empty";
  for (int a = 0; a < 3; ++a) {
    float lo = last.position[0][a], hi = lo;
    for (const auto& p : last.position) lo = std::min(lo, p[a]), hi = std::max(hi, p[a]);
    const double lowest = std::floor(lo / h - 0.5), highest = std::floor(hi / h - 0.5) + 2;
    EXPECT_NEAR(volume["density_min"][a].get<double>(), (lowest - 0.5) * h, 0.1 * h)
        << "axis " << a;
    EXPECT_NEAR(volume["density_max"][a].get<double>(), (highest + 1.5) * h, 0.1 * h)
        << "axis " << a;
  }
}

// The run's box collider reaches Blender keyframed where colliders.json puts it, turned z up with
// the snow; a run directory that is not there ends Blender with exit code 1, saving nothing.
TEST(Export, BlenderDrawsTheCollidersAndRefusesAMissingRun) {
  if (runCommand("command -v blender").code != 0)
    GTEST_SKIP() << "blender is not installed (apt-get install blender; scripts/setup.sh does)";
  const fs::path out = freshDir("export_blender_colliders");
  const std::string source = SNOWSIM_SOURCE_DIR;
  ASSERT_EQ(runSnowsim("run " + source + "/scenes/mpm_snowball_wall.json -o " + out.string() +
                       " --scale 0.5 --no-png --no-mp4 --set time.duration=0.04")
                .code,
            0);
  const fs::path report = out.parent_path() / "blender_colliders.json";
  const std::string blender = " blender -b --factory-startup --python-exit-code 1 --python " +
                              source + "/scripts/blender_load_run.py ";
  const Result r = runCommand("SNOWSIM_BLENDER_REPORT=" + report.string() + blender + "--python " +
                              source + "/tests/sim/io/blender_check.py -- " + out.string());
  ASSERT_EQ(r.code, 0) << r.output;
  const auto loaded = nlohmann::json::parse(std::ifstream(report))["colliders"];
  const auto frames = nlohmann::json::parse(std::ifstream(out / "colliders.json"))["frames"];
  ASSERT_EQ(loaded.size(), 1u);
  const auto& box = loaded["snowsim_collider_0"];
  EXPECT_EQ(box["keyframes"].get<size_t>(), frames.size());
  const auto& pose = frames.back()["colliders"][0];
  const double y_up[3] = {pose["position"][0], pose["position"][1], pose["position"][2]};
  const double z_up[3] = {y_up[0], -y_up[2], y_up[1]};
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(box["location"][a].get<double>(), z_up[a], 1e-6) << a;
  EXPECT_NEAR(box["dimensions"][1].get<double>(), pose["size"][1].get<double>(), 1e-6);

  const fs::path saved = out.parent_path() / "missing.blend";
  const Result missing =
      runCommand(blender + "--python-expr \"import bpy; bpy.ops.wm.save_as_mainfile(filepath='" +
                 saved.string() + "')\" -- " + (out.string() + "_typo"));
  EXPECT_EQ(missing.code, 1) << missing.output;
  EXPECT_NE(missing.output.find("_typo: no such directory"), std::string::npos) << missing.output;
  EXPECT_FALSE(fs::exists(saved));

  // A misspelt option is refused, naming it and the known ones, with or without
  // --python-exit-code.
  for (const std::string& exit_code : {std::string(" --python-exit-code 1"), std::string()}) {
    const Result typo =
        runCommand("blender -b --factory-startup" + exit_code + " --python " + source +
                   "/scripts/blender_load_run.py --python-expr \"import bpy; "
                   "bpy.ops.wm.save_as_mainfile(filepath='" +
                   saved.string() + "')\" -- " + out.string() + " --vdb-typo");
    EXPECT_EQ(typo.code, 1) << typo.output;
    EXPECT_NE(typo.output.find("unknown option --vdb-typo (known: --vdb, --bake)"),
              std::string::npos)
        << typo.output;
    EXPECT_FALSE(fs::exists(saved));
  }
}

// What a fresh Blender shows of a .blend the loader saved, opened without the loader
// (blender_saved_check.py's report); `open` holds Blender's options before the file.
nlohmann::json openSaved(const fs::path& blend, const std::string& open = "") {
  const fs::path report = blend.string() + ".json";
  const Result r =
      runCommand("SNOWSIM_BLENDER_REPORT=" + report.string() + " blender -b --python-exit-code 1 " +
                 open + " " + blend.string() + " --python " + SNOWSIM_SOURCE_DIR +
                 "/tests/sim/io/blender_saved_check.py");
  EXPECT_EQ(r.code, 0) << r.output;
  return r.code == 0 ? nlohmann::json::parse(std::ifstream(report)) : nlohmann::json::object();
}

// The smash of the flagship scene at a quarter of its cells, saved by the loader with `options`.
fs::path savedSmash(const std::string& name, const std::string& set, const std::string& options) {
  const fs::path out = freshDir(name);
  const std::string source = SNOWSIM_SOURCE_DIR;
  const Result run =
      runSnowsim("run " + source + "/scenes/flagship/smash_wall.json -o " + out.string() +
                 " --scale 0.25 --no-png --no-mp4 " + "--set time.duration=0.1 " + set);
  EXPECT_EQ(run.code, 0) << run.output;
  const fs::path blend = out.string() + ".blend";
  fs::remove(blend);
  const Result r =
      runCommand("blender -b --factory-startup --python-exit-code 1 --python " + source +
                 "/scripts/blender_load_run.py --python-expr \"import bpy; "
                 "bpy.ops.wm.save_as_mainfile(filepath='" +
                 blend.string() + "')\" -- " + out.string() + " " + options);
  EXPECT_EQ(r.code, 0) << r.output;
  return blend;
}

// The saved file plays: the snow at its last frame is not where it is at its first.
void expectPlays(const nlohmann::json& shown) {
  const auto& first = shown["frames"]["0"];
  const auto& last = shown["frames"]["4"];
  ASSERT_GT(first["count"].get<int>(), 0);
  EXPECT_EQ(first["count"], last["count"]);
  EXPECT_NE(first["positions"], last["positions"]) << "the file shows one frame throughout";
}

// The camera sees the snow's centre at both frames: inside the image, in front of the camera,
// no face (the wall, the ground) in between; the ground is the floor under the snow; Cycles
// renders without a denoiser, which Debian's Blender lacks.
void expectSeenOnTheGround(const nlohmann::json& shown) {
  for (const char* frame : {"0", "4"}) {
    const auto& f = shown["frames"][frame];
    ASSERT_TRUE(f.contains("in_view")) << "no camera";
    const double x = f["in_view"][0], y = f["in_view"][1], depth = f["in_view"][2];
    EXPECT_TRUE(x > 0.05 && x < 0.95 && y > 0.05 && y < 0.95) << x << ", " << y << " at " << frame;
    EXPECT_GT(depth, 0) << "behind the camera at " << frame;
    EXPECT_EQ(f["hidden_by"], "") << "the camera's view of the snow is blocked at " << frame;
    ASSERT_TRUE(shown.contains("ground"));
    const auto& ground = shown["ground"];
    EXPECT_EQ(ground["min"][2].get<double>(), 0) << "the floor is the grid's bottom";
    EXPECT_EQ(ground["max"][2].get<double>(), 0);
    for (int a = 0; a < 2; ++a) {
      EXPECT_LT(ground["min"][a].get<double>(), f["centre"][a].get<double>()) << a;
      EXPECT_GT(ground["max"][a].get<double>(), f["centre"][a].get<double>()) << a;
    }
  }
  EXPECT_EQ(shown["engine"], "CYCLES");
  EXPECT_EQ(shown["denoising"], false);
}

// A saved file keeps the frame handler as a text block Blender runs on opening it when auto-run
// of Python scripts is allowed (-y); the scene's placed camera sees the snow, not the wall.
TEST(Export, BlenderSavesAFileThatPlaysWithAutoRunAndSeesTheSnow) {
  if (runCommand("command -v blender").code != 0)
    GTEST_SKIP() << "blender is not installed (apt-get install blender; scripts/setup.sh does)";
  const fs::path blend = savedSmash("export_blender_saved", "", "");
  const auto shown = openSaved(blend, "-y");
  EXPECT_EQ(shown["texts"], nlohmann::json::array({"snowsim_frame_change.py"}));
  expectPlays(shown);
  expectSeenOnTheGround(shown);
  // Without auto-run the text block does not run: the first frame throughout.
  const auto still = openSaved(blend);
  EXPECT_EQ(still["frames"]["0"]["positions"], still["frames"]["4"]["positions"]);
}

// --bake keeps every frame in the file, the particles and the surface meshes, which plays with no
// script at all; the scene's side preset looks through the wall, so the camera frames the snow
// from another side.
TEST(Export, BlenderBakedFilePlaysWithoutAScriptAndSeesTheSnow) {
  if (runCommand("command -v blender").code != 0)
    GTEST_SKIP() << "blender is not installed (apt-get install blender; scripts/setup.sh does)";
  const fs::path blend = savedSmash(
      "export_blender_baked", "--surface --set 'render.camera={\"preset\": \"side\"}'", "--bake");
  const auto shown = openSaved(blend);
  EXPECT_EQ(shown["texts"], nlohmann::json::array());
  expectPlays(shown);
  expectSeenOnTheGround(shown);
  // One surface mesh shown at each frame, its own file's.
  const fs::path run = blend.parent_path() / blend.stem();
  for (const char* frame : {"0", "4"}) {
    const std::string name = std::string("snowsim_surface_0000") + frame;
    const nlohmann::json& surfaces = shown["frames"][frame]["surfaces"];
    ASSERT_EQ(surfaces.size(), 1u) << surfaces.dump();
    ASSERT_TRUE(surfaces.contains(name)) << surfaces.dump();
    const SurfaceFile m = readSurfaceFile(run / ("surface_0000" + std::string(frame) + ".ply"));
    EXPECT_EQ(surfaces[name].get<size_t>(), m.vertices.size()) << "frame " << frame;
  }
}

// A scene whose only body is the particles of `ply` (a path relative to the scene), written
// next to it, with the smash scene's grid and solver.
fs::path pointsScene(const fs::path& dir, const std::string& ply) {
  auto scene = nlohmann::json::parse(std::ifstream(kSmash));
  scene["name"] = "continued";
  scene["bodies"] = {{{"shape", "points"}, {"file", ply}}};
  fs::create_directories(dir);
  const fs::path file = dir / "continued.json";
  std::ofstream(file) << scene.dump(2);
  return file;
}

TEST(Export, ARunContinuesFromAnotherRunsLastFrame) {
  const fs::path a = freshDir("export_a"), b = freshDir("export_b");
  runSmash(a, 0.1);
  const fs::path scene = pointsScene(a.parent_path(), "export_a/frame_00005.ply");
  const Result r = runSnowsim("run " + scene.string() + " -o " + b.string() +
                              " --no-png --no-mp4 --set time.duration=0.02");
  ASSERT_EQ(r.code, 0) << r.output;
  const snowsim::Snapshot last = snowsim::readPly((a / "frame_00005.ply").string());
  const snowsim::Snapshot first = snowsim::readPly((b / "frame_00000.ply").string());
  EXPECT_EQ(first.position, last.position);
  EXPECT_EQ(first.velocity, last.velocity);
  EXPECT_EQ(first.plastic_j, last.plastic_j) << "the compaction carries over";
  EXPECT_EQ(first.mass, last.mass);
  EXPECT_EQ(first.radius, last.radius);
  EXPECT_NE(snowsim::readPly((b / "frame_00001.ply").string()).position, first.position)
      << "and the run goes on from there";
}

TEST(Export, APointsBodyFileIsChecked) {
  const fs::path dir = freshDir("export_points_bad");
  const auto expectRefused = [&](const std::string& set, const std::string& says) {
    const Result r = runSnowsim("run " + pointsScene(dir, "state.ply").string() + " -o " +
                                (dir / "out").string() + " --no-png --no-mp4 " + set);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("bodies[0].file"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(says), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir / "out" / "frame_00000.ply"));
  };
  expectRefused("", "state.ply: cannot open");
  {
    std::ofstream ply(dir / "state.ply", std::ios::binary);
    ply << "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
        << "property float y\nproperty float z\nend_header\n";
    const float xyz[3] = {0.05f, 0.05f, 0.05f};
    ply.write(reinterpret_cast<const char*>(xyz), sizeof xyz);
  }
  expectRefused("", "no vertex property vx");
  const fs::path a = freshDir("export_points_source");
  runSmash(a, 0);
  fs::copy_file(a / "frame_00000.ply", dir / "state.ply", fs::copy_options::overwrite_existing);
  expectRefused("--set 'grid.cells=[4,10,8]'", "outside the grid along axis x");
  // A NaN or infinite coordinate is not said to lie outside the grid: it lies nowhere.
  snowsim::Snapshot state = snowsim::readPly((a / "frame_00000.ply").string());
  for (const double bad : {std::nan(""), -std::numeric_limits<double>::infinity()}) {
    snowsim::Snapshot broken = state;
    broken.position[3][1] = bad;
    snowsim::writePly((dir / "state.ply").string(), broken);
    expectRefused("", "state.ply: particle 3: its y coordinate (" +
                          std::string(std::isnan(bad) ? "nan" : "-inf") +
                          ") is not a finite number; allowed: [0, ");
  }
}

}  // namespace
