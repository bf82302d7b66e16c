// Inputs the fuzz targets (fuzz/) found, or that are known to have broken a reader: each must be
// read or refused with an InputError naming the file, never crash. A new crash found by
// scripts/fuzz.sh goes into fuzz/regressions/TARGET/ and is tested here from then on.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "render/image.h"
#include "sim/core/errors.h"
#include "sim/io/checkpoint.h"
#include "sim/io/ply.h"
#include "sim/scene/json_fields.h"
#include "sim/scene/scene.h"

namespace snowsim {
namespace {

namespace fs = std::filesystem;

std::vector<fs::path> regressions(const std::string& target) {
  std::vector<fs::path> files;
  for (const auto& e :
       fs::directory_iterator(std::string(SNOWSIM_SOURCE_DIR) + "/fuzz/regressions/" + target))
    files.push_back(e.path());
  return files;
}

// Reads the file with `read`; an InputError must name it.
template <class Read>
void expectReadOrRefused(const fs::path& file, Read read) {
  try {
    read(file.string());
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
  }
}

// A checkpoint and its solver state read as fuzz/checkpoint_fuzzer.cpp reads them: an empty
// array once reached memcpy with a null pointer.
TEST(ReaderRegressions, CheckpointFiles) {
  for (const fs::path& file : regressions("checkpoint"))
    expectReadOrRefused(file, [](const std::string& path) {
      const Checkpoint c = readCheckpoint(path);
      StateReader in(c.solver_state, path);
      std::vector<double> array;
      in.value<long>();
      in.array(array);
      in.array(array, 3);
    });
}

TEST(ReaderRegressions, PlyFiles) {
  const auto files = regressions("ply");
  EXPECT_FALSE(files.empty());
  for (const fs::path& f : files) {
    SCOPED_TRACE(f);
    EXPECT_THROW(readPly(f.string()), InputError);
  }
}

TEST(ReaderRegressions, PngFiles) {
  for (const fs::path& f : regressions("png")) {
    SCOPED_TRACE(f);
    expectReadOrRefused(f, [](const std::string& path) { readPng(path); });
  }
}

// The scene target's input: the file's text, then each --set override after a NUL byte.
TEST(ReaderRegressions, SceneFilesWithOverrides) {
  for (const fs::path& f : regressions("scene")) {
    SCOPED_TRACE(f);
    expectReadOrRefused(f, [](const std::string& path) {
      std::ifstream in(path, std::ios::binary);
      std::stringstream text;
      text << in.rdbuf();
      std::vector<std::string> parts;
      std::stringstream split(text.str());
      for (std::string part; std::getline(split, part, '\0');) parts.push_back(part);
      const std::vector<std::string> overrides(parts.begin() + 1, parts.end());
      const Scene s = loadScene(parseJsonText(parts.at(0), path), path, overrides);
      parseScene(sceneToJson(s), path);
    });
  }
}

}  // namespace
}  // namespace snowsim
