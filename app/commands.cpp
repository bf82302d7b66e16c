#include "app/commands.h"

#include <cstdio>
#include <cstdlib>
#include <new>
#include <string>
#include <utility>

#include "app/interrupt.h"
#include "app/memory_budget.h"
#include "app/options.h"
#include "sim/core/errors.h"
#include "version.h"

namespace snowsim {

int runCommandLine(int argc, char** argv) {
  CLI::App app{
      "snowsim: simulates snow (the report's density hybrid method and MPM snow) and "
      "renders it off-screen into PNG frames, MP4 videos and figure strips."};
  app.require_subcommand(1);
  app.set_version_flag("--version", "snowsim " SNOWSIM_VERSION " (commit " SNOWSIM_COMMIT ")");
  // The parser's errors in the form of snowsim's own, with where to read more.
  const std::string command = argc > 1 && argv[1][0] != '-' ? argv[1] : "COMMAND";
  app.failure_message([command](const CLI::App*, const CLI::Error& e) {
    return "snowsim: error: " + std::string(e.what()) + "\n(snowsim " + command +
           " --help lists the options)\n";
  });
  recordCommandLine(argc, argv);
  addRunCommand(app);
  addResumeCommand(app);
  addRenderCommand(app);
  addFigureCommand(app);
  addDiffCommand(app);
  addStudyCommand(app);
  addClumpsCommand(app);
  // CLI11 answers a misspelt command with "A subcommand is required"; name it instead.
  if (argc > 1 && argv[1][0] != '-') {
    std::string names;
    bool known = false;
    for (const CLI::App* command :
         std::as_const(app).get_subcommands([](const CLI::App*) { return true; })) {
      known = known || command->check_name(argv[1]);
      names += (names.empty() ? "" : ", ") + command->get_name();
    }
    if (!known) {
      const std::string word = argv[1];
      const bool scene_file = word.size() > 5 && word.compare(word.size() - 5, 5, ".json") == 0;
      std::fprintf(stderr, "snowsim: error: unknown command '%s'; the commands are %s%s\n", argv[1],
                   names.c_str(),
                   scene_file ? " (a scene runs with: snowsim run SCENE.json)"
                              : " (snowsim --help says more)");
      return 2;
    }
  }
  // A run across MPI ranks: every rank parses the same command line, and an error that reaches
  // here is one every rank met alike (one a rank meets alone ends every rank through MPI_Abort):
  // rank 0 alone says so. (Study shards under mpirun are independent runs: each speaks.)
  const bool distributed_run =
      argc > 1 && (std::string(argv[1]) == "run" || std::string(argv[1]) == "resume");
  const bool quiet = distributed_run && !launchedAsRankZero();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = quiet && e.get_exit_code() != 0 ? e.get_exit_code() : app.exit(e);
    return code == 0 ? 0 : 2;
  } catch (const Interrupted& e) {
    if (!quiet) std::fprintf(stderr, "snowsim: %s\n", e.what());
    return 128 + e.signal;
  } catch (const std::exception& e) {
    if (quiet) return exitCodeOf(e);
    return reportFailure(e);
  }
  return 0;
}

bool launchedAsRankZero() {
  const char* rank = std::getenv("OMPI_COMM_WORLD_RANK");
  return !rank || std::string(rank) == "0";
}

int exitCodeOf(const std::exception& e) {
  if (dynamic_cast<const InputError*>(&e)) return 2;
  if (dynamic_cast<const SimulationError*>(&e)) return 3;
  if (dynamic_cast<const OutOfMemory*>(&e) || dynamic_cast<const std::bad_alloc*>(&e)) return 5;
  return 4;
}

int reportFailure(const std::exception& e) {
  const int code = exitCodeOf(e);
  const char* kind = code == 2   ? "error"
                     : code == 3 ? "simulation failed"
                     : code == 5 ? "out of memory"
                                 : "internal error";
  std::fprintf(stderr, "snowsim: %s: %s\n", kind, e.what());
  return code;
}

}  // namespace snowsim
