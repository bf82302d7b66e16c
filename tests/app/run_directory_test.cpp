// What `snowsim run` does with its output directory: an earlier run's files are refused or, with
// --overwrite, removed (and only they); run.json says how to reproduce the run; a write that fails
// mid-run names the file and leaves every earlier frame whole.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "render/image.h"
#include "sim/io/ply.h"
#include "sim/scene/json_fields.h"
#include "sim/scene/scene.h"
#include "tests/support/run_snowsim.h"
#include "tests/support/threaded_test.h"

namespace {

namespace fs = std::filesystem;

using snowsim_test::freshDir;
using snowsim_test::Result;
using snowsim_test::runSnowsim;
using snowsim_test::scene;

int countFrames(const fs::path& dir, const std::string& extension) {
  int n = 0;
  for (const auto& entry : fs::directory_iterator(dir))
    n += entry.path().extension() == extension &&
         entry.path().stem().string().rfind("frame_", 0) == 0;
  return n;
}

// The case: a 0.2 s rerun into the directory of a longer run.
TEST(RunDirectory, AnEarlierRunIsRefusedOrWithOverwriteReplacedLeavingOtherFiles) {
  const fs::path out = freshDir("rerun");
  const std::string run =
      "run " + scene("snowball_drop") + " -o " + out.string() + " --width 64 --height 64 ";
  ASSERT_EQ(runSnowsim(run + "--set time.duration=0.3").code, 0);
  ASSERT_EQ(countFrames(out, ".png"), 16);
  std::ofstream(out / "notes.txt") << "mine";
  std::ofstream(out / "frame_notes.png") << "not a frame of snowsim's";

  Result r = runSnowsim(run + "--set time.duration=0.1");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find(out.string() + ": holds an earlier run (16 PLY frames, 16 PNG frames, "
                                         "run.json, snowball_drop.mp4)"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("--overwrite"), std::string::npos) << r.output;
  EXPECT_EQ(countFrames(out, ".png"), 17) << "nothing is touched";

  r = runSnowsim(run + "--set time.duration=0.1 --overwrite");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("--overwrite: removed 16 PLY frames, 16 PNG frames, run.json, "
                          "snowball_drop.mp4 of an earlier run"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(countFrames(out, ".png"), 6 + 1);  // frames 0 to 5 and frame_notes.png
  EXPECT_EQ(countFrames(out, ".ply"), 6);
  EXPECT_TRUE(fs::exists(out / "notes.txt"));
  EXPECT_TRUE(fs::exists(out / "frame_notes.png"));
  EXPECT_EQ(nlohmann::json::parse(std::ifstream(out / "run.json"))["frames"], 6);
}

// A scene refused at set-up (a body that fills no particle, found only by sampling it) leaves an
// earlier run whole, --overwrite or not.
TEST(RunDirectory, ASceneRefusedAtSetUpLeavesTheEarlierRunWhole) {
  const fs::path out = freshDir("refused_at_set_up");
  ASSERT_EQ(runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                       " --set time.duration=0.04 --no-png --no-mp4")
                .code,
            0);
  const int frames = countFrames(out, ".ply");
  ASSERT_GT(frames, 1);
  // A plate 1 micrometre thick turned 45 degrees about z: wide along every axis, yet no point of
  // the particle lattice falls inside it.
  const fs::path inputs = freshDir("refused_at_set_up_inputs");
  fs::create_directories(inputs);
  std::ofstream plate(inputs / "plate.obj");
  for (int corner = 0; corner < 8; ++corner)
    plate << "v " << (corner & 4 ? 0.5 : -0.5) << " " << (corner & 2 ? 5e-6 : -5e-6) << " "
          << (corner & 1 ? 0.5 : -0.5) << "\n";
  plate << "f 1 2 4\nf 1 4 3\nf 5 7 8\nf 5 8 6\nf 1 5 6\nf 1 6 2\n"
        << "f 3 4 8\nf 3 8 7\nf 1 3 7\nf 1 7 5\nf 2 6 8\nf 2 8 4\n";
  plate.close();
  std::ofstream(inputs / "plate.json")
      << nlohmann::json{{"name", "plate"},
                        {"dimension", 3},
                        {"solver", "mpm"},
                        {"grid", {{"cells", {20, 20, 20}}, {"cell_size", 0.01}}},
                        {"particles_per_cell", 27},
                        {"bodies",
                         {{{"shape", "mesh"},
                           {"mesh", (inputs / "plate.obj").string()},
                           {"position", {0.1, 0.1, 0.1}},
                           {"scale", 0.1},
                           {"rotation", {0, 0, 45}}}}}};
  const Result r = runSnowsim("run " + (inputs / "plate.json").string() + " -o " + out.string() +
                              " --overwrite --no-png --no-mp4");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("bodies[0] holds no particles"), std::string::npos) << r.output;
  EXPECT_EQ(countFrames(out, ".ply"), frames) << "the earlier run's frames are kept";
  EXPECT_TRUE(fs::exists(out / "run.json"));
  EXPECT_FALSE(fs::exists(out / ".snowsim.lock")) << "an error leaves the directory's lock";
}

// An empty directory, or one with only other files, takes a run without --overwrite.
TEST(RunDirectory, OtherFilesDoNotStopARun) {
  const fs::path out = freshDir("other_files");
  fs::create_directories(out);
  std::ofstream(out / "README") << "results go here";
  const Result r = runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                              " --set time.duration=0.02 --no-png --no-mp4");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_FALSE(fs::exists(out / ".snowsim.lock")) << "a run that ended leaves its lock";
}

// run.json holds what reproduces the run: its resolved scene, run again with no --set or
// --quality, gives the same frames.
THREADED_TEST(RunDirectory, RunJsonRecordsWhatReproducesTheRun) {
  const fs::path out = freshDir("reproduce"), again = freshDir("reproduce_again");
  const Result r = runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                              " --no-png --no-mp4 --quality draft --threads 2 --set solver=mpm "
                              "--set time.duration=0.04 --set 'bodies[0].velocity=[0.5,0]'");
  ASSERT_EQ(r.code, 0) << r.output;
  const auto summary = nlohmann::json::parse(std::ifstream(out / "run.json"));
  EXPECT_EQ(summary["overrides"],
            nlohmann::json({"solver=mpm", "time.duration=0.04", "bodies[0].velocity=[0.5,0]"}));
  EXPECT_EQ(summary["quality"], "draft");
  EXPECT_EQ(summary["threads"], 2);
  EXPECT_FALSE(summary["snowsim"]["version"].get<std::string>().empty());
  EXPECT_FALSE(summary["snowsim"]["commit"].get<std::string>().empty());
  const auto& resolved = summary["resolved_scene"];
  EXPECT_EQ(resolved["solver"], "mpm");
  EXPECT_EQ(resolved["time"]["duration"], 0.04);
  EXPECT_EQ(resolved["bodies"][0]["velocity"], nlohmann::json({0.5, 0.0}));
  EXPECT_EQ(resolved["particles_per_cell"], 4) << "--quality draft gives MPM in 2D 4 a cell";

  const fs::path resolved_file = out.string() + ".scene.json";
  std::ofstream(resolved_file) << resolved.dump();
  const Result rerun = runSnowsim("run " + resolved_file.string() + " -o " + again.string() +
                                  " --no-png --no-mp4 --threads 1");
  ASSERT_EQ(rerun.code, 0) << rerun.output;
  const auto summary_again = nlohmann::json::parse(std::ifstream(again / "run.json"));
  EXPECT_EQ(summary_again["steps"], summary["steps"]);
  EXPECT_EQ(summary_again["resolved_scene"], resolved);
  for (const char* frame : {"frame_00000.ply", "frame_00002.ply"}) {
    const snowsim::Snapshot a = snowsim::readPly((out / frame).string());
    const snowsim::Snapshot b = snowsim::readPly((again / frame).string());
    EXPECT_EQ(a.position, b.position) << frame;
    EXPECT_EQ(a.velocity, b.velocity) << frame;
  }
}

// Every scene file written back parses to a scene that writes back the same.
TEST(RunDirectory, EveryScenesResolvedFormReadsBackTheSame) {
  for (const auto& entry :
       fs::recursive_directory_iterator(std::string(SNOWSIM_SOURCE_DIR) + "/scenes")) {
    if (!entry.is_regular_file() || entry.path().extension() != ".json" ||
        entry.path().filename() == "figures.json")
      continue;
    const snowsim::Scene s = snowsim::loadScene(entry.path().string());
    const auto written = snowsim::sceneToJson(s);
    EXPECT_EQ(snowsim::sceneToJson(snowsim::parseScene(written, "resolved")), written)
        << entry.path();
  }
}

// A full disk mid-run: frame 3's PLY goes to /dev/full (its temporary file is a link there), so
// the write fails with ENOSPC as on a full file system.
THREADED_TEST(RunDirectory, AFullDiskMidRunNamesTheFileAndKeepsEarlierFrames) {
  for (const std::string failing : {"frame_00003.ply", "frame_00003.png"}) {
    const fs::path out = freshDir("full_disk");
    fs::create_directories(out);
    fs::create_symlink("/dev/full", out / (failing + ".tmp"));
    const Result r = runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                                " --set time.duration=0.2 --width 64 --height 64 --no-mp4 "
                                "--checkpoint-every 1");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(
        r.output.find((out / failing).string() + ": writing failed (No space left on device)"),
        std::string::npos)
        << r.output;
    EXPECT_FALSE(fs::exists(out / failing));
    EXPECT_FALSE(fs::exists(out / "run.json")) << "an unfinished run has no summary";
    for (int frame = 0; frame < 3; ++frame) {
      char name[32];
      std::snprintf(name, sizeof name, "frame_%05d", frame);
      EXPECT_EQ(snowsim::readPly((out / (std::string(name) + ".ply")).string()).size(), 25);
      EXPECT_EQ(snowsim::readPng((out / (std::string(name) + ".png")).string()).width, 64);
    }
    // The last checkpoint, after frame 2, is intact: with room again, resume finishes the run.
    fs::remove(out / (failing + ".tmp"));
    const Result resumed = runSnowsim("resume " + out.string());
    EXPECT_EQ(resumed.code, 0) << resumed.output;
    EXPECT_EQ(snowsim::readPly((out / "frame_00003.ply").string()).size(), 25);
    EXPECT_EQ(snowsim::readPng((out / "frame_00003.png").string()).width, 64);
    EXPECT_EQ(snowsim::readPly((out / "frame_00010.ply").string()).size(), 25);
  }
}

}  // namespace
