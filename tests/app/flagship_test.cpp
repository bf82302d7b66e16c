// The flagship scenes break up as docs/snow-at-scale.md says, checked at a quarter of their
// resolution (cell 20 mm), where a run takes seconds.
#include <gtest/gtest.h>

#include <sstream>
#include <string>

#include "tests/support/run_snowsim.h"

using namespace snowsim_test;
namespace fs = std::filesystem;

namespace {

// The last row of `snowsim clumps RUN`: its columns by name.
struct LastFrameClumps {
  double largest, other_chunks, single, second_chunk;
};

LastFrameClumps clumpsAtTheEnd(const fs::path& run) {
  const Result r = runSnowsim("clumps " + run.string());
  EXPECT_EQ(r.code, 0) << r.output;
  std::istringstream lines(r.output);
  std::string header, line, last;
  std::getline(lines, header);
  while (std::getline(lines, line))
    if (!line.empty()) last = line;
  const auto column = [&](const std::string& name) {
    std::istringstream names(header), values(last);
    std::string n, v;
    while (std::getline(names, n, ',') && std::getline(values, v, ','))
      if (n == name) return std::stod(v);
    ADD_FAILURE() << "no column " << name << " in " << header;
    return 0.0;
  };
  return {column("largest_share"), column("other_chunks_share"), column("single_share"),
          column("chunk2_mass_share")};
}

// The flagship scene `name` at --scale 0.25 with `settings`, into a fresh directory `out`.
fs::path quarterRun(const std::string& name, const std::string& out_name,
                    const std::string& settings) {
  const fs::path out = freshDir("flagship_" + out_name);
  const Result r = runSnowsim("run " + scene("flagship/" + name) + " -o " + out.string() +
                              " --scale 0.25 --threads 1 --no-png --no-mp4 " + settings);
  EXPECT_EQ(r.code, 0) << r.output;
  return out;
}

}  // namespace

// With cracks that open, the ball dropped on the box breaks into chunks by 0.4 s, on every jitter
// seed; without them (drop_on_box.json, the same ball and box) it lands whole at this cell.
TEST(FlagshipScenes, TheDropWithCracksBreaksIntoChunksWhereThePlainDropLandsWhole) {
  for (const int seed : {1, 2, 3}) {
    const std::string s = std::to_string(seed);
    const LastFrameClumps c =
        clumpsAtTheEnd(quarterRun("drop_on_box_cracks", "drop_cracks" + s, "--set seed=" + s));
    EXPECT_LT(c.largest, 0.8) << "seed " << seed;
    EXPECT_GT(c.other_chunks, 0.15) << "seed " << seed;
    EXPECT_GT(c.second_chunk, 0.04) << "seed " << seed;
    EXPECT_LT(c.single, 0.08) << "seed " << seed << ": the snow breaks into chunks, not dust";
  }
  const LastFrameClumps plain = clumpsAtTheEnd(quarterRun("drop_on_box", "drop", ""));
  EXPECT_GT(plain.largest, 0.99);
}
