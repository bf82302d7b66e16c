// Visual regression: each case of tests/render/golden/cases.txt, a test of its own named after it,
// is simulated and rendered by the snowsim command line and compared with its golden image by
// `snowsim diff`. Tolerance (docs/rendering.md), the same for every case: a pixel differs beyond a
// YIQ distance of 0.1, and at most 0.5% of the pixels may differ, which covers the isolated pixels
// another CPU flips where spheres meet. On failure the rendered, golden and diff images are left
// in the test's working directory and named in the message.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <ostream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

struct GoldenCase {
  std::string name, scene, options;
};

// How GoogleTest shows a case's parameter: its name.
void PrintTo(const GoldenCase& c, std::ostream* os) {
  *os << c.name;
}

std::vector<GoldenCase> goldenCases() {
  std::ifstream in(std::string(SNOWSIM_SOURCE_DIR) + "/tests/render/golden/cases.txt");
  std::vector<GoldenCase> cases;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const size_t a = line.find('|'), b = line.find('|', a + 1);
    cases.push_back({line.substr(0, a), line.substr(a + 1, b - a - 1), line.substr(b + 1)});
  }
  return cases;
}

int exitCode(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// The cases file lists the eight cases; each is a test of its own below, named after it, so a
// failing case hides none of the others.
TEST(Golden, CasesFileListsEightCases) {
  ASSERT_EQ(goldenCases().size(), 8u);
}

class GoldenCaseTest : public testing::TestWithParam<GoldenCase> {};

TEST_P(GoldenCaseTest, RenderedSceneMatchesItsGoldenImage) {
  const GoldenCase& c = GetParam();
  const std::string snowsim = SNOWSIM_BINARY;
  const fs::path dir = fs::current_path() / "golden_out" / c.name;
  fs::remove_all(dir);
  ASSERT_EQ(exitCode(snowsim + " run " + SNOWSIM_SOURCE_DIR + "/scenes/" + c.scene + ".json -o " +
                     dir.string() + " --no-ply --no-mp4 " + c.options + " > /dev/null 2>&1"),
            0)
      << c.name;
  const fs::path rendered = dir / "frame_00001.png", diff = dir / "diff.png";
  const std::string golden =
      std::string(SNOWSIM_SOURCE_DIR) + "/tests/render/golden/" + c.name + ".png";
  const int code = exitCode(snowsim + " diff " + rendered.string() + " " + golden +
                            " --threshold 0.1 --max-share 0.005 --out " + diff.string() + " > " +
                            (dir / "diff.txt").string() + " 2>&1");
  std::ifstream summary(dir / "diff.txt");
  const std::string text((std::istreambuf_iterator<char>(summary)), {});
  EXPECT_EQ(code, 0) << c.name << ": " << text << "rendered " << rendered.string() << ", golden "
                     << golden << ", diff " << diff.string();
}

INSTANTIATE_TEST_SUITE_P(Golden, GoldenCaseTest, testing::ValuesIn(goldenCases()),
                         [](const testing::TestParamInfo<GoldenCase>& info) {
                           return info.param.name;
                         });

// The comparison is not blind: a golden against a different picture fails.
TEST(Golden, ADifferentPictureFails) {
  const std::string dir = std::string(SNOWSIM_SOURCE_DIR) + "/tests/render/golden/";
  EXPECT_EQ(exitCode(std::string(SNOWSIM_BINARY) + " diff " + dir + "snowball_drop_halfway.png " +
                     dir + "column_density_cells.png --max-share 0.005 > /dev/null 2>&1"),
            1);
}

}  // namespace
