// Files a test writes go under one directory private to its process, removed once every test of
// the process has passed (ctest runs each test in a process of its own, so thousands would pile
// up); a failed test's files stay to be looked at.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

#include <gtest/gtest.h>

namespace snowsim_test {

inline std::filesystem::path processTempPath() {
  return std::filesystem::temp_directory_path() / ("snowsim_test_" + std::to_string(getpid()));
}

// The directory itself, created on first use.
inline std::filesystem::path processTempDir() {
  const std::filesystem::path dir = processTempPath();
  std::filesystem::create_directories(dir);
  return dir;
}

class TempDirCleanup : public ::testing::Environment {
 public:
  void TearDown() override {
    if (!::testing::UnitTest::GetInstance()->Passed()) return;
    std::error_code ignored;
    std::filesystem::remove_all(processTempPath(), ignored);
  }
};
inline const ::testing::Environment* const kTempDirCleanup =
    ::testing::AddGlobalTestEnvironment(new TempDirCleanup);

}  // namespace snowsim_test
