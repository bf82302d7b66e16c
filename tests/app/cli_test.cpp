// The command line as a user meets it: exit codes, messages, and no half-written output.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <regex>
#include <set>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "render/image.h"
#include "sim/io/ply.h"
#include "tests/support/run_snowsim.h"
#include "tests/support/threaded_test.h"

namespace {

namespace fs = std::filesystem;

using snowsim_test::freshDir;
using snowsim_test::Result;
using snowsim_test::runCommand;
using snowsim_test::runSnowsim;
using snowsim_test::scene;
using snowsim_test::startSnowsim;

// Whether every line of a run's output is a per-frame progress line, the memory or the cost
// estimate: nothing else to say.
bool onlyProgress(const std::string& output) {
  std::istringstream lines(output);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind("frame ", 0) != 0 && line.find("particle-steps") == std::string::npos &&
        line.find(": memory: about ") == std::string::npos)
      return false;
  return true;
}

nlohmann::json runSummary(const fs::path& out) {
  return nlohmann::json::parse(std::ifstream(out / "run.json"));
}

// Threaded: its PNGs go through the writer's thread, as every `snowsim run` writing PNGs does.
THREADED_TEST(Cli, RunWritesPlyFramesAndASummary) {
  const fs::path out = freshDir("ok");
  const Result r = runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                              " --set time.duration=0.1");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(out / "frame_00000.ply"));
  EXPECT_TRUE(fs::exists(out / "frame_00005.ply"));
  EXPECT_TRUE(fs::exists(out / "frame_00005.png"));
  EXPECT_FALSE(fs::exists(out / "frame_00006.ply"));
  const auto summary = nlohmann::json::parse(std::ifstream(out / "run.json"));
  EXPECT_EQ(summary["steps"], 100);
  EXPECT_EQ(summary["particles"], 25);
  EXPECT_EQ(summary["dimension"], 2);
  EXPECT_DOUBLE_EQ(summary["simulated_time"].get<double>(), 0.1);
  EXPECT_TRUE(summary.contains("wall_time"));
  EXPECT_FALSE(summary.contains("implicit_solves")) << "no semi-implicit solves to count";
  EXPECT_TRUE(onlyProgress(r.output)) << "only a line per frame off a terminal:\n" << r.output;
}

// A semi-implicit run counts its linear solves in run.json, and says so when some stopped at
// the iteration limit short of the tolerance.
TEST(Cli, RunCountsTheSemiImplicitSolves) {
  const fs::path out = freshDir("semi");
  const std::string run = "run " + scene("study_smash_3d") + " -o " + out.string() +
                          " --no-png --no-mp4 --no-ply --set time.duration=0.03" +
                          " --set mpm.integrator=semi_implicit";  // the ball meets the wall
  Result r = runSnowsim(run);
  ASSERT_EQ(r.code, 0) << r.output;
  auto solves = nlohmann::json::parse(std::ifstream(out / "run.json"))["implicit_solves"];
  EXPECT_GT(solves["solves"].get<int>(), 0);
  EXPECT_EQ(solves["unconverged"], 0);
  EXPECT_TRUE(onlyProgress(r.output)) << r.output;

  r = runSnowsim(run + " --overwrite --set mpm.max_iterations=2");
  ASSERT_EQ(r.code, 0) << r.output;
  solves = nlohmann::json::parse(std::ifstream(out / "run.json"))["implicit_solves"];
  EXPECT_GT(solves["unconverged"].get<int>(), 0);
  EXPECT_EQ(solves["most_iterations"], 2);
  EXPECT_NE(r.output.find("study_smash_3d.json"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("mpm.max_iterations (2)"), std::string::npos) << r.output;
}

// Each bad input: exit code 2, a message with the expected words, nothing written.
void expectRejected(const std::string& args, const std::string& expected_message) {
  const fs::path out = freshDir("rejected");
  const Result r = runSnowsim(args + " -o " + out.string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find(expected_message), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out)) << "output written for bad input: " << args;
}

TEST(Cli, BadInputExitsTwoWithAClearMessageAndWritesNothing) {
  const fs::path bad = freshDir("bad_scene");
  fs::create_directories(bad);
  std::ofstream(bad / "broken.json") << "{\n  \"name\": \"x\",\n  \"bodies\": [\n}\n";
  expectRejected("run " + (bad / "broken.json").string(), "broken.json:4:");
  expectRejected("run " + scene("snowball_drop") + " --set time.dt=-1",
                 "time.dt: -1 is out of range");
  expectRejected("run " + scene("snowball_drop") + " --set bodies.0.raduis=0.01",
                 "did you mean \"radius\"");
  expectRejected("run " + scene("snowball_drop") + " --set output.checkpoint_every=3",
                 "did you mean \"checkpoint_every_frames\"");
  expectRejected("run " + scene("snowball_drop") + " --set grid.cells=[0,12]", "grid.cells");
  expectRejected("run " + scene("snowball_drop") + " --set bodies.0.center=[0.5,0.05]",
                 "outside the grid");
  expectRejected("run " + scene("snowball_drop") + " --set bodies.0.radius=0.5",
                 "--set bodies.0.radius=0.5 on");
  expectRejected("run " + scene("mpm_snowball_wall") + " --set grid.cells=[32,20]",
                 "grid.cells: has 2 entries, which makes the scene 2D");
  expectRejected("run " + scene("snowball_drop") + " --set time.dt", "expected key=value");
  expectRejected("run missing.json", "missing.json");
  expectRejected("run " + scene("snowball_drop") + " --color-by temperature",
                 "allowed: white, density, speed");
  expectRejected("run " + scene("snowball_drop") + " --width 0", "out of range");
  expectRejected("run " + scene("snowball_drop") + " --width 201", "even width and height");
  expectRejected("run " + scene("snowball_drop") + " --set render.width=201",
                 "even width and height, got 201x");
  expectRejected("run " + scene("snowball_drop") + " --mp4-codec nonesuch", "--mp4-codec");
  expectRejected("run " + scene("snowball_drop") + " --mp4-crf 60", "--mp4-crf: 60");
  expectRejected("run " + scene("snowball_drop") + " --mp4-fps -5", "--mp4-fps");
  expectRejected("run " + scene("snowball_drop") + " --mp4-fps 0", "--mp4-fps: 0 is outside");
  expectRejected("run " + scene("snowball_drop") + " --checkpoint-every -1",
                 "--checkpoint-every: \"-1\" is not allowed; allowed: a whole number, 0 or more");
  expectRejected("run " + scene("snowball_drop") + " --checkpoint-every 1e3",
                 "--checkpoint-every: \"1e3\" is not allowed; allowed: a whole number, 0 or more");
  expectRejected("run " + scene("snowball_drop") + " --checkpoint-minutes ten",
                 "--checkpoint-minutes: \"ten\" is not allowed; allowed: a number, 0 or more");
  expectRejected("figure " + scene("snowball_drop") + " --times 0.2,5", "--times: 5 is not");
  expectRejected("figure " + scene("snowball_drop") + " --threads 0", "--threads");
  expectRejected("figure fig2 --set time.duration=0.01", "fig2.rows[0].times: 0.02 is not");
  expectRejected("run " + scene("snowball_drop") + " --look noir", "allowed: studio, figure");
  expectRejected("run " + scene("snowball_drop") + " --background 1,2,0", "--background");
  expectRejected("run " + scene("mpm_snowball_drop_3d") + " --fov 0",
                 "camera field of view (--fov, render.camera.fov) 0 is out of range");
  expectRejected("run " + scene("snowball_drop") + " --color-range 3,1",
                 "colour range (--color-range, render.color_range) [3, 1] is empty");
  expectRejected("run " + scene("snowball_drop") + " --sphere-radius 20",
                 "sphere radius (--sphere-radius, render.sphere_radius) 20 is out of range");
  expectRejected("run " + scene("snowball_drop") + " --colour-by heat",
                 "allowed: white, density, speed");
  // The parser's own errors in snowsim's form.
  expectRejected("run " + scene("snowball_drop") + " --no-such-option",
                 "snowsim: error: The following argument was not expected: --no-such-option");
  expectRejected("run " + scene("snowball_drop") + " --threads 0",
                 "snowsim: error: --threads: \"0\" is not allowed");
  expectRejected("run " + scene("snowball_drop") + " --set render.look=noir", "render.look");
}

// A bad value given by --set is blamed on the assignment, which the user can find and fix.
TEST(Cli, ErrorsOfSetNameTheAssignment) {
  expectRejected("run " + scene("snowball_drop") + " --set mpm.cfl=-1",
                 "--set mpm.cfl=-1 on " + scene("snowball_drop") +
                     ": mpm.cfl: -1 is out of range; allowed: (0, 1]");
  expectRejected("run " + scene("snowball_drop") + " --set 'bodies[0].raduis=0.01'",
                 "--set bodies[0].raduis=0.01 on");
}

TEST(Cli, SetTakesArrayIndicesInBrackets) {
  const fs::path out = freshDir("brackets");
  const std::string run = "run " + scene("snowball_drop") + " -o " + out.string() +
                          " --no-png --no-mp4 --set time.duration=0.02 ";
  Result r = runSnowsim(run + "--set 'bodies[0].radius=0.02'");
  ASSERT_EQ(r.code, 0) << r.output;
  const int bigger = nlohmann::json::parse(std::ifstream(out / "run.json"))["particles"];
  r = runSnowsim(run + "--overwrite --set bodies.0.radius=0.02");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(nlohmann::json::parse(std::ifstream(out / "run.json"))["particles"], bigger);
  EXPECT_GT(bigger, 25) << "the ball of radius 0.0095 m has 25 particles";
}

// --scale S: S times the cells along each axis over the same domain, the bodies kept at their
// particles per cell: S^2 times the particles of a 2D box whose edges lie on both lattices.
TEST(Cli, ScaleRefinesTheGridAndKeepsTheBodies) {
  const fs::path dir = freshDir("scale");
  fs::create_directories(dir);
  std::ofstream(dir / "box.json") << R"({"name": "box", "particles_per_cell": 4,
    "grid": {"cells": [8, 8], "cell_size": 0.25},
    "time": {"dt": 0.002, "duration": 0.004, "fps": 250},
    "bodies": [{"shape": "box", "center": [1, 1], "size": [1, 1]}]})";
  const std::string run = "run " + (dir / "box.json").string() + " --no-png --no-mp4 --no-ply";
  Result r = runSnowsim(run + " -o " + (dir / "plain").string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("box: 64 particles, 8 x 8 cells of 0.25 m; 0.004 s simulated at a "
                          "first step of 0.002 s: about 2 steps, 128 particle-steps"),
            std::string::npos)
      << r.output;
  for (const double scale : {2.0, 0.5}) {
    const fs::path out = dir / ("scaled" + std::to_string(scale));
    r = runSnowsim(run + " -o " + out.string() + " --scale " + std::to_string(scale));
    ASSERT_EQ(r.code, 0) << r.output;
    const auto summary = runSummary(out);
    EXPECT_EQ(summary["particles"].get<double>(), 64 * scale * scale);
    EXPECT_DOUBLE_EQ(summary["cell_size"].get<double>(), 0.25 / scale);
    EXPECT_EQ(summary["scale"].get<double>(), scale);
    EXPECT_EQ(summary["steps"].get<double>(), 2 * scale) << "a fixed step follows the cell";
  }
  r = runSnowsim(run + " -o " + (dir / "scaled").string() + " --scale 2 --set time.dt=0.002");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(runSummary(dir / "scaled")["steps"], 2) << "the user's --set time.dt is kept";

  const fs::path refused = dir / "refused";
  for (const auto& [scale, message] :
       {std::pair<std::string, std::string>{
            "1.1", "--scale 1.1: " + (dir / "box.json").string() +
                       ": grid.cells: 1.1 times 8 cells is 8.8; allowed: a whole number "
                       "from 1 to 4096 along each axis"},
        {"0", "--scale 0: allowed: a number above 0"},
        {"-2", "--scale -2: allowed: a number above 0"}}) {
    r = runSnowsim(run + " -o " + refused.string() + " --scale " + scale);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(refused)) << "nothing is written for bad input";
  }
}

// Once its first steps are measured, a run says how long its steps will take.
TEST(Cli, RunEstimatesItsCostFromItsFirstSteps) {
  const fs::path out = freshDir("estimate");
  const Result r = runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                              " --no-png --no-mp4 --no-ply --set time.duration=0.2");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("snowball_drop: 25 particles, 10 x 12 cells of 0.01 m; 0.2 s simulated "
                          "at a first step of 0.001 s: about 200 steps, 5000 particle-steps"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("snowball_drop: estimate: the steps take about "), std::string::npos)
      << r.output;
  EXPECT_TRUE(
      std::regex_search(r.output, std::regex("particle-steps a second over steps 2-[0-9]+")))
      << r.output;

  // --estimate stops there and writes nothing.
  const fs::path none = freshDir("estimate_only");
  const Result e = runSnowsim("run " + scene("snowball_drop") + " -o " + none.string() +
                              " --estimate --scale 2");
  ASSERT_EQ(e.code, 0) << e.output;
  EXPECT_NE(e.output.find("snowball_drop: 96 particles, 20 x 24 cells of 0.005 m; 1 s "
                          "simulated at a first step of 0.0005 s: about 2000 steps, 192 thousand "
                          "particle-steps"),
            std::string::npos)
      << e.output;
  EXPECT_NE(e.output.find("snowball_drop: estimate: the steps take about "), std::string::npos)
      << e.output;
  EXPECT_EQ(e.output.find("frame "), std::string::npos) << e.output;
  EXPECT_FALSE(fs::exists(none));

  // Cracks that open cost more once the snow stretches, which the first steps may not show.
  const Result cracks = runSnowsim("run " + scene("snowball_drop") + " -o " + none.string() +
                                   " --estimate --set solver=mpm --set mpm.open_cracks=true "
                                   "--set material.fracture_strain=0.3");
  ASSERT_EQ(cracks.code, 0) << cracks.output;
  EXPECT_NE(cracks.output.find("stretched past J_P = 1 (mpm.open_cracks)"), std::string::npos)
      << cracks.output;
  // Snow stretched from the first steps (two blocks pulled apart) runs the crack passes in the
  // steps the rate is measured over: the estimate holds them already.
  const fs::path apart = freshDir("estimate_apart");
  fs::create_directories(apart);
  std::ofstream(apart / "apart.json") << R"({"name": "apart", "solver": "mpm",
    "particles_per_cell": 4, "grid": {"cells": [40, 30], "cell_size": 0.01},
    "time": {"dt": 0.0005, "duration": 0.05, "fps": 100},
    "mpm": {"open_cracks": true}, "material": {"preset": "paper", "fracture_strain": 0.02},
    "bodies": [{"shape": "box", "center": [0.15, 0.15], "size": [0.1, 0.1], "velocity": [-2, 0]},
               {"shape": "box", "center": [0.25, 0.15], "size": [0.1, 0.1], "velocity": [2, 0]}]})";
  const Result pulled = runSnowsim("run " + (apart / "apart.json").string() + " -o " +
                                   (apart / "out").string() + " --estimate");
  ASSERT_EQ(pulled.code, 0) << pulled.output;
  EXPECT_NE(pulled.output.find("apart: estimate: the steps take about "), std::string::npos)
      << pulled.output;
  EXPECT_EQ(pulled.output.find("stretched past J_P = 1 (mpm.open_cracks)"), std::string::npos)
      << pulled.output;

  // A run of no duration (a scene's first frame only) takes no step, not "-0".
  const Result zero = runSnowsim("run " + scene("snowball_drop") + " -o " + none.string() +
                                 " --estimate --set time.duration=0");
  ASSERT_EQ(zero.code, 0) << zero.output;
  EXPECT_NE(zero.output.find("about 0 steps, 0 particle-steps"), std::string::npos) << zero.output;
}

// run.json says where the wall time went: the solver's stages and the main thread's, each a
// share of the run's wall time, together no more than it.
TEST(Cli, RunRecordsItsStageTimes) {
  const fs::path out = freshDir("stages");
  for (const std::string integrator : {"explicit", "semi_implicit"}) {
    const Result r = runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                                " --overwrite --set solver=mpm --set time.duration=0.02 --width 64 "
                                "--height 48 --no-mp4 --set mpm.integrator=" +
                                integrator);
    ASSERT_EQ(r.code, 0) << r.output;
    const auto summary = runSummary(out);
    const double wall = summary["wall_time"];
    double sum = 0;
    std::set<std::string> names;
    for (const auto& stage : summary["stages"]) {
      const double seconds = stage["seconds"];
      EXPECT_GE(seconds, 0) << stage;
      EXPECT_DOUBLE_EQ(stage["share"].get<double>(), seconds / wall) << stage;
      sum += seconds;
      names.insert(stage["stage"].get<std::string>());
    }
    EXPECT_LE(sum, wall);
    for (const char* stage : {"setup", "scatter", "grid update", "move particles",
                              "rest of the step", "snapshot", "write PLY", "render"})
      EXPECT_EQ(names.count(stage), 1) << integrator << ": " << stage;
    EXPECT_EQ(names.count("implicit solve"), integrator == "semi_implicit") << integrator;
  }
}

// A step that collapses is reported once, with its cause: the hardening of compacted snow, or the
// speed of the snow; a calm run (the step halves as the ball lands) says nothing.
TEST(Cli, RunWarnsWhenTheStepCollapses) {
  const fs::path out = freshDir("collapse");
  const std::string run = "run " + scene("snowball_drop") + " -o " + out.string() +
                          " --overwrite --no-png --no-mp4 --no-ply --set solver=mpm ";
  Result r = runSnowsim(run + "--set time.duration=0.3");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.output.find("warning"), std::string::npos) << r.output;
  EXPECT_FALSE(runSummary(out).contains("step_collapse"));

  // A ball thrown at the ground at 16 m/s: the snow it compacts hardens.
  r = runSnowsim(run + "--set time.duration=0.04 --set 'bodies[0].velocity=[0,-16]'");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("the time step fell below a quarter of the"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("s it started at, to "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("the snow hardened. Its stiffest elastic wave runs at"),
            std::string::npos)
      << r.output;
  auto collapse = runSummary(out)["step_collapse"];
  EXPECT_EQ(collapse["cause"], "hardening");
  EXPECT_LT(collapse["step_size"].get<double>(),
            0.25 * collapse["initial_step_size"].get<double>());
  EXPECT_GT(collapse["hardening"].get<double>(), 16) << "the wave four times as fast";

  // Soft snow falling under strong gravity from a step of its slow wave: its speed sets the step.
  r = runSnowsim(run + "--set time.duration=0.04 --set time.dt=0.05 --set material.E0=300 " +
                 "--set 'gravity=[0,-100]'");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("the snow sped up. It moves at"), std::string::npos) << r.output;
  collapse = runSummary(out)["step_collapse"];
  EXPECT_EQ(collapse["cause"], "speed");
  EXPECT_GT(collapse["particle_speed"].get<double>(), collapse["wave_speed"].get<double>());
  EXPECT_EQ(r.output.find("warning"), r.output.rfind("warning")) << "once:\n" << r.output;
}

// A still collider placed wholly outside the grid touches no snow: the run says so and goes on.
// One that reaches in, or moves, is not warned about.
TEST(Cli, RunWarnsOfAStillColliderOutsideTheGrid) {
  const fs::path out = freshDir("collider_outside");
  const std::string run = "run " + scene("mpm_snowball_wall") + " -o " + out.string() +
                          " --overwrite --estimate --threads 1 ";
  Result r = runSnowsim(run + "--set 'colliders[0].position=[5,5,5]'");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("colliders[0] lies wholly outside the grid (8.14 m beyond it"),
            std::string::npos)
      << r.output;
  for (const char* inside :
       {"", "--set 'colliders[0].position=[-0.02,0.1,0.08]'",
        "--set 'colliders[0].position=[5,5,5]' --set 'colliders[0].velocity=[-10,-10,-10]'"}) {
    r = runSnowsim(run + inside);
    ASSERT_EQ(r.code, 0) << inside << ": " << r.output;
    EXPECT_EQ(r.output.find("outside the grid"), std::string::npos) << inside << ": " << r.output;
  }
}

TEST(Cli, ThreadsMustBeAWholeNumberFrom1To1024) {
  for (const char* bad : {"0", "abc", "1025", "-3", "2.5"})
    expectRejected("run " + scene("snowball_drop") + " --threads " + bad,
                   "allowed: a whole number from 1 to 1024");
  const fs::path out = freshDir("threads");
  const Result r = runSnowsim("run " + scene("mpm_reference") + " -o " + out.string() +
                              " --no-png --no-mp4 --threads 1 --set time.duration=0.02");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(out / "frame_00001.ply"));
  const Result study = runSnowsim("study --quick --threads 0 -o " + (out / "s.csv").string());
  EXPECT_EQ(study.code, 2) << study.output;
  EXPECT_FALSE(fs::exists(out / "s.csv"));
}

// The scene file is read once, whatever the options: a named pipe, which can be read only once,
// serves as the scene of a run at a quality level.
TEST(Cli, RunReadsTheSceneOnce) {
  const fs::path dir = freshDir("fifo");
  fs::create_directories(dir);
  const fs::path fifo = dir / "scene.json";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  std::stringstream text;
  text << std::ifstream(scene("snowball_drop")).rdbuf();
  std::thread writer([&] { std::ofstream(fifo) << text.str(); });
  const Result r = runCommand("timeout 60 " + std::string(SNOWSIM_BINARY) + " run " +
                              fifo.string() + " -o " + (dir / "out").string() +
                              " --quality draft --no-png --no-mp4 --set time.duration=0.02");
  // Should snowsim not have opened the pipe, a reader lets the writer finish.
  const int reader = open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
  writer.join();
  close(reader);
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(dir / "out" / "run.json"));
}

TEST(Cli, VersionNamesTheCommit) {
  const Result r = runSnowsim("--version");
  EXPECT_EQ(r.code, 0);
  std::smatch m;
  ASSERT_TRUE(
      std::regex_search(r.output, m, std::regex(R"(^snowsim \d+\.\d+\S* \(commit (\S+)\))")))
      << r.output;
  if (fs::exists(fs::path(SNOWSIM_SOURCE_DIR) / ".git"))
    EXPECT_TRUE(std::regex_match(m[1].str(), std::regex("[0-9a-f]{7,40}"))) << r.output;
  else
    EXPECT_EQ(m[1].str(), "unknown");
}

// What ffprobe reads of a video: codec, size, pixel format and the frames it decodes.
struct Probe {
  std::string codec, pix_fmt;
  int width = 0, height = 0, frames = 0;
};

Probe probe(const fs::path& video) {
  const std::string command =
      "ffprobe -v error -count_frames -select_streams v:0 -show_entries "
      "stream=codec_name,width,height,pix_fmt,nb_read_frames -of json " +
      video.string();
  FILE* pipe = popen(command.c_str(), "r");
  std::string text;
  std::array<char, 4096> buffer;
  while (size_t n = fread(buffer.data(), 1, buffer.size(), pipe)) text.append(buffer.data(), n);
  pclose(pipe);
  const auto json = nlohmann::json::parse(text, nullptr, false);
  Probe p;
  if (json.is_discarded() || json["streams"].empty()) return p;
  const auto& stream = json["streams"][0];
  p.codec = stream.value("codec_name", "");
  p.pix_fmt = stream.value("pix_fmt", "");
  p.width = stream.value("width", 0);
  p.height = stream.value("height", 0);
  p.frames = std::stoi(stream.value("nb_read_frames", "0"));
  return p;
}

TEST(Cli, RunEncodesItsFramesIntoAnMp4ThatFfprobeReads) {
  const fs::path out = freshDir("video");
  const Result r =
      runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                 " --set time.duration=0.2 --no-ply --no-png --width 320 --height 240");
  ASSERT_EQ(r.code, 0) << r.output;
  const Probe video = probe(out / "snowball_drop.mp4");
  EXPECT_EQ(video.codec, "h264");
  EXPECT_EQ(video.pix_fmt, "yuv420p");
  EXPECT_EQ(video.width, 320);
  EXPECT_EQ(video.height, 240);
  EXPECT_EQ(video.frames, 11);  // 0.2 s at 50 frames a second, and the first frame
  EXPECT_FALSE(fs::exists(out / "snowball_drop.mp4.part"));
}

// After `path` exists, one more second, then the signal: returns the seconds until the child
// exited and its wait status.
std::pair<double, int> signalOnceWritten(pid_t child, const fs::path& path, int sig) {
  for (int i = 0; i < 200 && !fs::exists(path); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const auto signalled = std::chrono::steady_clock::now();
  kill(child, sig);
  int status = 0;
  waitpid(child, &status, 0);
  return {std::chrono::duration<double>(std::chrono::steady_clock::now() - signalled).count(),
          status};
}

// SIGTERM in the middle of a long run: the video so far is finalised and plays, run.json says
// how many frames it holds, the exit code is 128 + 15.
THREADED_TEST(Cli, SigtermFinalisesTheVideoWrittenSoFar) {
  const fs::path out = freshDir("interrupted");
  const pid_t child = startSnowsim({"run", scene("snowball_drop"), "-o", out.string(), "--set",
                                    "time.duration=1000", "--no-ply", "--no-png", "--width", "160",
                                    "--height", "120"});
  ASSERT_GE(child, 0);
  // Let it encode some frames first (x264 holds its first frames back, so the file stays small).
  const fs::path part = out / "snowball_drop.mp4.part";
  const int status = signalOnceWritten(child, part, SIGTERM).second;
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 128 + SIGTERM);
  EXPECT_FALSE(fs::exists(part));
  const auto summary = nlohmann::json::parse(std::ifstream(out / "run.json"));
  EXPECT_EQ(summary["interrupted_by_signal"], SIGTERM);
  const Probe video = probe(out / "snowball_drop.mp4");
  EXPECT_EQ(video.width, 160);
  EXPECT_GT(video.frames, 1);
  EXPECT_EQ(video.frames, summary["frames"].get<int>());
}

// A signal stops the run at the end of the current step, not at the next frame: here a frame is
// 2 s of simulated snow, many seconds of stepping, and the run must end long before the next one.
THREADED_TEST(Cli, SigtermStopsWithinAFewStepsNotAtTheNextFrame) {
  const fs::path out = freshDir("interrupted_mid_frame");
  const pid_t child =
      startSnowsim({"run", scene("mpm_snowball_wall"), "-o", out.string(), "--set",
                    "time.duration=1000", "--set", "time.fps=0.5", "--no-png", "--no-mp4"});
  ASSERT_GE(child, 0);
  const auto [seconds, status] = signalOnceWritten(child, out / "frame_00000.ply", SIGTERM);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 128 + SIGTERM);
  // Stepping on to the next frame takes over ten seconds on a 2-core machine; a step, milliseconds.
  EXPECT_LT(seconds, 5.0);
  const auto summary = nlohmann::json::parse(std::ifstream(out / "run.json"));
  EXPECT_EQ(summary["frames"], 1);
  EXPECT_GT(summary["steps"].get<long>(), 0);
  EXPECT_LT(summary["simulated_time"].get<double>(), 2.0);
  EXPECT_FALSE(fs::exists(out / "frame_00001.ply"));
}

// Off a terminal (a log, a cluster job) a run reports each frame on a line of its own, with the
// simulated time, the steps, the step size and the time left.
TEST(Cli, OffATerminalEachFrameGetsAProgressLine) {
  const fs::path out = freshDir("progress");
  const Result r = runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                              " --set time.duration=0.04 --no-png --no-mp4");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("frame 0/2  t = 0.000 / 0.040 s  0 steps"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("frame 1/2  t = 0.020 / 0.040 s  20 steps"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("dt 1.0e-03 s  ETA"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("frame 2/2  t = 0.040 / 0.040 s  40 steps"), std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find('\r'), std::string::npos) << "no terminal redraws in a log";
  EXPECT_EQ(r.output.find("asleep"), std::string::npos) << r.output;

  // With auto-sleep, the share of the particles asleep: snow lying on the ground falls asleep.
  const Result sleeping = runSnowsim(
      "run " + scene("mpm_reference") + " -o " + out.string() +
      " --overwrite --set time.duration=0.6 --set time.fps=5 --set mpm.auto_sleep.enabled=true "
      "--no-png --no-mp4 --no-ply");
  ASSERT_EQ(sleeping.code, 0) << sleeping.output;
  EXPECT_NE(sleeping.output.find("frame 1/3  t = 0.200 / 0.600 s"), std::string::npos)
      << sleeping.output;
  const std::regex asleep(R"(frame 3/3 .* dt [0-9.e+-]+ s  ([0-9]+)% asleep)");
  std::smatch share;
  ASSERT_TRUE(std::regex_search(sleeping.output, share, asleep)) << sleeping.output;
  EXPECT_GT(std::stoi(share[1]), 0) << sleeping.output;
}

// run.json gives the step sizes the policy chose: one fixed step for the report's method, a range
// for MPM's adaptive step, which shrinks as the ball lands and hardens.
TEST(Cli, RunRecordsTheStepSizes) {
  const fs::path fixed = freshDir("steps_fixed"), adaptive = freshDir("steps_adaptive");
  ASSERT_EQ(runSnowsim("run " + scene("snowball_drop") + " -o " + fixed.string() +
                       " --set time.duration=0.05 --no-png --no-mp4 --no-ply")
                .code,
            0);
  const auto report = nlohmann::json::parse(std::ifstream(fixed / "run.json"))["step_size"];
  EXPECT_DOUBLE_EQ(report["smallest"].get<double>(), 0.001);
  EXPECT_DOUBLE_EQ(report["largest"].get<double>(), 0.001);
  EXPECT_NEAR(report["mean"].get<double>(), 0.001, 1e-12);

  ASSERT_EQ(runSnowsim("run " + scene("mpm_snowball_wall") + " -o " + adaptive.string() +
                       " --set time.duration=0.2 --no-png --no-mp4 --no-ply")
                .code,
            0);
  const auto summary = nlohmann::json::parse(std::ifstream(adaptive / "run.json"));
  const auto mpm = summary["step_size"];
  EXPECT_LT(mpm["smallest"].get<double>(), 0.5 * mpm["largest"].get<double>());
  EXPECT_LE(mpm["smallest"].get<double>(), mpm["mean"].get<double>());
  EXPECT_NEAR(mpm["mean"].get<double>(), 0.2 / summary["steps"].get<double>(), 1e-12);
}

TEST(Cli, RenderRedrawsSavedFrames) {
  const fs::path out = freshDir("render");
  ASSERT_EQ(runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                       " --set time.duration=0.04 --no-png")
                .code,
            0);
  EXPECT_FALSE(fs::exists(out / "frame_00000.png"));
  const Result r = runSnowsim("render " + out.string() +
                              " --color-by density --width 200 --height 100 "
                              "--overwrite");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(out / "frame_00002.png"));
  EXPECT_NE(r.output.find("3 frames drawn into " + out.string()), std::string::npos) << r.output;
  const Result nothing = runSnowsim("render " + out.string() + " --no-png --no-mp4");
  EXPECT_EQ(nothing.code, 2) << nothing.output;
  EXPECT_NE(nothing.output.find("nothing left to write"), std::string::npos) << nothing.output;
  // A damaged frame stops it before the first image, also where the run's own colouring and
  // camera leave nothing to read from the frames.
  fs::resize_file(out / "frame_00002.ply", fs::file_size(out / "frame_00002.ply") / 2);
  const fs::path again = freshDir("render_damaged");
  const Result damaged = runSnowsim("render " + out.string() + " -o " + again.string());
  EXPECT_EQ(damaged.code, 2) << damaged.output;
  EXPECT_NE(damaged.output.find("frame_00002.ply"), std::string::npos) << damaged.output;
  EXPECT_FALSE(fs::exists(again)) << "images written before the damaged frame";
}

// The surface look and its files: a run draws it and says how many grains it left loose, `render`
// draws a saved run so (the surface meshes are not frames to it), --overwrite removes the meshes.
TEST(Cli, SurfaceLookDrawsARunAndItsSavedFrames) {
  const fs::path out = freshDir("surface_look");
  const std::string run = "run " + scene("study_smash_3d") + " -o " + out.string() +
                          " --set time.duration=0.04 --width 96 --height 64 --no-mp4 --surface "
                          "--look surface --color-by plastic";
  const Result r = runSnowsim(run);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("snowsim: surface: at most "), std::string::npos) << r.output;
  const nlohmann::json summary = nlohmann::json::parse(std::ifstream(out / "run.json"));
  EXPECT_EQ(summary["drawing"]["look"], "surface");
  EXPECT_EQ(summary["drawing"]["surface"]["filter"], "gaussian");
  EXPECT_EQ(summary["surface"]["frames"], 3);
  EXPECT_LE(summary["surface"]["most_loose"]["loose_grains"].get<int>(),
            summary["surface"]["most_loose"]["particles"].get<int>());
  for (const char* name : {"frame_00002.png", "surface_00002.ply", "frame_00002.ply"})
    EXPECT_TRUE(fs::exists(out / name)) << name;

  // Redrawn from the saved particles, as the run drew it.
  const fs::path again = out / "again";
  const Result render =
      runSnowsim("render " + out.string() + " -o " + again.string() + " --no-mp4");
  ASSERT_EQ(render.code, 0) << render.output;
  EXPECT_NE(render.output.find("3 frames drawn"), std::string::npos) << render.output;
  EXPECT_EQ(snowsim::readPng((again / "frame_00002.png").string()).rgba,
            snowsim::readPng((out / "frame_00002.png").string()).rgba);

  const Result refused = runSnowsim(run);
  EXPECT_EQ(refused.code, 2);
  EXPECT_NE(refused.output.find("3 surface PLY frames"), std::string::npos) << refused.output;
  ASSERT_EQ(runSnowsim(run + " --overwrite --set time.duration=0.02").code, 0);
  EXPECT_FALSE(fs::exists(out / "surface_00002.ply")) << "an earlier run's mesh left behind";
  EXPECT_TRUE(fs::exists(out / "surface_00001.ply"));

  const Result bad = runSnowsim(run + " --overwrite --surface-filter box");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.output.find("--surface-filter: \"box\" is not allowed; allowed: gaussian, "
                            "mean-curvature, none"),
            std::string::npos)
      << bad.output;
  const Result coarse = runSnowsim(run + " --overwrite --surface-voxel 0");
  EXPECT_EQ(coarse.code, 2);
  EXPECT_NE(coarse.output.find("--surface-voxel 0 is out of range"), std::string::npos)
      << coarse.output;
}

// --supersample is recorded in run.json and `render` draws the run so again; --no-supersample
// redraws it with FXAA, another picture of the same close-up impostor frame.
TEST(Cli, SupersamplingIsRecordedAndRedrawnAsTheRunDrewIt) {
  const fs::path out = freshDir("supersample");
  const Result r = runSnowsim("run " + scene("mpm_snowball_wall") + " -o " + out.string() +
                              " --set time.duration=0.1 --set time.fps=10 --width 320 "
                              "--height 180 --camera-eye 0.12,0.16,0.2 --camera-target "
                              "0.26,0.1,0.08 --no-mp4 --supersample");
  ASSERT_EQ(r.code, 0) << r.output;
  const nlohmann::json summary = nlohmann::json::parse(std::ifstream(out / "run.json"));
  EXPECT_EQ(summary["drawing"]["supersample"], true);
  const fs::path again = out / "again", fxaa = out / "fxaa";
  ASSERT_EQ(runSnowsim("render " + out.string() + " -o " + again.string() + " --no-mp4").code, 0);
  ASSERT_EQ(
      runSnowsim("render " + out.string() + " -o " + fxaa.string() + " --no-mp4 --no-supersample")
          .code,
      0);
  const auto pixels = [](const fs::path& file) { return snowsim::readPng(file.string()).rgba; };
  EXPECT_EQ(pixels(again / "frame_00001.png"), pixels(out / "frame_00001.png"));
  EXPECT_NE(pixels(fxaa / "frame_00001.png"), pixels(out / "frame_00001.png"))
      << "the frame was not drawn supersampled";

  // A run.json whose record is damaged is refused naming the field, with nothing drawn.
  nlohmann::json damaged = summary;
  damaged["drawing"]["supersample"] = "yes";
  std::ofstream(out / "run.json") << damaged.dump();
  const fs::path refused_dir = out / "refused";
  const Result refused =
      runSnowsim("render " + out.string() + " -o " + refused_dir.string() + " --no-mp4");
  EXPECT_EQ(refused.code, 2) << refused.output;
  EXPECT_NE(refused.output.find("drawing.supersample: \"yes\" is not a true or false"),
            std::string::npos)
      << refused.output;
  EXPECT_FALSE(fs::exists(refused_dir / "frame_00000.png"));
}

// --surface-format obj writes the same mesh as the PLY, as OBJ text: as many vertices, normals and
// triangles, the same first vertex, indices counted from 1.
TEST(Cli, SurfaceMeshesAsObjHoldThePlysMesh) {
  const fs::path ply = freshDir("surface_ply"), obj = freshDir("surface_obj");
  const std::string run = "run " + scene("study_smash_3d") +
                          " --set time.duration=0.02 --no-png --no-mp4 --no-ply --surface -o ";
  ASSERT_EQ(runSnowsim(run + ply.string()).code, 0);
  const Result r = runSnowsim(run + obj.string() + " --surface-format obj");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_FALSE(fs::exists(obj / "surface_00001.ply"));
  std::ifstream header(ply / "surface_00001.ply", std::ios::binary);
  long vertices = 0, faces = 0;
  for (std::string line; std::getline(header, line) && line != "end_header";) {
    std::sscanf(line.c_str(), "element vertex %ld", &vertices);
    std::sscanf(line.c_str(), "element face %ld", &faces);
  }
  float first_ply[3];
  header.read(reinterpret_cast<char*>(first_ply), sizeof first_ply);
  ASSERT_GT(vertices, 100);
  std::ifstream text(obj / "surface_00001.obj");
  long v = 0, vn = 0, f = 0, largest_index = 0;
  float first_obj[3] = {0, 0, 0};
  for (std::string line; std::getline(text, line);) {
    if (line.rfind("v ", 0) == 0 && v++ == 0)
      std::sscanf(line.c_str(), "v %f %f %f", &first_obj[0], &first_obj[1], &first_obj[2]);
    vn += line.rfind("vn ", 0) == 0;
    if (line.rfind("f ", 0) == 0) {
      ++f;
      long a, b, c;
      ASSERT_EQ(std::sscanf(line.c_str(), "f %ld//%*d %ld//%*d %ld//%*d", &a, &b, &c), 3) << line;
      EXPECT_GE(std::min({a, b, c}), 1);
      largest_index = std::max({largest_index, a, b, c});
    }
  }
  EXPECT_EQ(v, vertices);
  EXPECT_EQ(vn, vertices);
  EXPECT_EQ(f, faces);
  EXPECT_EQ(largest_index, vertices);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(first_obj[k], first_ply[k]);

  const Result alone = runSnowsim("run " + scene("study_smash_3d") + " -o " +
                                  freshDir("surface_obj_alone").string() +
                                  " --surface-format obj --no-png --no-mp4");
  EXPECT_EQ(alone.code, 2);
  EXPECT_NE(alone.output.find("--surface-format obj: no mesh is written without --surface"),
            std::string::npos)
      << alone.output;
}

// Every file of a directory, by name, with its bytes: what a refused command must leave as it was.
std::map<std::string, std::string> everyFile(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(dir))
    if (entry.is_regular_file())
      files[fs::relative(entry.path(), dir).string()] = snowsim_test::bytesOf(entry.path());
  return files;
}

// `snowsim render DIR` draws into DIR by default, where the run drew its own PNG frames and video:
// like `snowsim run`, it does not write over them without --overwrite, and refused, writes
// nothing.
TEST(Cli, RenderKeepsTheFramesAndVideoItWouldWriteOverUnlessOverwrite) {
  const fs::path out = freshDir("render_keeps");
  ASSERT_EQ(runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                       " --set time.duration=0.04 --width 64 --height 48")
                .code,
            0);
  const auto before = everyFile(out);
  ASSERT_TRUE(before.count("frame_00002.png") && before.count("snowball_drop.mp4"));
  Result r = runSnowsim("render " + out.string() + " --color-by speed");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(
      r.output.find((out / "frame_00000.png").string() + ": would be overwritten (" + out.string() +
                    " holds 3 PNG frames, snowball_drop.mp4); pass "
                    "--overwrite"),
      std::string::npos)
      << r.output;
  EXPECT_EQ(everyFile(out), before) << "a refused render wrote or changed a file";
  r = runSnowsim("render " + out.string() + " --no-png");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find((out / "snowball_drop.mp4").string() + ": would be overwritten"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(everyFile(out), before);

  // Elsewhere it draws; the run's PNGs do not stand in the way of a video alone, or of nothing
  // of theirs.
  ASSERT_EQ(runSnowsim("render " + out.string() + " --no-mp4 -o " + (out / "speed").string() +
                       " --color-by speed")
                .code,
            0);
  EXPECT_TRUE(fs::exists(out / "speed" / "frame_00002.png"));
  // --overwrite replaces them, and removes a frame no longer drawn, so that one render's frames
  // are there.
  snowsim::writePng((out / "frame_00099.png").string(),
                    snowsim::readPng((out / "frame_00000.png").string()));
  r = runSnowsim("render " + out.string() + " --color-by speed --overwrite");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(
      r.output.find("--overwrite: removed 4 PNG frames, snowball_drop.mp4 from " + out.string()),
      std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(out / "frame_00099.png"));
  EXPECT_EQ(snowsim_test::bytesOf(out / "frame_00002.png"),
            snowsim_test::bytesOf(out / "speed" / "frame_00002.png"));
  EXPECT_NE(snowsim_test::bytesOf(out / "frame_00002.png"), before.at("frame_00002.png"));
  EXPECT_TRUE(fs::exists(out / "snowball_drop.mp4"));
  EXPECT_EQ(snowsim_test::bytesOf(out / "frame_00002.ply"), before.at("frame_00002.ply"));
}

// run.json records the scene's colliders and colliders.json where they are at every frame;
// `snowsim render` draws them from there, and refuses a run.json whose colliders it cannot read
// before writing anything.
TEST(Cli, RenderDrawsTheCollidersTheRunRecorded) {
  const fs::path out = freshDir("render_colliders");
  ASSERT_EQ(runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                       " --set time.duration=0.02 --no-mp4 --width 200 --height 160" +
                       R"( --set 'colliders=[{"shape": "box", "position": [0.02, 0.02],)" +
                       R"( "size": [0.02, 0.04], "velocity": [0.1, 0], "angular_velocity": 900}]')")
                .code,
            0);
  auto summary = nlohmann::json::parse(std::ifstream(out / "run.json"));
  ASSERT_EQ(summary["colliders"].size(), 1u);
  EXPECT_EQ(summary["colliders"][0]["shape"], "box");
  EXPECT_EQ(summary["colliders"][0]["velocity"][0], 0.1);
  // Frame 1 at 0.02 s: moved 2 mm along x, turned 18 degrees about z.
  const auto frames = nlohmann::json::parse(std::ifstream(out / "colliders.json"))["frames"];
  ASSERT_EQ(frames.size(), 2u);
  const auto& box = frames[1]["colliders"][0];
  EXPECT_EQ(frames[1]["time"], 0.02);
  EXPECT_NEAR(box["position"][0].get<double>(), 0.022, 1e-15);
  EXPECT_NEAR(box["rotation"][0].get<double>(), std::cos(std::numbers::pi / 20),
              1e-12);  // w = cos(9 deg)
  EXPECT_NEAR(box["rotation"][3].get<double>(), std::sin(std::numbers::pi / 20), 1e-12);
  EXPECT_NEAR(box["matrix"][1][0].get<double>(), std::sin(std::numbers::pi / 10), 1e-12);
  const auto image = [&](const std::string& name) {
    std::ifstream in(out / name, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string from_run = image("frame_00001.png");
  ASSERT_EQ(
      runSnowsim("render " + out.string() + " --no-mp4 --width 200 --height 160 --overwrite").code,
      0);
  EXPECT_EQ(image("frame_00001.png"), from_run) << "render draws what run drew, collider too";

  // Frames and colliders.json without a run.json (another program's frames): the colliders drawn.
  const fs::path bare = freshDir("render_colliders_bare");
  fs::create_directories(bare);
  for (const char* name : {"frame_00000.ply", "frame_00001.ply"}) fs::copy(out / name, bare / name);
  const auto bareImage = [&] {
    EXPECT_EQ(
        runSnowsim("render " + bare.string() + " --no-mp4 --width 200 --height 160 --overwrite")
            .code,
        0);
    std::ifstream in(bare / "frame_00001.png", std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string without_colliders = bareImage();
  fs::copy(out / "colliders.json", bare / "colliders.json");
  EXPECT_NE(bareImage(), without_colliders) << "colliders.json without run.json not drawn";

  fs::remove(out / "colliders.json");  // run.json's collider, moved on without turning
  ASSERT_EQ(
      runSnowsim("render " + out.string() + " --no-mp4 --width 200 --height 160 --overwrite").code,
      0);
  EXPECT_NE(image("frame_00001.png"), from_run) << "the collider unturned differs";

  summary["colliders"] = {{{"shape", "cone"}}};
  std::ofstream(out / "run.json") << summary.dump();
  const Result bad = runSnowsim("render " + out.string() + " -o " + (out / "again").string());
  EXPECT_EQ(bad.code, 2) << bad.output;
  EXPECT_NE(bad.output.find("colliders[0]"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(out / "again"));
}

std::vector<std::uint8_t> fileBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A 3D run records the camera that framed its snow; `snowsim render` draws the saved frames
// with it (the same image), or frames them anew from a preset it is given.
TEST(Cli, RenderReusesTheCameraOfTheRun) {
  const fs::path out = freshDir("camera");
  const std::string size = " --width 160 --height 120 --no-mp4";
  Result r = runSnowsim("run " + scene("study_smash_3d") + " -o " + out.string() +
                        " --set time.duration=0.02 --set time.fps=50" + size);
  ASSERT_EQ(r.code, 0) << r.output;
  const auto camera = nlohmann::json::parse(std::ifstream(out / "run.json"))["camera"];
  EXPECT_EQ(camera["preset"], "three_quarter");
  EXPECT_EQ(camera["eye"].size(), 3u);
  r = runSnowsim("render " + out.string() + " -o " + (out / "again").string() + size);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(fileBytes(out / "again" / "frame_00001.png"), fileBytes(out / "frame_00001.png"));
  r = runSnowsim("render " + out.string() + " -o " + (out / "tilted").string() +
                 " --camera-up 1 1 0" + size);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(fileBytes(out / "tilted" / "frame_00001.png"), fileBytes(out / "frame_00001.png"))
      << "--camera-up turns the run's camera";
  r = runSnowsim("render " + out.string() + " -o " + (out / "top").string() +
                 " --camera-preset top" + size);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(fileBytes(out / "top" / "frame_00001.png"), fileBytes(out / "frame_00001.png"));
  r = runSnowsim("render " + out.string() + " --camera-preset below" + size);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("allowed: front, side, three_quarter, top"), std::string::npos)
      << r.output;
}

// A run that draws no frames still records how it would have drawn them (run.json: the image
// size, the camera, the colouring); `snowsim render` of its PLY frames then draws what the same
// run drawing PNGs drew, byte for byte, and the command line still changes any of it.
TEST(Cli, RenderDrawsWhatTheRunWouldHaveDrawn) {
  const fs::path drawn = freshDir("drawn"), later = freshDir("drawn_later");
  const std::string run = "run " + scene("study_smash_3d") +
                          " --set time.duration=0.02 --set time.fps=50 --no-mp4 --width 160 "
                          "--height 120 --color-by plastic --camera-eye 0.1 0.3 0.6 "
                          "--camera-target 0.3 0.1 0.1 --look figure --no-grid -o ";
  Result r = runSnowsim(run + drawn.string());
  ASSERT_EQ(r.code, 0) << r.output;
  r = runSnowsim(run + later.string() + " --no-png");
  ASSERT_EQ(r.code, 0) << r.output;
  ASSERT_FALSE(fs::exists(later / "frame_00001.png"));
  const auto summary = nlohmann::json::parse(std::ifstream(later / "run.json"));
  EXPECT_EQ(summary["image"], nlohmann::json({160, 120}));
  EXPECT_EQ(summary["color"]["by"], "plastic");
  EXPECT_EQ(summary["camera"]["eye"], nlohmann::json({0.1, 0.3, 0.6}));
  EXPECT_EQ(summary["drawing"]["look"], "figure");
  EXPECT_EQ(summary["drawing"]["grid"], false);
  r = runSnowsim("render " + later.string() + " --no-mp4");
  ASSERT_EQ(r.code, 0) << r.output;
  for (const char* frame : {"frame_00000.png", "frame_00001.png"})
    EXPECT_EQ(fileBytes(later / frame), fileBytes(drawn / frame)) << frame;
  r = runSnowsim("render " + later.string() + " -o " + (later / "white").string() +
                 " --no-mp4 --color-by white");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(fileBytes(later / "white" / "frame_00001.png"), fileBytes(drawn / "frame_00001.png"));
  EXPECT_EQ(snowsim::readPng((later / "white" / "frame_00001.png").string()).width, 160);

  // With no camera placed, the run frames its snow from its first frame: the camera it records
  // draws the same images as well.
  const std::string framed = "run " + scene("study_smash_3d") +
                             " --set time.duration=0.02 --set time.fps=50 --no-mp4 --width 160 "
                             "--height 120 --color-by speed -o ";
  ASSERT_EQ(runSnowsim(framed + (drawn / "framed").string()).code, 0);
  ASSERT_EQ(runSnowsim(framed + (later / "framed").string() + " --no-png").code, 0);
  r = runSnowsim("render " + (later / "framed").string() + " --no-mp4");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(fileBytes(later / "framed" / "frame_00001.png"),
            fileBytes(drawn / "framed" / "frame_00001.png"));

  // An MP4 at the run's size is checked before anything is written: yuv420p needs even sides.
  auto odd = summary;
  odd["image"] = {161, 120};
  std::ofstream(later / "run.json") << odd.dump();
  r = runSnowsim("render " + later.string() + " -o " + (later / "odd").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("even width and height, got 161x120"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(later / "odd"));

  // A run.json whose colouring cannot be read is refused before anything is written.
  auto broken = summary;
  broken["color"]["by"] = "temperature";
  std::ofstream(later / "run.json") << broken.dump();
  r = runSnowsim("render " + later.string() + " -o " + (later / "bad").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("color.by"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(later / "bad"));
}

// A 3D frame (deferred passes, occlusion, grid lines on the ground) is the same image in every
// process. Each render is a process of its own: what llvmpipe leaves in an output a shader does
// not write depends on the addresses a process gets. With llvmpipe rasterising on the calling
// thread (LP_NUM_THREADS=0), the grid lines' unwritten normals changed the occlusion beside them
// in about 4 processes of 10; the chance that 8 processes all miss it is under 2%.
TEST(Cli, A3DFrameRendersTheSameInEveryProcess) {
  const fs::path out = freshDir("same_image");
  Result r =
      runSnowsim("run " + scene("mpm_snowball_wall") + " -o " + out.string() +
                 " --scale 0.5 --set time.duration=0.01 --set time.fps=100 --no-png " + "--no-mp4");
  ASSERT_EQ(r.code, 0) << r.output;
  std::vector<std::uint8_t> first;
  for (int process = 0; process < 8; ++process) {
    const fs::path again = out / ("render_" + std::to_string(process));
    r = runCommand("LP_NUM_THREADS=0 " + std::string(SNOWSIM_BINARY) + " render " + out.string() +
                   " -o " + again.string() + " --width 96 --height 64");
    ASSERT_EQ(r.code, 0) << r.output;
    const std::vector<std::uint8_t> image = fileBytes(again / "frame_00000.png");
    if (process == 0) first = image;
    EXPECT_EQ(image, first) << "process " << process << " drew another image";
  }
}

TEST(Cli, UnwritableOutputDirectoryIsBadInput) {
  const Result r = runSnowsim("run " + scene("snowball_drop") + " -o /proc/snowsim_out");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("/proc/snowsim_out"), std::string::npos) << r.output;
}

TEST(Cli, AMisspeltCommandIsNamed) {
  const Result r = runSnowsim("rnu " + scene("snowball_drop"));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("unknown command 'rnu'; the commands are run, resume"), std::string::npos)
      << r.output;
  const Result scene_first = runSnowsim(scene("snowball_drop"));
  EXPECT_EQ(scene_first.code, 2) << scene_first.output;
  EXPECT_NE(scene_first.output.find("a scene runs with: snowsim run SCENE.json"), std::string::npos)
      << scene_first.output;
}

// A study stops before its CSV is begun when a scene of its preset cannot be read or the CSV
// cannot be written.
TEST(Cli, AStudyOfMissingScenesOrToAnUnwritablePathWritesNothing) {
  const fs::path dir = freshDir("study_bad");
  fs::create_directories(dir);
  Result r = runSnowsim("study --quick --scenes " + (dir / "none").string() + " -o " +
                        (dir / "s.csv").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("cannot open the file"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "s.csv"));
  r = runSnowsim("study --quick --scenes " + std::string(SNOWSIM_SOURCE_DIR) +
                 "/scenes -o /proc/snowsim_out/s.csv");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--out: cannot write /proc/snowsim_out/s.csv"), std::string::npos)
      << r.output;
}

// snowsim clumps prints its CSV only once every frame has been read: a damaged frame leaves no
// partial table behind for a `> file` to keep.
TEST(Cli, ClumpsOfADamagedRunPrintsNoRows) {
  const fs::path run = freshDir("clumps_run");
  ASSERT_EQ(runSnowsim("run " + scene("mpm_reference") + " -o " + run.string() +
                       " --set time.duration=0.06 --no-png --no-mp4")
                .code,
            0);
  Result r = runSnowsim("clumps " + run.string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("\n2,0.0400,"), std::string::npos) << r.output;
  fs::resize_file(run / "frame_00002.ply", fs::file_size(run / "frame_00002.ply") / 2);
  r = runSnowsim("clumps " + run.string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("frame_00002.ply"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("frame,time_s"), std::string::npos) << r.output;
}

// --intact-below leaves out the particles stretched past a J_P and measures the pieces of the rest,
// its shares still of all the particles: two rows joined by a bridge of torn snow are one clump,
// or two pieces and the bridge left out. The chunks' mass shares follow, heaviest first: the second
// row's particles weigh twice the first's, so of the 33 units of mass the second row holds 20 and
// the first 10.
TEST(Cli, ClumpsOfTheIntactSnowLeaveOutTheTornSnow) {
  const fs::path run = freshDir("clumps_intact");
  fs::create_directories(run);
  snowsim::Snapshot s;
  s.grid.dimension = 3;
  s.grid.cells = {30, 2, 2};
  s.grid.cell_size = 0.01;
  s.grid.particle_spacing = 0.01;
  // A row of 23 particles one spacing apart: 10 intact, 3 torn (J_P 2), 10 intact.
  for (int i = 0; i < 23; ++i) {
    s.position.push_back({0.01f * i, 0, 0});
    s.velocity.push_back({0, 0, 0});
    s.plastic_j.push_back(i >= 10 && i < 13 ? 2.0f : 1.0f);
    s.density.push_back(400);
    s.mass.push_back(i >= 13 ? 2e-3f : 1e-3f);
    s.radius.push_back(0.005f);
  }
  snowsim::writePly((run / "frame_00000.ply").string(), s);
  Result r = runSnowsim("clumps " + run.string());
  ASSERT_EQ(r.code, 0) << r.output;
  const std::string no_more_chunks = ",0.0000,0.0000,0.0000,0.0000,0.0000,0.0000,0.0000,0.0000";
  EXPECT_NE(r.output.find("\n0,0.0000,23,1,1,1.0000,0.0000,1.0000,0.0000,0.0000,1.0000,0.0000" +
                          no_more_chunks + "\n"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find(",chunk1_mass_share,"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(",chunk10_mass_share\n"), std::string::npos) << r.output;
  r = runSnowsim("clumps " + run.string() + " --intact-below 1.5");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("\n0,0.0000,23,2,2,0.4348,0.4348,0.8696,0.0000,0.1304,0.6061,0.3030" +
                          no_more_chunks + "\n"),
            std::string::npos)
      << r.output;
}

TEST(Cli, HelpDescribesEachSubcommand) {
  const Result top = runSnowsim("--help");
  EXPECT_EQ(top.code, 0);
  EXPECT_NE(top.output.find("run"), std::string::npos);
  const Result run = runSnowsim("run --help");
  EXPECT_EQ(run.code, 0);
  EXPECT_NE(run.output.find("--set"), std::string::npos);
  EXPECT_NE(run.output.find("Exit codes"), std::string::npos);
  EXPECT_NE(run.output.find("--threads"), std::string::npos);
  for (const char* flag : {"--no-ply", "--no-png", "--no-mp4"})
    EXPECT_NE(run.output.find(std::string(flag) + "  "), std::string::npos) << flag;
  EXPECT_EQ(run.output.find("{false}"), std::string::npos) << run.output;
}

}  // namespace

namespace {

TEST(Cli, FigureRegeneratesAReportFigureAsAStrip) {
  const fs::path out = freshDir("figure");
  const Result r = runSnowsim("figure fig6 -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.output;
  const fs::path png = out / "fig6.png";
  ASSERT_TRUE(fs::exists(png));
  // The title, then three rows of one 320x352 panel, each with a label strip: a tall, narrow
  // image.
  std::ifstream in(png, std::ios::binary);
  unsigned char header[24];
  in.read(reinterpret_cast<char*>(header), 24);
  const int width = header[16] << 24 | header[17] << 16 | header[18] << 8 | header[19];
  const int height = header[20] << 24 | header[21] << 16 | header[22] << 8 | header[23];
  EXPECT_EQ(width, 320 + 2 * 8);
  EXPECT_EQ(height, 44 + 8 + 3 * (352 + 34 + 8));

  const Result unknown = runSnowsim("figure fig9 -o " + out.string());
  EXPECT_EQ(unknown.code, 2);
  EXPECT_NE(unknown.output.find("allowed: fig1"), std::string::npos) << unknown.output;
}

// Any scene's strip, here a 3D one coloured by J_P: the panels at the times asked, the title
// above and J_P's colour bar below: red at its low (compressed) end, grey in the middle (J_P = 1)
// and blue at its high (stretched) end.
TEST(Cli, FigureOfAnyScene) {
  const fs::path out = freshDir("scene_figure");
  const Result r =
      runSnowsim("figure " + scene("study_smash_3d") +
                 " --times 0,0.02 --color-by plastic --width 160 --height 120 -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.output;
  const snowsim::Image image = snowsim::readPng((out / "study_smash_3d.png").string());
  EXPECT_EQ(image.width, 8 + 2 * (160 + 8));
  EXPECT_EQ(image.height, 44 + 8 + (120 + 34 + 8) + 64);
  const int bar_y = image.height - 64 + 9, bar_x0 = 40, bar_x1 = image.width - 40 - 1;
  const auto *low = image.pixel(bar_x0, bar_y), *high = image.pixel(bar_x1, bar_y);
  const auto* middle = image.pixel((bar_x0 + bar_x1) / 2, bar_y);
  EXPECT_GT(low[0], low[2] + 100) << "red at the compressed end";
  EXPECT_GT(high[2], high[0] + 100) << "blue at the stretched end";
  EXPECT_LT(std::abs(middle[0] - middle[2]), 10) << "grey in the middle";

  const Result late =
      runSnowsim("figure " + scene("study_smash_3d") + " --times 0,9 -o " + out.string());
  EXPECT_EQ(late.code, 2);
  EXPECT_NE(late.output.find("--times: 9"), std::string::npos) << late.output;
}

// A one-row figure of the first 0.02 s of the snowball drop, in a scenes directory of its own.
void writeTinyFigure(const fs::path& scenes) {
  fs::create_directories(scenes);
  fs::copy_file(scene("snowball_drop"), scenes / "snowball_drop.json");
  std::ofstream(scenes / "figures.json")
      << R"({"tiny": {"rows": [{"scene": "snowball_drop", "times": [0.02]}]}})";
}

// Without --figures: scenes/figures.json of the current directory, else the one beside the
// binary (the build tree's, or a moved binary's), else an installation's.
TEST(Cli, FigureFindsItsDescriptionsFromAnyDirectory) {
  const fs::path dir = freshDir("figure_cwd");
  fs::create_directories(dir / "elsewhere");
  const std::string elsewhere = "cd " + (dir / "elsewhere").string() + " && ";
  Result r = runCommand(elsewhere + SNOWSIM_BINARY + " figure fig9 -o out");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("allowed: fig1"), std::string::npos) << r.output;

  writeTinyFigure(dir / "elsewhere" / "scenes");
  r = runCommand(elsewhere + SNOWSIM_BINARY + " figure tiny -o out");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(dir / "elsewhere" / "out" / "tiny.png"));

  // A moved binary with its scenes beside it, and an installation under a prefix.
  for (const auto& [binary, scenes] :
       {std::pair{dir / "moved" / "snowsim", dir / "moved" / "scenes"},
        std::pair{dir / "prefix" / "bin" / "snowsim", dir / "prefix" / "share/snowsim/scenes"}}) {
    fs::create_directories(binary.parent_path());
    fs::copy_file(SNOWSIM_BINARY, binary);
    const std::string run = "cd " + dir.string() + " && " + binary.string() + " figure tiny -o " +
                            (binary.parent_path() / "out").string();
    r = runCommand(run);
    EXPECT_EQ(r.code, 2) << "no scenes yet: " << r.output;
    EXPECT_NE(r.output.find("give their file with --figures"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(scenes.string()), std::string::npos) << r.output;
    writeTinyFigure(scenes);
    r = runCommand(run);
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_TRUE(fs::exists(binary.parent_path() / "out" / "tiny.png")) << binary;
  }
}

// Options a 2D scene's frames have no use for are named, not dropped silently.
TEST(Cli, ThreeDimensionalOptionsOnATwoDimensionalSceneAreNamed) {
  const fs::path out = freshDir("unused_options");
  const Result r = runSnowsim("run " + scene("snowball_drop") + " -o " + out.string() +
                              " --set time.duration=0.02 --no-mp4 --fov 20 --no-shadows");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("warning: --fov, --no-shadows: not used for 2D frames"),
            std::string::npos)
      << r.output;
  const Result three =
      runSnowsim("run " + scene("mpm_snowball_drop_3d") + " -o " + (out / "3d").string() +
                 " --set time.duration=0.01 --no-mp4 --fov 20 --density-cells");
  ASSERT_EQ(three.code, 0) << three.output;
  EXPECT_NE(three.output.find("warning: --density-cells: not used for 3D frames"),
            std::string::npos)
      << three.output;
  EXPECT_EQ(three.output.find("--fov"), std::string::npos) << three.output;
}

// Without --scenes a study reads scenes/ of the current directory, else the scenes beside the
// binary (the build tree's), as figure does; a binary with neither says where it looked.
TEST(Cli, StudyFindsItsScenesFromAnyDirectory) {
  const fs::path dir = freshDir("study_cwd");
  fs::create_directories(dir / "elsewhere");
  Result r = runCommand("cd " + (dir / "elsewhere").string() + " && " + SNOWSIM_BINARY +
                        " study --quick -o quick.csv");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(dir / "elsewhere" / "quick.csv"));

  const fs::path moved = dir / "moved" / "snowsim";
  fs::create_directories(moved.parent_path());
  fs::copy_file(SNOWSIM_BINARY, moved);
  r = runCommand("cd " + (dir / "elsewhere").string() + " && " + moved.string() +
                 " study --quick -o moved.csv");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("give it with --scenes"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find((dir / "moved" / "scenes").string()), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "elsewhere" / "moved.csv"));
}

}  // namespace

// A bad mesh, for a body or a collider: exit 2, the mesh file and its problem named, nothing
// written.
TEST(Cli, ABadMeshExitsTwoNamingTheFileAndWritesNothing) {
  const fs::path dir = freshDir("bad_meshes");
  fs::create_directories(dir);
  std::ifstream cube(std::string(SNOWSIM_SOURCE_DIR) + "/scenes/meshes/cube.obj");
  std::string line, open_cube;
  for (int faces = 0; std::getline(cube, line);)
    if (line.rfind("f ", 0) != 0 || ++faces < 12) open_cube += line + "\n";
  std::ofstream(dir / "open.obj") << open_cube;
  std::ofstream(dir / "empty.stl");
  std::ofstream(dir / "garbage.ply", std::ios::binary) << std::string("\x01\xfe\x7f garbage", 11);
  std::ofstream(dir / "flat.obj") << "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n";
  const std::string drop = "run " + scene("mesh_snow_drop") + " --set bodies.0.mesh=";
  expectRejected(drop + (dir / "missing.obj").string(), "missing.obj: no such mesh file");
  expectRejected(drop + (dir / "open.obj").string(), "open.obj: the mesh is not watertight");
  expectRejected(drop + (dir / "empty.stl").string(), "empty.stl: the file is empty");
  expectRejected(drop + (dir / "garbage.ply").string(), "garbage.ply: cannot read it as a mesh");
  expectRejected(drop + (dir / "flat.obj").string(), "flat.obj: triangle 0 is degenerate");
  expectRejected("run " + scene("mesh_snow_drop") + " --set bodies.0.scale=1",
                 "torus.stl: the mesh is larger than the grid");
  expectRejected(
      "run " + scene("mesh_snow_drop") + " --set colliders.0.mesh=" + (dir / "open.obj").string(),
      "colliders[0].mesh: " + (dir / "open.obj").string());
}

// run.json names a mesh collider's file: `snowsim render` reads it again and draws the same frame.
TEST(Cli, RenderDrawsAMeshColliderAsTheRunDid) {
  const fs::path out = freshDir("render_mesh");
  ASSERT_EQ(runSnowsim("run " + scene("mesh_snow_drop") + " -o " + out.string() +
                       " --set time.duration=0.034 --no-mp4 --width 160 --height 120")
                .code,
            0);
  const auto summary = nlohmann::json::parse(std::ifstream(out / "run.json"));
  EXPECT_EQ(summary["colliders"][0]["shape"], "mesh");
  const auto from_run = fileBytes(out / "frame_00001.png");
  ASSERT_EQ(
      runSnowsim("render " + out.string() + " --no-mp4 --width 160 --height 120 --overwrite").code,
      0);
  EXPECT_EQ(fileBytes(out / "frame_00001.png"), from_run)
      << "render draws what run drew, the mesh too";
}
