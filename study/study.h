// The speed/accuracy study (docs/study.md): scene families run over solver, time step, cell size
// and particles per cell, one CSV row per run with its wall time, steps, particles, error by each
// metric of study/metrics.h against a reference run, and how the run ended. A study can be split
// into shards run apart and merged into the CSV one process writes.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace snowsim {

// The i-th (1-based) of n shares of a study.
struct Shard {
  int index = 1;
  int count = 1;
};

// "i/n" with whole numbers 1 <= i <= n; else InputError naming --shard.
Shard parseShard(const std::string& text);

// One family of runs: every combination of its lists. A preset is one or more sweeps.
struct Sweep {
  std::vector<std::string> scenes;
  std::vector<std::string> solvers;
  std::vector<double> dts;
  std::vector<int> refines;
  std::vector<int> particles_per_cell;  // 2D counts; a 3D scene uses the nearest cube
  double duration;
  std::vector<double> E0s = {0};
  bool errors = true;  // false: the stability map records only how each run ended
};

// The sweeps of preset quick, full, stability or axes; else InputError naming --preset.
std::vector<Sweep> presetNamed(const std::string& name);

struct StudySettings {
  std::string scenes;          // the directory holding the scene files
  std::string out;             // the CSV, appended to
  int threads = 0;             // the MPM solver's threads; 0: the OpenMP default
  std::optional<Shard> shard;  // none: every run of the preset
};

struct StudyTally {
  int measured = 0;  // runs measured now
  int skipped = 0;   // runs the CSV already held for this build
  std::string build;
};

// Runs the preset's runs that this build has not measured yet into settings.out, saying each on
// stderr. Every scene is read before the CSV is begun.
StudyTally runStudy(const std::vector<Sweep>& preset, const StudySettings& settings);

// Joins shard CSVs into `out` (a new file), the CSV one process would have written: the header,
// then each run of the preset measured by this build, in the study's order. Refuses a run found
// in two shards, a run missing from all, and a run the preset does not have. Returns the runs.
size_t mergeShards(const std::string& preset, const std::vector<std::string>& shard_csvs,
                   const std::string& out);

}  // namespace snowsim
