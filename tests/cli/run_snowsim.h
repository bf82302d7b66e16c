// Running the snowsim binary from a test, as a user would, and a fresh directory for its output.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

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

inline Result runSnowsim(const std::string& args) {
  return runCommand(std::string(SNOWSIM_BINARY) + " " + args);
}

// Starts `snowsim ARGS...` in a child process, its stderr discarded; a test signals and reaps it.
inline pid_t startSnowsim(std::vector<std::string> args) {
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

// An empty path under the temporary directory, private to this test process.
inline std::filesystem::path freshDir(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("snowsim_cli_" + std::to_string(getpid())) / name;
  std::filesystem::remove_all(dir);
  return dir;
}

}  // namespace snowsim_test
