#include "app/run_checkpoint.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "sim/core/errors.h"
#include "sim/io/checkpoint.h"
#include "sim/scene/json_fields.h"
#include "version.h"

namespace snowsim {

namespace fs = std::filesystem;

namespace {

std::uint32_t scalarBytes(const Scene& scene) {
  return scene.solver == SolverType::Mpm && scene.mpm.precision == MpmPrecision::Float ? 4 : 8;
}

std::uint64_t hashOf(const nlohmann::json& resolved_scene) {
  return fnv1a(resolved_scene.dump());
}

}  // namespace

bool mpirunMayKillTheCheckpoint() {
  if (!std::getenv("OMPI_MCA_orte_hnp_uri")) return false;  // not ORTE's mpirun
  constexpr const char* kSetting = "odls_base_sigkill_timeout";
  if (std::getenv((std::string("OMPI_MCA_") + kSetting).c_str())) return false;
  const char* home = std::getenv("HOME");
  for (const std::string& file : {std::string(home ? home : "") + "/.openmpi/mca-params.conf",
                                  std::string("/etc/openmpi/openmpi-mca-params.conf")}) {
    std::ifstream in(file);
    for (std::string line; std::getline(in, line);) {
      const size_t start = line.find_first_not_of(" \t");
      if (start != std::string::npos && line[start] != '#' &&
          line.find(kSetting) != std::string::npos)
        return false;
    }
  }
  return true;
}

std::string checkpointPath(const std::string& dir) {
  return dir + "/checkpoint.snowsim";
}

bool CheckpointCadence::due(int frames_written) {
  const bool by_count = every_frames_ > 0 && frames_written % every_frames_ == 0;
  const bool by_time =
      minutes_ > 0 && std::chrono::duration<double>(Clock::now() - last_).count() >= 60 * minutes_;
  if (by_count || by_time) last_ = Clock::now();
  return by_count || by_time;
}

std::uint64_t sceneHash(const Scene& scene) {
  return hashOf(sceneToJson(scene));
}

void saveCheckpoint(const std::string& dir, const Scene& scene, const Simulation& simulation,
                    nlohmann::json run_state, bool across_ranks) {
  writeCheckpointFile(checkpointPath(dir), scene, simulation, std::move(run_state), across_ranks);
}

void writeCheckpointFile(const std::string& file, const Scene& scene, const Simulation& simulation,
                         nlohmann::json run_state, bool across_ranks) {
  run_state["scene"] = sceneToJson(scene);
  run_state["scene_file"] = scene.file;
  CheckpointHeader header;
  header.dimension = static_cast<std::uint32_t>(scene.dimension);
  header.scalar_bytes = scalarBytes(scene);
  header.scene_hash = sceneHash(scene);
  header.snowsim_version = SNOWSIM_VERSION;
  if (!across_ranks) {
    writeCheckpoint(file, header, run_state.dump(),
                    [&](StateWriter& out) { simulation.saveState(out); });
    return;
  }
  // The gather meets the other ranks once: its bytes are kept for the count and the write.
  StateWriter gathered;
  simulation.saveState(gathered);
  writeCheckpoint(file, header, run_state.dump(),
                  [&](StateWriter& out) { out.append(gathered.bytes()); });
}

SavedRun readCheckpointFile(const std::string& file) {
  Checkpoint checkpoint = readCheckpoint(file);
  const auto refuse = [&](const std::string& problem) { return InputError(file + ": " + problem); };
  if (checkpoint.header.snowsim_version != SNOWSIM_VERSION)
    throw refuse("written by snowsim " + checkpoint.header.snowsim_version + "; this is snowsim " +
                 SNOWSIM_VERSION + ", whose steps may differ: resume it with that version");
  SavedRun saved;
  saved.file = file;
  saved.scene_hash = checkpoint.header.scene_hash;
  saved.run_state = nlohmann::json::parse(checkpoint.run_state, nullptr, false);
  if (!saved.run_state.is_object() || !saved.run_state.contains("scene") ||
      !saved.run_state["scene_file"].is_string())
    throw refuse("its run state is not what snowsim writes");
  try {
    saved.scene = parseScene(saved.run_state["scene"], saved.run_state["scene_file"]);
  } catch (const InputError& e) {
    throw refuse(std::string("its scene does not load: ") + e.what());
  }
  if (sceneHash(saved.scene) != checkpoint.header.scene_hash ||
      static_cast<int>(checkpoint.header.dimension) != saved.scene.dimension ||
      checkpoint.header.scalar_bytes != scalarBytes(saved.scene))
    throw refuse("its state is of another scene than the one it records");
  saved.solver_state = std::move(checkpoint.solver_state);
  return saved;
}

SavedRun loadCheckpoint(const std::string& dir) {
  const std::string file = checkpointPath(dir);
  if (!fs::exists(file))
    throw InputError(file + ": no checkpoint to resume from" +
                     (fs::exists(dir + "/run.json") ? " (run.json is there: the run ended)"
                                                    : " (is " + dir + " a run's --out?)"));
  // A damaged checkpoint names the one before it, kept beside it, to resume from instead.
  SavedRun saved = [&] {
    try {
      return readCheckpointFile(file);
    } catch (const DamagedCheckpoint& e) {
      const std::string previous = file + ".prev";
      if (!fs::exists(previous)) throw;
      throw InputError(std::string(e.what()) + "; the checkpoint before it is " + previous +
                       ": `mv " + previous + " " + file + "` resumes from there");
    }
  }();
  const auto refuse = [&](const std::string& problem) { return InputError(file + ": " + problem); };
  if (!saved.run_state["args"].is_array() || !saved.run_state["next_frame"].is_number_integer())
    throw refuse("its run state is not what snowsim writes");
  const int next_frame = saved.run_state["next_frame"].get<int>();
  if (next_frame < 0 || next_frame > saved.scene.frameCount())
    throw refuse("its next frame, " + std::to_string(next_frame) + ", is not one of the run's");
  // A run stopped by a signal has a run.json: it must be the same run's.
  std::ifstream summary_file(dir + "/run.json");
  const auto summary = nlohmann::json::parse(summary_file, nullptr, false);
  if (summary.is_object() && summary.contains("resolved_scene") &&
      hashOf(summary["resolved_scene"]) != saved.scene_hash)
    throw refuse("of another scene than " + dir + "/run.json records (" +
                 summary.value("scene", std::string("?")) + "); resume only the run it belongs to");
  return saved;
}

void removeCheckpoints(const std::string& dir) {
  for (const char* suffix : {"", ".prev"}) fs::remove(checkpointPath(dir) + suffix);
}

}  // namespace snowsim
