// What `snowsim run` writes into its output directory, recognised by name, so that a new run never
// leaves an earlier run's frames beside its own and never removes a file it did not write.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sim/io/files.h"

namespace snowsim {

// The files of an earlier run in dir: frame_NNNNN.ply and .png, run.json, colliders.json, the
// video run.json names or `video` (the file this run's video would replace), its checkpoints
// (checkpoint.snowsim and .prev), and leftover temporaries (NAME.tmp, NAME.part) of any of them.
// Sorted.
std::vector<std::filesystem::path> earlierRunFiles(const std::filesystem::path& dir,
                                                   const std::string& video);

// Throws InputError listing an earlier run's frames, run.json or video when dir holds them.
void refuseEarlierRun(const std::string& dir, const std::string& video);

// For --overwrite, once the run's set-up has accepted the scene: removes exactly the earlier
// run's files (temporaries included) and says on stderr what it removed.
void removeEarlierRun(const std::string& dir, const std::string& video);

// What `snowsim render` would replace in dir: every frame_NNNNN.png (with png), the video (with a
// non-empty video) and their leftover temporaries. Sorted.
std::vector<std::filesystem::path> renderedFiles(const std::filesystem::path& dir, bool png,
                                                 const std::string& video);

// Throws InputError naming the first such file and --overwrite when dir holds frames or a video
// a render would write over (the run's own or an earlier render's).
void refuseEarlierRender(const std::string& dir, bool png, const std::string& video);

// For render --overwrite, once every setting and frame has been checked: removes those files, so
// that the directory holds one render's frames, and says on stderr what it removed.
void removeEarlierRender(const std::string& dir, bool png, const std::string& video);

// Holds dir for one run (or resume) while it lives: a second run, or a resume, given the same
// directory is refused instead of writing its frames among this one's. A lock on dir/.snowsim.lock
// that the kernel releases when the process ends, however it ends; the file holds the process id
// and is removed when the run ends, also by a second signal. A file left by a killed run holds no
// lock and is taken over; where the file system cannot lock, a warning says so and only a file
// naming a live process refuses the run.
class RunDirectoryLock {
 public:
  // Throws InputError when another process holds dir.
  explicit RunDirectoryLock(const std::string& dir);
  // Throws the same InputError when another process holds dir, without taking the lock: what
  // resume checks before it reads the checkpoint of a run that may still be going.
  static void refuseIfHeld(const std::string& dir);
  ~RunDirectoryLock();
  RunDirectoryLock(const RunDirectoryLock&) = delete;
  RunDirectoryLock& operator=(const RunDirectoryLock&) = delete;

 private:
  std::string path_;
  int fd_ = -1;
  std::optional<UnfinishedFile> removed_at_once_;
};

}  // namespace snowsim
