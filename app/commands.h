// The subcommands of the snowsim command line. Each registers itself on the app and runs when
// chosen; errors are thrown (InputError: exit 2, SimulationError: exit 3).
#pragma once

#include <exception>

#include <CLI/CLI.hpp>

namespace snowsim {

// snowsim's command line: parses it, runs the command chosen and returns the exit code.
int runCommandLine(int argc, char** argv);

void addRunCommand(CLI::App& app);
void addResumeCommand(CLI::App& app);
void addRenderCommand(CLI::App& app);
void addFigureCommand(CLI::App& app);
void addDiffCommand(CLI::App& app);
void addStudyCommand(CLI::App& app);
void addClumpsCommand(CLI::App& app);

// Prints a command's error on stderr and returns its exit code: 2 bad input, 3 the simulation
// failed, 4 anything else.
int reportFailure(const std::exception& e);
// The exit code reportFailure gives, without the message.
int exitCodeOf(const std::exception& e);
// Whether this process is rank 0 of an mpirun launch, or not launched by mpirun at all; known
// from mpirun's environment before MPI is started.
bool launchedAsRankZero();

}  // namespace snowsim
