#include "sim/io/files.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "sim/core/errors.h"

namespace snowsim {

namespace {

// The files being written, in fixed slots a signal handler can read without locks: a slot's path
// is complete while its state is kReady.
constexpr int kSlots = 32;
constexpr int kFree = 0, kFilling = 1, kReady = 2;
struct Slot {
  std::atomic<int> state{kFree};
  char path[4096];
};
Slot slots[kSlots];

}  // namespace

UnfinishedFile::UnfinishedFile(const std::string& path) : slot_(-1) {
  if (path.size() >= sizeof slots[0].path) return;
  for (int i = 0; i < kSlots; ++i) {
    int expected = kFree;
    if (!slots[i].state.compare_exchange_strong(expected, kFilling)) continue;
    std::memcpy(slots[i].path, path.c_str(), path.size() + 1);
    slots[i].state.store(kReady);
    slot_ = i;
    return;
  }
}

UnfinishedFile::~UnfinishedFile() {
  if (slot_ >= 0) slots[slot_].state.store(kFree);
}

void removeUnfinishedFiles() {
  for (Slot& slot : slots)
    if (slot.state.load() == kReady) ::unlink(slot.path);
}

void writeFileAtomically(const std::string& path, const std::string& bytes) {
  const std::string temporary = path + ".tmp";
  const UnfinishedFile unfinished(temporary);
  // POSIX calls rather than a stream: a failed write's errno (ENOSPC, EIO, ...) is the message.
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw InputError(path + ": cannot write (" + std::strerror(errno) + ")");
  const char* data = bytes.data();
  size_t left = bytes.size();
  int error = 0;
  while (left > 0 && error == 0) {
    const ssize_t written = ::write(fd, data, left);
    if (written < 0 && errno != EINTR) error = errno;
    if (written > 0) data += written, left -= static_cast<size_t>(written);
  }
  // Synced before the rename, so that a crash cannot leave an empty frame under the final name
  // that a later checkpoint counts as written (the checkpoint syncs the directory).
  if (error == 0 && ::fsync(fd) != 0) error = errno;
  if (::close(fd) != 0 && error == 0) error = errno;
  if (error != 0) {
    std::filesystem::remove(temporary);
    throw InputError(path + ": writing failed (" + std::strerror(error) + ")");
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    std::filesystem::remove(temporary);
    throw InputError(path + ": cannot write (" + ec.message() + ")");
  }
}

void syncFile(const std::string& written, const std::string& path) {
  const int fd = ::open(written.c_str(), O_RDONLY | O_CLOEXEC);
  int error = fd < 0 || ::fsync(fd) != 0 ? errno : 0;
  if (fd >= 0) ::close(fd);
  if (error != 0) throw InputError(path + ": writing failed (" + std::strerror(error) + ")");
}

void prepareOutputDirectory(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir)) {
    // The OS's reason, and where it stopped: "No such file or directory" for a directory in /proc
    // reads as if /proc were missing.
    std::error_code ignored;
    std::filesystem::path existing = std::filesystem::absolute(dir, ignored).parent_path();
    while (!existing.empty() && existing != existing.root_path() &&
           !std::filesystem::exists(existing, ignored))
      existing = existing.parent_path();
    throw InputError(dir + ": cannot create the output directory" +
                     (ec ? " (" + ec.message() + "; in " + existing.string() + ")"
                         : std::string(" (a file is in the way)")));
  }
  const std::string probe = dir + "/.snowsim-write-test";
  std::ofstream out(probe);
  if (!out) throw InputError(dir + ": the output directory is not writable");
  out.close();
  std::filesystem::remove(probe);
}

}  // namespace snowsim
