// Running the snowsim binary from a test, as a user would, and a fresh directory for its output.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/temp_dir.h"

namespace snowsim_test {

struct Result {
  int code;
  std::string output;  // stdout and stderr together
};

// Runs a shell command line, e.g. a snowsim binary with its arguments.
inline Result runCommand(const std::string& command_line) {
  const std::string command = command_line + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  std::string output;
  std::array<char, 4096> buffer;
  while (size_t n = fread(buffer.data(), 1, buffer.size(), pipe)) output.append(buffer.data(), n);
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, output};
}

// The path of a shipped scene file, e.g. scene("snowball_drop") or scene("flagship/smash_wall").
inline std::string scene(const std::string& name) {
  return std::string(SNOWSIM_SOURCE_DIR) + "/scenes/" + name + ".json";
}

inline Result runSnowsim(const std::string& args) {
  return runCommand(std::string(SNOWSIM_BINARY) + " " + args);
}

// Starts `snowsim ARGS...` in a child process, its stderr into `log` (by default discarded); a
// test signals and reaps it.
inline pid_t startSnowsim(std::vector<std::string> args, const std::string& log = "/dev/null") {
  args.insert(args.begin(), SNOWSIM_BINARY);
  std::vector<char*> argv;
  for (std::string& arg : args) argv.push_back(arg.data());
  argv.push_back(nullptr);
  const pid_t child = fork();
  if (child == 0) {
    freopen(log.c_str(), "w", stderr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return child;
}

inline std::string bytesOf(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

// Every frame file of a run directory, by name, with its bytes.
inline std::map<std::string, std::string> frames(const std::filesystem::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("frame_", 0) == 0) files[name] = bytesOf(entry.path());
  }
  return files;
}

// An empty path under the test process's temporary directory.
inline std::filesystem::path freshDir(const std::string& name) {
  const std::filesystem::path dir = processTempDir() / name;
  std::filesystem::remove_all(dir);
  return dir;
}

}  // namespace snowsim_test
