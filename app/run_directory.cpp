#include "app/run_directory.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <regex>

#include <nlohmann/json.hpp>

#include "sim/core/errors.h"
#include "sim/io/files.h"

namespace snowsim {

namespace fs = std::filesystem;

namespace {

const std::string kTemporary = ".tmp";      // sim/io/files.h: writeFileAtomically's suffix
const std::string kPartialVideo = ".part";  // render/video_encoder.cpp: the video being encoded

bool isTemporary(const fs::path& file) {
  return file.extension() == kTemporary || file.extension() == kPartialVideo;
}

// Drops `suffix` from the end of name, if it ends so.
void dropSuffix(std::string& name, const std::string& suffix) {
  if (name.size() > suffix.size() &&
      name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0)
    name.resize(name.size() - suffix.size());
}

// The video an earlier run recorded in its run.json, or "" when there is none.
std::string recordedVideo(const fs::path& dir) {
  std::ifstream in(dir / "run.json");
  if (!in) return "";
  const auto summary = nlohmann::json::parse(in, nullptr, false);
  if (!summary.is_object() || !summary.contains("video") || !summary["video"].is_string())
    return "";
  const std::string name = summary["video"];
  // A bare file name only: a run.json edited to name ../something must not reach outside.
  return fs::path(name).filename() == name ? name : "";
}

// "51 PNG frames, 51 PLY frames, run.json, ball.mp4": what the files are, counted.
std::string describe(const std::vector<fs::path>& files) {
  std::map<std::string, int> frames;
  std::string others;
  int temporaries = 0;
  for (const fs::path& file : files) {
    const std::string name = file.filename().string();
    if (isTemporary(file))
      ++temporaries;
    else if (name.rfind("surface_", 0) == 0)
      ++frames[file.extension() == ".obj" ? "surface OBJ" : "surface PLY"];
    else if (name.rfind("frame_", 0) == 0)
      ++frames[file.extension() == ".png" ? "PNG" : file.extension() == ".vdb" ? "VDB" : "PLY"];
    else
      others += ", " + name;
  }
  std::string text;
  for (const auto& [kind, count] : frames)
    text += (text.empty() ? "" : ", ") + std::to_string(count) + " " + kind + " frames";
  text += others;
  if (temporaries > 0) text += ", " + std::to_string(temporaries) + " unfinished temporary files";
  return text.rfind(", ", 0) == 0 ? text.substr(2) : text;
}

// The files in dir, sorted, whose names `keep` takes, a temporary by the name it is written for.
template <class Keep>
std::vector<fs::path> filesIn(const fs::path& dir, Keep&& keep) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    if (!entry.is_regular_file() && !entry.is_symlink()) continue;
    std::string name = entry.path().filename().string();
    dropSuffix(name, kTemporary);
    dropSuffix(name, kPartialVideo);
    if (keep(name)) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

void removeFiles(const std::vector<fs::path>& files) {
  for (const fs::path& file : files) {
    std::error_code ec;
    fs::remove(file, ec);
    if (ec) throw InputError(file.string() + ": cannot remove it (" + ec.message() + ")");
  }
}

}  // namespace

std::vector<fs::path> earlierRunFiles(const fs::path& dir, const std::string& video) {
  static const std::regex frame(
      R"((frame_[0-9]{5,}\.(ply|png|vdb))|(surface_[0-9]{5,}\.(ply|obj)))");
  const std::string recorded = recordedVideo(dir);
  return filesIn(dir, [&](const std::string& name) {
    return std::regex_match(name, frame) || name == "run.json" || name == "colliders.json" ||
           name == video || name == "checkpoint.snowsim" || name == "checkpoint.snowsim.prev" ||
           (!recorded.empty() && name == recorded);
  });
}

void refuseEarlierRun(const std::string& dir, const std::string& video) {
  std::vector<fs::path> files = earlierRunFiles(dir, video);
  // Leftover temporaries are replaced as the run writes; only finished files are in the way.
  std::erase_if(files, isTemporary);
  if (files.empty()) return;
  throw InputError(dir + ": holds an earlier run (" + describe(files) +
                   "); choose another --out, or pass --overwrite to remove these files (and "
                   "only these) first");
}

void removeEarlierRun(const std::string& dir, const std::string& video) {
  const std::vector<fs::path> files = earlierRunFiles(dir, video);
  if (files.empty()) return;
  removeFiles(files);
  std::fprintf(stderr, "snowsim: --overwrite: removed %s of an earlier run from %s\n",
               describe(files).c_str(), dir.c_str());
}

std::vector<fs::path> renderedFiles(const fs::path& dir, bool png, const std::string& video) {
  static const std::regex frame(R"(frame_[0-9]{5,}\.png)");
  return filesIn(dir, [&](const std::string& name) {
    return (png && std::regex_match(name, frame)) || (!video.empty() && name == video);
  });
}

void refuseEarlierRender(const std::string& dir, bool png, const std::string& video) {
  std::vector<fs::path> files = renderedFiles(dir, png, video);
  // Leftover temporaries are replaced as the render writes; only finished files are in the way.
  std::erase_if(files, isTemporary);
  if (files.empty()) return;
  throw InputError(files.front().string() + ": would be overwritten (" + dir + " holds " +
                   describe(files) +
                   "); pass --overwrite to replace them, or render elsewhere with --out DIR");
}

void removeEarlierRender(const std::string& dir, bool png, const std::string& video) {
  const std::vector<fs::path> files = renderedFiles(dir, png, video);
  if (files.empty()) return;
  removeFiles(files);
  std::fprintf(stderr, "snowsim: --overwrite: removed %s from %s\n", describe(files).c_str(),
               dir.c_str());
}

namespace {

const char* const kLockFile = ".snowsim.lock";

// The process a lock file names (the run that wrote it), or 0 when it names none.
pid_t lockHolder(int fd) {
  char text[32] = {};
  const ssize_t n = pread(fd, text, sizeof text - 1, 0);
  if (n <= 0) return 0;
  char* end = nullptr;
  const long pid = std::strtol(text, &end, 10);
  return pid > 0 && end != text ? pid_t(pid) : 0;
}

bool isAlive(pid_t pid) {
  return kill(pid, 0) == 0 || errno == EPERM;
}

std::string heldMessage(const std::string& dir, pid_t holder) {
  const std::string who = holder > 0 ? "process " + std::to_string(holder) : "it";
  return dir + ": another snowsim run or resume is writing into it (" + who + " holds " + dir +
         "/" + kLockFile + "); wait for it to end, or stop it";
}

// A whole-file open-file-description lock: released when the descriptor closes, however the
// process ends, and carried to the server on NFS, where a flock on a directory is only local.
struct flock wholeFile(short type) {
  struct flock lock {};
  lock.l_type = type;
  lock.l_whence = SEEK_SET;
  return lock;
}

// Whether fd is still the file at path: a run that ended may have removed it since it was opened.
bool isTheFileAt(int fd, const std::string& path) {
  struct stat opened = {};
  struct stat named = {};
  return fstat(fd, &opened) == 0 && stat(path.c_str(), &named) == 0 &&
         opened.st_dev == named.st_dev && opened.st_ino == named.st_ino;
}

}  // namespace

RunDirectoryLock::RunDirectoryLock(const std::string& dir) : path_(dir + "/" + kLockFile) {
  int error = 0;
  bool locked = false;
  do {
    if (fd_ >= 0) close(fd_);
    fd_ = open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    struct flock lock = wholeFile(F_WRLCK);
    locked = fd_ >= 0 && fcntl(fd_, F_OFD_SETLK, &lock) == 0;
    error = locked ? 0 : errno;
  } while (locked && !isTheFileAt(fd_, path_));
  const pid_t earlier = fd_ >= 0 ? lockHolder(fd_) : 0;
  if (!locked) {
    if (fd_ >= 0 && (error == EAGAIN || error == EACCES)) {
      close(fd_);
      fd_ = -1;
      throw InputError(heldMessage(dir, earlier));
    }
    // Where the file system cannot lock, the process id is all there is to go by.
    if (earlier > 0 && earlier != getpid() && isAlive(earlier)) {
      if (fd_ >= 0) close(fd_);
      fd_ = -1;
      throw InputError(heldMessage(dir, earlier));
    }
    std::fprintf(stderr,
                 "snowsim: warning: %s: cannot lock it (%s): a second run or resume given "
                 "this directory is refused only by the process id the file holds\n",
                 path_.c_str(), std::strerror(error));
    if (fd_ < 0) return;
  } else if (earlier > 0 && earlier != getpid()) {
    // Unlocked, yet naming a process: left by a run that was killed before it could remove it.
    std::fprintf(stderr, "snowsim: note: %s: left by process %ld, which %s; taken over\n",
                 path_.c_str(), long(earlier),
                 isAlive(earlier) ? "no longer holds it" : "no longer runs");
  }
  // The process id, for the message that refuses another run and to tell a stale file.
  const std::string pid = std::to_string(getpid()) + "\n";
  if (ftruncate(fd_, 0) != 0 || pwrite(fd_, pid.data(), pid.size(), 0) != ssize_t(pid.size()))
    std::fprintf(stderr, "snowsim: warning: %s: cannot write the process id into it (%s)\n",
                 path_.c_str(), std::strerror(errno));
  // A second signal ends the process at once, past the destructor: the file goes then too.
  removed_at_once_.emplace(path_);
}

void RunDirectoryLock::refuseIfHeld(const std::string& dir) {
  const int fd = open((dir + "/" + kLockFile).c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return;  // no run has locked it yet
  struct flock lock = wholeFile(F_WRLCK);
  const bool held = fcntl(fd, F_OFD_GETLK, &lock) == 0 && lock.l_type != F_UNLCK;
  const pid_t holder = lockHolder(fd);
  close(fd);
  if (held) throw InputError(heldMessage(dir, holder));
}

RunDirectoryLock::~RunDirectoryLock() {
  if (fd_ < 0) return;
  removed_at_once_.reset();  // a signal from here on must not remove a later run's file
  // Removed while still locked: a run that opened this file meanwhile sees it gone and makes anew.
  unlink(path_.c_str());
  close(fd_);
}

}  // namespace snowsim
