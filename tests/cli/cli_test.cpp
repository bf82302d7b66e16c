// The command line as a user meets it: exit codes, messages, and no half-written output.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "tests/cli/run_snowsim.h"

namespace {

namespace fs = std::filesystem;

using snowsim_test::freshDir;
using snowsim_test::Result;
using snowsim_test::runCommand;
using snowsim_test::runSnowsim;

std::string scene(const std::string& name) {
  return std::string(SNOWSIM_SOURCE_DIR) + "/scenes/" + name + ".json";
}

// Whether every line of a run's output is a per-frame progress line: nothing else to say.
bool onlyProgress(const std::string& output) {
  std::istringstream lines(output);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind("frame ", 0) != 0) return false;
  return true;
}

TEST(Cli, RunWritesPlyFramesAndASummary) {
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
                          " --no-png --no-mp4 --no-ply --set time.duration=0.02" +
                          " --set mpm.integrator=semi_implicit";
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
  expectRejected("run " + scene("snowball_drop") + " --set grid.cells=[0,12]", "grid.cells");
  expectRejected("run " + scene("snowball_drop") + " --set bodies.0.center=[0.5,0.05]",
                 "outside the grid");
  expectRejected("run " + scene("snowball_drop") + " --set time.dt", "expected key=value");
  expectRejected("run missing.json", "missing.json");
  expectRejected("run " + scene("snowball_drop") + " --color-by temperature",
                 "allowed: white, density, speed");
  expectRejected("run " + scene("snowball_drop") + " --width 0", "out of range");
  expectRejected("run " + scene("snowball_drop") + " --width 201", "even width and height");
  expectRejected("run " + scene("snowball_drop") + " --mp4-codec nonesuch", "--mp4-codec");
  expectRejected("run " + scene("snowball_drop") + " --mp4-crf 60", "--mp4-crf: 60");
  expectRejected("run " + scene("snowball_drop") + " --mp4-fps -5", "--mp4-fps");
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

// Starts `snowsim ARGS...` in a child process, its stderr discarded; a test signals and reaps it.
pid_t startSnowsim(std::vector<std::string> args) {
  args.insert(args.begin(), SNOWSIM_BINARY);
  std::vector<char*> argv;
  for (std::string& arg : args) argv.push_back(arg.data());
  argv.push_back(nullptr);
  const pid_t child = fork();
  if (child == 0) {
    freopen("/dev/null", "w", stderr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return child;
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
TEST(Cli, SigtermFinalisesTheVideoWrittenSoFar) {
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
TEST(Cli, SigtermStopsWithinAFewStepsNotAtTheNextFrame) {
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
  const Result r =
      runSnowsim("render " + out.string() + " --color-by density --width 200 --height 100");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(out / "frame_00002.png"));
}

TEST(Cli, UnwritableOutputDirectoryIsBadInput) {
  const Result r = runSnowsim("run " + scene("snowball_drop") + " -o /proc/snowsim_out");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("/proc/snowsim_out"), std::string::npos) << r.output;
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
  // Three rows of one 320x352 panel, each with a label strip: a tall, narrow image.
  std::ifstream in(png, std::ios::binary);
  unsigned char header[24];
  in.read(reinterpret_cast<char*>(header), 24);
  const int width = header[16] << 24 | header[17] << 16 | header[18] << 8 | header[19];
  const int height = header[20] << 24 | header[21] << 16 | header[22] << 8 | header[23];
  EXPECT_EQ(width, 320 + 2 * 8);
  EXPECT_EQ(height, 8 + 3 * (352 + 34 + 8));

  const Result unknown = runSnowsim("figure fig9 -o " + out.string());
  EXPECT_EQ(unknown.code, 2);
  EXPECT_NE(unknown.output.find("allowed: fig1"), std::string::npos) << unknown.output;
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

}  // namespace
