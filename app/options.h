// Options several subcommands share.
#pragma once

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace snowsim {

// The command line as main() received it, for a run to record; the arguments after the
// subcommand `name` in it.
void recordCommandLine(int argc, char** argv);
std::vector<std::string> argumentsAfter(const std::string& subcommand);

// --threads N: the MPM solver's threads, 1 to 1024; `threads` stays 0 (the OpenMP default) when
// the option is not given.
void addThreadsOption(CLI::App& command, int& threads);

// A check that an option's value is a number (whole: a whole number) of 0 or more, naming what is
// allowed where CLI11's own check would print its range's limits in full.
CLI::Validator zeroOrMore(bool whole);

// Where a file or directory of the sources' `scenes/` is looked for when no option names it, in
// order: the current directory (a checkout of the sources), beside the executable (the build
// tree, a moved binary with its scenes), an installation's share directory. `path` starts with
// "scenes".
std::vector<std::string> scenesPaths(const std::string& path);
// The first of scenesPaths(path) that exists; else InputError naming `what`, the paths tried and
// the advice (the option that names it instead).
std::string findInScenes(const std::string& path, const std::string& what,
                         const std::string& advice);

// A flag that turns `value` off, e.g. --no-png; its help reads without CLI11's "{false}".
void addOffFlag(CLI::App& command, const std::string& name, bool& value, const std::string& help);

}  // namespace snowsim
