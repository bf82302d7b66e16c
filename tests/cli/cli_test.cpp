// The command line as a user meets it: exit codes, messages, and no half-written output.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

namespace {

namespace fs = std::filesystem;

struct Result {
  int code;
  std::string output;  // stdout and stderr together
};

Result runSnowsim(const std::string& args) {
  const std::string command = std::string(SNOWSIM_BINARY) + " " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  std::string output;
  std::array<char, 4096> buffer;
  while (size_t n = fread(buffer.data(), 1, buffer.size(), pipe)) output.append(buffer.data(), n);
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, output};
}

fs::path freshDir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("snowsim_cli_" + std::to_string(getpid())) / name;
  fs::remove_all(dir);
  return dir;
}

std::string scene(const std::string& name) {
  return std::string(SNOWSIM_SOURCE_DIR) + "/scenes/" + name + ".json";
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
  EXPECT_EQ(r.output, "") << "quiet when not on a terminal";
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

}  // namespace
