#include "sim/io/files.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "sim/core/errors.h"

namespace snowsim {

void writeFileAtomically(const std::string& path, const std::string& bytes) {
  const std::string temporary = path + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(path + ": cannot write (" + std::strerror(errno) + ")");
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) {
      std::filesystem::remove(temporary);
      throw InputError(path + ": writing failed (disk full?)");
    }
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
