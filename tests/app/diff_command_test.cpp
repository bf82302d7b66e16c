// snowsim diff as CI meets it: two images or two directories of frames, the lines and the
// summary it prints, its JSON and HTML reports, the mask, exit codes and refused input.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <nlohmann/json.hpp>

#include "render/image.h"
#include "render/image_diff.h"
#include "tests/support/run_snowsim.h"

namespace {

namespace fs = std::filesystem;
using snowsim::Image;
using snowsim_test::bytesOf;
using snowsim_test::freshDir;
using snowsim_test::Result;
using snowsim_test::runSnowsim;

constexpr int kWidth = 40, kHeight = 30;

Image flat(std::uint8_t grey, int width = kWidth, int height = kHeight) {
  return Image{width, height, std::vector<std::uint8_t>(size_t(width) * height * 4, grey)};
}

// `image` with a square of `size` pixels at (x, y) painted `grey`.
Image withSquare(Image image, int x, int y, int size, std::uint8_t grey) {
  for (int j = y; j < y + size; ++j)
    for (int i = x; i < x + size; ++i)
      for (int c = 0; c < 3; ++c) image.rgba[4 * (j * image.width + i) + c] = grey;
  return image;
}

std::string readText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// Whether the directory holds anything whose name starts with `prefix`: a leftover temporary.
bool holdsNameStartingWith(const fs::path& dir, const std::string& prefix) {
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.path().filename().string().rfind(prefix, 0) == 0) return true;
  return false;
}

// Two runs of four frames: B's frame_1 has a changed square, B lacks frame_3 and has a frame_4
// A lacks; frames 0 and 2 are the same.
struct TwoRuns {
  fs::path root, a, b;
  Image base = flat(60), changed = withSquare(flat(60), 10, 10, 8, 220);

  explicit TwoRuns(const std::string& name) : root(freshDir(name)), a(root / "a"), b(root / "b") {
    fs::create_directories(a);
    fs::create_directories(b);
    for (const char* frame : {"frame_0.png", "frame_1.png", "frame_2.png", "frame_3.png"})
      snowsim::writePng((a / frame).string(), base);
    for (const char* frame : {"frame_0.png", "frame_2.png", "frame_4.png"})
      snowsim::writePng((b / frame).string(), base);
    snowsim::writePng((b / "frame_1.png").string(), changed);
  }
  std::string args() const { return a.string() + " " + b.string(); }
};

TEST(DiffCommand, TwoImagesKeepTheirLineAndExitCodesAndAddASummary) {
  const fs::path dir = freshDir("diff_pair");
  fs::create_directories(dir);
  const std::string a = (dir / "a.png").string(), b = (dir / "b.png").string(),
                    small = (dir / "small.png").string();
  snowsim::writePng(a, flat(50));
  snowsim::writePng(b, withSquare(flat(50), 5, 5, 1, 250));
  snowsim::writePng(small, flat(50, 10, 10));

  const struct {
    std::string args;
    int code;
    std::string output;
  } cases[] = {
      {a + " " + a, 0, "0 differing pixels (0.0000%)"},
      {a + " " + a, 0,
       "PASS: share 0.0000 of the pixels differ; limits: --threshold 0.1, --max-share 0\n"},
      {a + " " + b, 1, "1 differing pixels"},
      {a + " " + b, 1, "FAIL: share 0.0008"},  // 1 of 1200
      {a + " " + b + " --max-share 0.001 --threshold 0.2", 0,
       "PASS: share 0.0008 of the pixels differ; limits: --threshold 0.2, --max-share 0.001\n"},
      // Another resolution is a difference, not bad input.
      {a + " " + small, 1, a + " is 40x30 but " + small + " is 10x10: no pixel compared\n"},
      {a + " " + small, 1, "FAIL: the image size differs (40x30 in A, 10x10 in B); limits"},
      {a + " " + (dir / "missing.png").string(), 2, "missing.png: no such file or directory"},
  };
  for (const auto& c : cases) {
    const Result r = runSnowsim("diff " + c.args);
    EXPECT_EQ(r.code, c.code) << c.args << ": " << r.output;
    EXPECT_TRUE(contains(r.output, c.output)) << c.output << " in\n" << r.output;
  }
}

TEST(DiffCommand, OutOfRangeLimitsAreRefusedAlike) {
  const fs::path dir = freshDir("diff_limits");
  fs::create_directories(dir);
  const std::string a = (dir / "a.png").string();
  snowsim::writePng(a, flat(50));
  for (const char* option : {"--threshold", "--max-share"})
    for (const char* value : {"-0.1", "1.5", "nan"}) {
      const Result r = runSnowsim("diff " + a + " " + a + " " + option + " " + value);
      EXPECT_EQ(r.code, 2) << option << " " << value << ": " << r.output;
      EXPECT_TRUE(contains(r.output, std::string(option) + ": ")) << r.output;
      EXPECT_TRUE(contains(r.output, "is out of range; allowed: 0 to 1")) << r.output;
    }
  EXPECT_EQ(runSnowsim("diff " + a + " " + a + " --max-share 1 --threshold 0").code, 0);
}

TEST(DiffCommand, DirectoriesPairFramesByNameAndReportEachDifference) {
  const TwoRuns runs("diff_dirs");
  Result r = runSnowsim("diff " + runs.args());
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_TRUE(contains(r.output, "FAIL  frame_1.png: ")) << r.output;
  EXPECT_TRUE(contains(r.output, "FAIL  frame_3.png: missing from B (in A only)")) << r.output;
  EXPECT_TRUE(contains(r.output, "FAIL  frame_4.png: extra in B (not in A)")) << r.output;
  EXPECT_FALSE(contains(r.output, "frame_0.png")) << "the same frames get no line: " << r.output;
  EXPECT_FALSE(contains(r.output, "frame_2.png")) << r.output;
  EXPECT_TRUE(contains(r.output,
                       "FAIL: 1 of 3 frames beyond the limits, 1 missing from B, 1 extra in B; "
                       "limits: --threshold 0.1, --max-share 0, missing frames fail, extra "
                       "frames fail\n"))
      << r.output;

  // The changed frame's line gives its figures as the library computes them.
  const snowsim::ImageDiff expected = snowsim::diffImages(runs.base, runs.changed);
  char figures[128];
  std::snprintf(figures, sizeof figures,
                "%ld of %d pixels differ (share %.4f = %.2f%%), largest difference %.3f",
                expected.differing, kWidth * kHeight, expected.share, 100 * expected.share,
                expected.largest);
  EXPECT_TRUE(contains(r.output, "frame_1.png: " + std::string(figures))) << r.output;

  // Within a generous share the changed frame passes, but its line stays; missing and extra
  // frames still fail until allowed.
  r = runSnowsim("diff " + runs.args() + " --max-share 0.5");
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_TRUE(contains(r.output, "ok    frame_1.png: ")) << r.output;
  r = runSnowsim("diff " + runs.args() + " --max-share 0.5 --allow-missing");
  EXPECT_EQ(r.code, 1) << "the extra frame fails: " << r.output;
  r = runSnowsim("diff " + runs.args() + " --max-share 0.5 --allow-missing --allow-extra");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "ok    frame_3.png: missing from B")) << r.output;
  EXPECT_TRUE(contains(r.output, "PASS: 0 of 3 frames beyond the limits")) << r.output;
  EXPECT_TRUE(contains(r.output, "missing frames allowed, extra frames allowed")) << r.output;
}

TEST(DiffCommand, JsonReportHoldsEveryFramesFigures) {
  const TwoRuns runs("diff_json");
  const fs::path report = runs.root / "report.json";
  const Result r = runSnowsim("diff " + runs.args() + " --json " + report.string());
  EXPECT_EQ(r.code, 1) << r.output;
  const auto json = nlohmann::json::parse(std::ifstream(report));
  EXPECT_EQ(json["result"], "FAIL");
  EXPECT_EQ(json["a"], runs.a.string());
  EXPECT_DOUBLE_EQ(json["limits"]["threshold"].get<double>(), 0.1);
  EXPECT_TRUE(json["limits"]["mask"].is_null());
  EXPECT_EQ(json["limits"]["missing_frames_fail"], true);
  const auto& frames = json["frames"];
  ASSERT_EQ(frames.size(), 5u);
  const char* statuses[] = {"pass", "fail", "pass", "missing", "extra"};
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(frames[i]["name"], "frame_" + std::to_string(i) + ".png");
    EXPECT_EQ(frames[i]["status"], statuses[i]) << i;
    EXPECT_EQ(frames[i].contains("share"), i < 3) << i;
  }
  const snowsim::ImageDiff expected = snowsim::diffImages(runs.base, runs.changed);
  EXPECT_EQ(frames[1]["compared_pixels"], kWidth * kHeight);
  EXPECT_EQ(frames[1]["differing_pixels"], expected.differing);
  EXPECT_EQ(frames[1]["anti_aliased_pixels"], expected.anti_aliased);
  EXPECT_DOUBLE_EQ(frames[1]["share"].get<double>(), expected.share);
  EXPECT_DOUBLE_EQ(frames[1]["largest_difference"].get<double>(), expected.largest);
  EXPECT_EQ(frames[0]["differing_pixels"], 0);
  EXPECT_FALSE(holdsNameStartingWith(runs.root, "report.json.")) << "no temporary left";
}

TEST(DiffCommand, HtmlReportShowsTheFailingFramesSideBySide) {
  const TwoRuns runs("diff_html");
  const fs::path report = runs.root / "report";
  Result r = runSnowsim("diff " + runs.args() + " --html " + report.string());
  EXPECT_EQ(r.code, 1) << r.output;
  const std::string page = readText(report / "index.html");
  EXPECT_TRUE(contains(page, "FAIL: 1 of 3 frames beyond the limits")) << page;
  for (const char* folder : {"a", "b", "diff"}) {
    EXPECT_TRUE(contains(page, "src=\"" + std::string(folder) + "/frame_1.png\"")) << folder;
    EXPECT_TRUE(fs::exists(report / folder / "frame_1.png")) << folder;
    EXPECT_FALSE(fs::exists(report / folder / "frame_0.png")) << "only failing frames";
  }
  EXPECT_EQ(readText(report / "a" / "frame_1.png"), readText(runs.a / "frame_1.png"));
  EXPECT_EQ(readText(report / "b" / "frame_1.png"), readText(runs.b / "frame_1.png"));
  const Image diff = snowsim::readPng((report / "diff" / "frame_1.png").string());
  EXPECT_EQ(diff.rgba, snowsim::diffImages(runs.base, runs.changed).visual.rgba);
  EXPECT_TRUE(contains(page, "frame_3.png: missing from B")) << page;
  EXPECT_TRUE(contains(page, "frame_4.png: extra in B")) << page;
  EXPECT_FALSE(holdsNameStartingWith(runs.root, "report.tmp")) << "no temporary left";

  // A second run replaces the earlier report whole (a trailing slash names the same directory).
  r = runSnowsim("diff " + runs.args() + " --max-share 0.5 --allow-missing --allow-extra --html " +
                 report.string() + "/");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(contains(readText(report / "index.html"), "PASS: 0 of 3 frames"));
  EXPECT_FALSE(fs::exists(report / "a" / "frame_1.png")) << "left over from the earlier report";
}

// A run rendered at another resolution differs: each frame of another size fails, without a pixel
// compared, and the reports say so frame by frame, giving both sizes.
TEST(DiffCommand, FramesOfAnotherSizeDifferFrameByFrame) {
  const TwoRuns runs("diff_resized");
  for (const char* frame : {"frame_0.png", "frame_2.png"})
    snowsim::writePng((runs.b / frame).string(), flat(60, 20, 16));
  const fs::path json = runs.root / "report.json", html = runs.root / "report";
  const Result r =
      runSnowsim("diff " + runs.args() + " --json " + json.string() + " --html " + html.string());
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_TRUE(contains(r.output,
                       "FAIL  frame_2.png: resized: 40x30 in A, 20x16 in B (no pixel "
                       "compared)\n"))
      << r.output;
  EXPECT_TRUE(contains(r.output,
                       "FAIL: 3 of 3 frames beyond the limits (2 of them resized), 1 "
                       "missing from B, 1 extra in B"))
      << r.output;
  const auto frames = nlohmann::json::parse(std::ifstream(json))["frames"];
  ASSERT_EQ(frames.size(), 5u);
  EXPECT_EQ(frames[0]["status"], "resized");
  EXPECT_EQ(frames[0]["size_a"], nlohmann::json::array({kWidth, kHeight}));
  EXPECT_EQ(frames[0]["size_b"], nlohmann::json::array({20, 16}));
  EXPECT_FALSE(frames[0].contains("share"));
  EXPECT_EQ(frames[1]["status"], "fail");
  EXPECT_FALSE(frames[1].contains("size_a"));
  EXPECT_EQ(frames[2]["status"], "resized");
  const std::string page = readText(html / "index.html");
  EXPECT_TRUE(contains(page, "frame_0.png: resized: 40x30 in A, 20x16 in B")) << page;
  EXPECT_TRUE(contains(page, "src=\"b/frame_0.png\"")) << page;
  EXPECT_FALSE(contains(page, "src=\"diff/frame_0.png\"")) << page;
  EXPECT_EQ(readText(html / "b" / "frame_0.png"), readText(runs.b / "frame_0.png"));
  EXPECT_FALSE(fs::exists(html / "diff" / "frame_0.png"));

  // No limit lets a resized frame pass.
  const Result allowed = runSnowsim("diff " + runs.args() +
                                    " --max-share 1 --threshold 1 --allow-missing --allow-extra");
  EXPECT_EQ(allowed.code, 1) << allowed.output;
}

TEST(DiffCommand, MaskLeavesItsDarkPixelsOut) {
  const fs::path dir = freshDir("diff_mask");
  fs::create_directories(dir);
  const std::string a = (dir / "a.png").string(), b = (dir / "b.png").string(),
                    mask = (dir / "mask.png").string(), small = (dir / "small.png").string();
  snowsim::writePng(a, flat(60));
  snowsim::writePng(b, withSquare(flat(60), 30, 2, 6, 220));  // a "clock" in the corner
  snowsim::writePng(mask, withSquare(flat(255), 28, 0, 12, 0));
  snowsim::writePng(small, flat(255, 20, 20));

  EXPECT_EQ(runSnowsim("diff " + a + " " + b).code, 1);
  const fs::path report = dir / "report.json";
  Result r = runSnowsim("diff " + a + " " + b + " --mask " + mask + " --json " + report.string());
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "--mask " + mask)) << "the limits name the mask: " << r.output;
  const auto json = nlohmann::json::parse(std::ifstream(report));
  EXPECT_EQ(json["frames"][0]["compared_pixels"], kWidth * kHeight - 12 * 12);
  EXPECT_EQ(json["limits"]["mask"], mask);

  // A change outside the mask still counts.
  snowsim::writePng(b, withSquare(flat(60), 2, 20, 6, 220));
  EXPECT_EQ(runSnowsim("diff " + a + " " + b + " --mask " + mask).code, 1);

  r = runSnowsim("diff " + a + " " + b + " --mask " + small);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_TRUE(contains(r.output, "--mask " + small + " is 20x20 but " + a + " is 40x30"))
      << r.output;
  r = runSnowsim("diff " + a + " " + b + " --mask " + (dir / "nonesuch.png").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_TRUE(contains(r.output, "--mask " + (dir / "nonesuch.png").string())) << r.output;
  // A mask that leaves nothing to compare (all dark, or one inverted by mistake) is refused
  // rather than passing every frame.
  const std::string dark = (dir / "dark.png").string();
  snowsim::writePng(dark, flat(0));
  r = runSnowsim("diff " + a + " " + b + " --mask " + dark);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_TRUE(contains(r.output, "--mask " + dark + ": every pixel is dark")) << r.output;
  const std::string mask_bytes = bytesOf(mask);
  r = runSnowsim("diff " + a + " " + b + " --mask " + mask + " --json " + mask);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_TRUE(contains(r.output, "--json " + mask + ": is the --mask")) << r.output;
  EXPECT_EQ(bytesOf(mask), mask_bytes);
}

// A directory comparison in which no frame is in both directories compares nothing: it fails even
// when missing and extra frames are allowed (a render step that wrote no frames is not a pass).
TEST(DiffCommand, NoFrameComparedIsAFailure) {
  const TwoRuns runs("diff_none");
  const fs::path empty = runs.root / "empty";
  fs::create_directories(empty);
  for (const std::string& args : {runs.a.string() + " " + empty.string() + " --allow-missing",
                                  empty.string() + " " + runs.b.string() + " --allow-extra"}) {
    const Result r = runSnowsim("diff " + args);
    EXPECT_EQ(r.code, 1) << args << ": " << r.output;
    EXPECT_TRUE(contains(r.output, "(no frame is in both: nothing was compared)"))
        << args << ": " << r.output;
  }
}

// Bad input: exit 2, a message naming the file or option, and no report, whole or half.
TEST(DiffCommand, BadInputWritesNoReport) {
  const TwoRuns runs("diff_bad");
  const fs::path json = runs.root / "report.json", html = runs.root / "report";
  const std::string reports = " --json " + json.string() + " --html " + html.string();
  const auto expectRefused = [&](const std::string& args, const std::string& message) {
    const Result r = runSnowsim("diff " + args);
    EXPECT_EQ(r.code, 2) << args << ": " << r.output;
    EXPECT_TRUE(contains(r.output, message)) << args << ": " << r.output;
    EXPECT_FALSE(fs::exists(json)) << args;
    EXPECT_FALSE(fs::exists(html)) << args;
    EXPECT_FALSE(holdsNameStartingWith(runs.root, "report.")) << args << ": a temporary is left";
  };

  // Found only when the frame is reached, after a failing frame went into the HTML report.
  std::ofstream(runs.b / "frame_2.png") << "not a PNG";
  expectRefused(runs.args() + reports, (runs.b / "frame_2.png").string() + ": cannot read");

  expectRefused(
      runs.a.string() + " " + (runs.a / "frame_0.png").string() + reports,
      runs.a.string() + " is a directory but " + (runs.a / "frame_0.png").string() + " is not");
  expectRefused(runs.args() + " --out " + (runs.root / "d.png").string() + reports, "--out: ");
  expectRefused((runs.a / "frame_0.png").string() + " " + (runs.b / "frame_0.png").string() +
                    " --out " + runs.root.string() + reports,
                "--out " + runs.root.string() + ": is a directory");
  expectRefused(runs.args() + " --json /proc/snowsim/report.json", "--json /proc/snowsim");
  expectRefused(runs.args() + " --json " + runs.root.string(), "is a directory");
  expectRefused(runs.args() + " --html /proc/snowsim_report", "--html /proc/snowsim_report");
  expectRefused(runs.args() + " --html " + runs.a.string(), "exists and is not an earlier report");
  const std::string reference = (runs.a / "frame_0.png").string();
  const std::string reference_bytes = bytesOf(reference);
  expectRefused(runs.args() + " --json " + reference,
                "--json " + reference + ": is " + reference + ", one of the images compared");
  expectRefused(reference + " " + (runs.b / "frame_0.png").string() + " --out " + reference,
                "--out " + reference + ": is " + reference);
  EXPECT_EQ(bytesOf(reference), reference_bytes) << "the reference frame was replaced";
  EXPECT_TRUE(fs::exists(runs.a / "frame_0.png")) << "a directory in the way is left alone";

  const fs::path empty_a = runs.root / "empty_a", empty_b = runs.root / "empty_b";
  fs::create_directories(empty_a);
  fs::create_directories(empty_b);
  expectRefused(empty_a.string() + " " + empty_b.string() + reports, "neither holds a PNG frame");
}

TEST(DiffCommand, HelpExplainsTheUnits) {
  const Result r = runSnowsim("diff --help");
  EXPECT_EQ(r.code, 0);
  for (const char* part : {"YIQ colour distance", "1: black against white", "0.005 is 0.5%",
                           "paired by name", "--mask", "--json", "--html", "Exit codes"})
    EXPECT_TRUE(contains(r.output, part)) << part << " in\n" << r.output;
}

}  // namespace
