// snowsim study: the study of study/study.h over the presets, its shards and their merge.
#include <cstdio>

#include "app/commands.h"
#include "app/options.h"
#include "study/study.h"

namespace snowsim {

namespace {

struct StudyOptions {
  std::string preset = "full";
  std::string scenes;  // empty: the first of scenesPaths("scenes") that exists
  std::string out = "docs/study/results.csv";
  int threads = 0;                 // the MPM solver's threads; 0: the OpenMP default
  std::string shard;               // "i/n": run the i-th of n shares of the sweep; empty: all of it
  std::vector<std::string> merge;  // shard CSVs to join into `out`
};

// The preset, the scene directory and the shard are checked in this order, before any scene is
// read.
void study(const StudyOptions& options) {
  const std::vector<Sweep> preset = presetNamed(options.preset);
  StudySettings settings;
  settings.scenes = options.scenes.empty()
                        ? findInScenes("scenes", "scene directory", "give it with --scenes")
                        : options.scenes;
  settings.out = options.out;
  settings.threads = options.threads;
  if (!options.shard.empty()) settings.shard = parseShard(options.shard);
  const StudyTally tally = runStudy(preset, settings);
  std::printf("study: %d runs measured, %d already measured for build %s; results in %s\n",
              tally.measured, tally.skipped, tally.build.c_str(), options.out.c_str());
}

}  // namespace

void addStudyCommand(CLI::App& app) {
  auto options = std::make_shared<StudyOptions>();
  CLI::App* cmd = app.add_subcommand(
      "study", "Measure speed against accuracy over solvers, time steps and resolutions");
  cmd->add_option("--preset", options->preset, "quick | full | stability | axes")
      ->capture_default_str();
  cmd->add_flag_callback(
      "--quick", [options] { options->preset = "quick"; },
      "Same as --preset quick: 21 short runs, seconds, for CI");
  cmd->add_option("--scenes", options->scenes,
                  "Directory holding the scene files. Default: scenes/ in the current "
                  "directory, else beside the executable (EXE_DIR/scenes), else in an "
                  "installation (EXE_DIR/../share/snowsim/scenes)");
  cmd->add_option("-o,--out", options->out,
                  "CSV file; rows already measured by this build "
                  "are kept and skipped")
      ->capture_default_str();
  addThreadsOption(*cmd, options->threads);
  auto* shard = cmd->add_option("--shard", options->shard,
                                "i/n: run only the i-th of n shares of the sweep (1 <= i <= n), "
                                "e.g. one task of a cluster job array; -o defaults to "
                                "docs/study/results.shard-I-of-N.csv");
  cmd->add_option("--merge", options->merge,
                  "Join these shard CSVs into -o (a new file), in the order one process "
                  "writes; refuses runs missing, found twice or not of --preset")
      ->excludes(shard)
      ->expected(1, -1);
  cmd->footer(
      "Each row: the configuration, wall time, steps, particles, errors against a reference run "
      "(density field, height profile, centre-of-mass path), the free-fall error, how far the "
      "thrown ball's centre ends past the tower's far face, and how the run ended: finished, "
      "diverged (stopped by the divergence check), nan, escaped (left the domain) or tunnelled "
      "(the ball through the tower). Failed runs leave their error columns empty. Charts: "
      "scripts/charts.sh.");
  cmd->callback([options, cmd] {
    if (!options->merge.empty()) {
      const size_t runs = mergeShards(options->preset, options->merge, options->out);
      std::printf("study: %zu runs of %zu shards merged into %s\n", runs, options->merge.size(),
                  options->out.c_str());
      return;
    }
    if (!options->shard.empty() && cmd->count("--out") == 0) {
      const Shard shard = parseShard(options->shard);
      options->out = "docs/study/results.shard-" + std::to_string(shard.index) + "-of-" +
                     std::to_string(shard.count) + ".csv";
    }
    study(*options);
  });
}

}  // namespace snowsim
