#include "sim/io/files.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "sim/core/errors.h"

namespace snowsim {

void writeFileAtomically(const std::string& path, const std::string& bytes) {
  const std::string temporary = path + ".tmp";
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

void prepareOutputDirectory(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw InputError(dir + ": cannot create the output directory" +
                     (ec ? " (" + ec.message() + ")" : std::string(" (a file is in the way)")));
  const std::string probe = dir + "/.snowsim-write-test";
  std::ofstream out(probe);
  if (!out) throw InputError(dir + ": the output directory is not writable");
  out.close();
  std::filesystem::remove(probe);
}

}  // namespace snowsim
