// The subcommands of the snowsim command line. Each registers itself on the app and runs when
// chosen; errors are thrown (InputError: exit 2, SimulationError: exit 3).
#pragma once

#include <CLI/CLI.hpp>

namespace snowsim {

void addRunCommand(CLI::App& app);
void addResumeCommand(CLI::App& app);
void addRenderCommand(CLI::App& app);
void addFigureCommand(CLI::App& app);
void addDiffCommand(CLI::App& app);
void addStudyCommand(CLI::App& app);
void addClumpsCommand(CLI::App& app);

}  // namespace snowsim
