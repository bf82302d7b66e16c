#include "app/options.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>

#include "sim/core/errors.h"

namespace snowsim {

namespace {
std::vector<std::string> command_line;
}  // namespace

void recordCommandLine(int argc, char** argv) {
  command_line.assign(argv, argv + argc);
}

std::vector<std::string> argumentsAfter(const std::string& subcommand) {
  const auto at = std::find(command_line.begin(), command_line.end(), subcommand);
  return at == command_line.end() ? std::vector<std::string>()
                                  : std::vector(at + 1, command_line.end());
}

void addThreadsOption(CLI::App& command, int& threads) {
  const auto check = [](std::string& text) -> std::string {
    const bool digits =
        !text.empty() && text.size() <= 4 &&
        std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); });
    if (digits && std::stoi(text) >= 1 && std::stoi(text) <= 1024) return "";
    return "\"" + text + "\" is not allowed; allowed: a whole number from 1 to 1024";
  };
  command
      .add_option("--threads", threads,
                  "Threads of the MPM solver (default: OMP_NUM_THREADS, else every core); the "
                  "simulated frames do not depend on it. Drawing (llvmpipe: LP_NUM_THREADS) and "
                  "the MP4 encoder use the cores they find")
      ->check(CLI::Validator(check, "1 to 1024"));
}

CLI::Validator zeroOrMore(bool whole) {
  const std::string allowed = whole ? "a whole number, 0 or more" : "a number, 0 or more";
  const auto check = [whole, allowed](std::string& text) -> std::string {
    const char* end = text.data() + text.size();
    bool fits = false;
    if (whole) {  // what an int option reads: digits, within int
      int value = -1;
      const auto [at, error] = std::from_chars(text.data(), end, value);
      fits = error == std::errc() && at == end && value >= 0;
    } else {
      double value = -1;
      const auto [at, error] = std::from_chars(text.data(), end, value);
      fits = error == std::errc() && at == end && value >= 0 && std::isfinite(value);
    }
    return fits ? "" : "\"" + text + "\" is not allowed; allowed: " + allowed;
  };
  return CLI::Validator(check, "0 or more");
}

void addOffFlag(CLI::App& command, const std::string& name, bool& value, const std::string& help) {
  command.add_flag_callback(
      name, [&value] { value = false; }, help);
}

std::vector<std::string> scenesPaths(const std::string& path) {
  std::vector<std::string> paths = {path};
  std::error_code error;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    paths.push_back((exe.parent_path() / path).string());
    paths.push_back((exe.parent_path().parent_path() / "share/snowsim" / path).string());
  }
  return paths;
}

std::string findInScenes(const std::string& path, const std::string& what,
                         const std::string& advice) {
  std::string tried;
  const std::vector<std::string> candidates = scenesPaths(path);
  for (const std::string& candidate : candidates) {
    std::error_code unreadable;  // a directory we may not look into: not found there
    if (std::filesystem::exists(candidate, unreadable)) return candidate;
    tried += (tried.empty() ? "" : ", ") + candidate;
  }
  if (candidates.size() == 1) tried += "; where the executable lies is unknown";
  throw InputError("no " + what + " found (looked for " + tried + "); " + advice);
}

}  // namespace snowsim
