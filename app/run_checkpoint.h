// The checkpoints of `snowsim run` (sim/io/checkpoint.h holds the file format): when a run writes
// one, what the run layer keeps in it besides the solver's state, and reading one back for
// `snowsim resume`.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "sim/scene/scene.h"
#include "sim/simulation.h"

namespace snowsim {

// DIR/checkpoint.snowsim; the one before it stays as checkpoint.snowsim.prev.
std::string checkpointPath(const std::string& dir);

// Wall time between checkpoints when neither the scene nor the command line says.
constexpr double kDefaultCheckpointMinutes = 5;

// When a run writes a checkpoint at a frame boundary: every `every_frames` frames (0: not by
// count) and once `minutes` of wall time have passed since the last one (0: not by time).
class CheckpointCadence {
 public:
  CheckpointCadence(int every_frames, double minutes)
      : every_frames_(every_frames), minutes_(minutes) {}
  // After `frames_written` frames: whether to write one now (then the clock starts anew).
  bool due(int frames_written);

 private:
  using Clock = std::chrono::steady_clock;
  int every_frames_;
  double minutes_;
  Clock::time_point last_ = Clock::now();
};

// Whether the ranks were launched by OpenMPI 4's mpirun (ORTE) without odls_base_sigkill_timeout
// where they can see it: on mpirun's command line or in its environment (both reach the ranks as
// OMPI_MCA_odls_base_sigkill_timeout), or in OpenMPI's default parameter files. Stopped, that
// mpirun passes the stop on to the ranks and kills them 1 s later unless set, mostly before their
// checkpoint is written.
bool mpirunMayKillTheCheckpoint();

// The hash that ties a checkpoint to its scene: of the resolved scene as run.json records it.
std::uint64_t sceneHash(const Scene& scene);

// Writes DIR's checkpoint: the simulation's state and the run layer's `run_state`, to which the
// resolved scene is added. InputError naming the file when it cannot be written; the earlier
// checkpoint is then intact. across_ranks: the state gathers every MPI rank's (each rank saves
// its state once, at the same time), which is kept in memory; else it streams to the file.
void saveCheckpoint(const std::string& dir, const Scene& scene, const Simulation& simulation,
                    nlohmann::json run_state, bool across_ranks);

// The same file at any path (the Python module's save): run_state needs no more than the scene,
// which is added.
void writeCheckpointFile(const std::string& file, const Scene& scene, const Simulation& simulation,
                         nlohmann::json run_state, bool across_ranks);

struct SavedRun {
  std::string file;  // the checkpoint read
  Scene scene;       // the resolved scene it ran
  std::uint64_t scene_hash = 0;
  nlohmann::json run_state;
  std::string solver_state;
};

// A checkpoint file, checked for this snowsim version and against the scene it records:
// InputError naming the file otherwise (DamagedCheckpoint, sim/io/checkpoint.h, when truncated or
// corrupted). Whatever run state it holds beside the scene is the caller's to check.
SavedRun readCheckpointFile(const std::string& file);

// DIR's checkpoint, checked: InputError naming the file when there is none, or it is truncated,
// corrupted, of another snowsim version, or of another scene than its own header or DIR's
// run.json names. Writes nothing.
SavedRun loadCheckpoint(const std::string& dir);

// Removes DIR's checkpoints once its run is complete.
void removeCheckpoints(const std::string& dir);

}  // namespace snowsim
