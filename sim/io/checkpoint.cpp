#include "sim/io/checkpoint.h"

#include "sim/io/files.h"

#include <fcntl.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace snowsim {

// The arrays are written as the machine holds them; the format says little-endian.
static_assert(std::endian::native == std::endian::little,
              "checkpoints assume a little-endian host");

namespace {

constexpr std::string_view kMagic = "SNOWCKPT";

// Appends the bytes of a value; a length-prefixed text.
template <class T>
void put(std::string& out, T v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}
template <class Length>
void putText(std::string& out, std::string_view text) {
  put(out, static_cast<Length>(text.size()));
  out.append(text);
}

// Throws InputError naming the file, after removing `temporary` when given.
[[noreturn]] void failWrite(const std::string& path, int error, const std::string& temporary) {
  if (!temporary.empty()) ::unlink(temporary.c_str());
  throw InputError(path + ": writing the checkpoint failed (" + std::strerror(error) + ")");
}

void syncDirectory(const std::string& path) {
  const std::string dir = std::filesystem::path(path).parent_path().string();
  const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;  // the rename is done; a directory that cannot be opened cannot be synced
  ::fsync(fd);
  ::close(fd);
}

}  // namespace

std::uint32_t crc32(std::string_view bytes, std::uint32_t crc) {
  // zlib takes at most a uInt (32 bits) of bytes at a time.
  constexpr std::size_t most = std::size_t(1) << 30;
  for (std::size_t at = 0; at < bytes.size(); at += most) {
    const std::size_t size = std::min(most, bytes.size() - at);
    crc = static_cast<std::uint32_t>(
        ::crc32(crc, reinterpret_cast<const Bytef*>(bytes.data() + at), static_cast<uInt>(size)));
  }
  return crc;
}

std::uint64_t fnv1a(std::string_view bytes) {
  std::uint64_t hash = 0xcbf29ce484222325ull;
  for (const char b : bytes) hash = (hash ^ static_cast<unsigned char>(b)) * 0x100000001b3ull;
  return hash;
}

const char* StateReader::take(std::size_t n) {
  if (n > bytes_.size() - at_) fail("it ends in the middle of the state");
  const char* p = bytes_.data() + at_;
  at_ += n;
  return p;
}

void StateReader::finish() const {
  if (at_ != bytes_.size())
    fail(std::to_string(bytes_.size() - at_) + " bytes are left over after the state");
}

void StateReader::fail(const std::string& problem) const {
  throw InputError(file_ + ": not a checkpoint of this run's state (" + problem + ")");
}

namespace {

// Everything before the solver state's bytes, their length last.
std::string checkpointHead(const CheckpointHeader& header, std::string_view run_state,
                           std::uint64_t solver_state_bytes) {
  std::string out(kMagic);
  put(out, kCheckpointFormat);
  put(out, header.dimension);
  put(out, header.scalar_bytes);
  put(out, header.scene_hash);
  putText<std::uint32_t>(out, header.snowsim_version);
  putText<std::uint32_t>(out, run_state);
  put(out, solver_state_bytes);
  return out;
}

// A file written through a buffer, its CRC-32 kept as it goes; the first error is kept and
// written bytes are dropped after it.
class ChecksummedFile {
 public:
  explicit ChecksummedFile(int fd) : fd_(fd) { buffer_.reserve(kBuffer); }
  void write(const char* bytes, std::size_t size) {
    crc_ = crc32(std::string_view(bytes, size), crc_);
    if (buffer_.size() + size > kBuffer) flush();
    if (size >= kBuffer)
      writeOut(bytes, size);
    else
      buffer_.append(bytes, size);
  }
  void flush() {
    writeOut(buffer_.data(), buffer_.size());
    buffer_.clear();
  }
  std::uint32_t crc() const { return crc_; }
  int error() const { return error_; }

 private:
  static constexpr std::size_t kBuffer = std::size_t(1) << 20;
  void writeOut(const char* data, std::size_t left) {
    while (left > 0 && error_ == 0) {
      const ssize_t written = ::write(fd_, data, left);
      if (written < 0 && errno != EINTR) error_ = errno;
      if (written > 0) data += written, left -= static_cast<std::size_t>(written);
    }
  }

  int fd_;
  std::string buffer_;
  std::uint32_t crc_ = 0;
  int error_ = 0;
};

}  // namespace

std::string encodeCheckpoint(const Checkpoint& c) {
  std::string out = checkpointHead(c.header, c.run_state, c.solver_state.size());
  out += c.solver_state;
  put(out, crc32(out));
  return out;
}

namespace {

// Checks the checkpoint in bytes and reads all of it into c but the solver state, whose place in
// bytes it returns: readCheckpoint takes it from the file's bytes without a copy.
std::string_view decodeAllButState(std::string_view bytes, const std::string& file, Checkpoint& c) {
  const auto bad = [&](const std::string& problem) {
    return InputError(file + ": " + problem + "; resume needs an intact checkpoint");
  };
  const auto damaged = [&](const std::string& problem) {
    return DamagedCheckpoint(file + ": " + problem + "; resume needs an intact checkpoint");
  };
  if (bytes.size() < kMagic.size() || bytes.substr(0, kMagic.size()) != kMagic)
    throw bad("not a snowsim checkpoint (no SNOWCKPT at its start)");
  StateReader in(bytes.substr(kMagic.size()), file);
  try {
    const auto format = in.value<std::uint32_t>();
    if (format != kCheckpointFormat)
      throw bad("a checkpoint of format " + std::to_string(format) +
                "; this snowsim reads format " + std::to_string(kCheckpointFormat));
  } catch (const InputError&) {
    if (bytes.size() < kMagic.size() + 4) throw damaged("truncated (it ends after its magic)");
    throw;
  }
  if (bytes.size() < kMagic.size() + 8) throw damaged("truncated (it ends in its header)");
  std::uint32_t stored_crc;
  std::memcpy(&stored_crc, bytes.data() + bytes.size() - 4, 4);
  if (crc32(bytes.substr(0, bytes.size() - 4)) != stored_crc)
    throw damaged("truncated or corrupted (its CRC-32 does not match its contents)");
  std::string_view solver_state;
  try {
    in.value(c.header.dimension);
    in.value(c.header.scalar_bytes);
    in.value(c.header.scene_hash);
    c.header.snowsim_version = in.text<std::uint32_t>();
    c.run_state = in.text<std::uint32_t>();
    solver_state = in.textView<std::uint64_t>();
    in.value<std::uint32_t>();  // the CRC, checked above
    in.finish();
  } catch (const InputError& e) {
    throw bad(std::string("its layout is broken: ") + e.what());
  }
  if (c.header.dimension != 2 && c.header.dimension != 3)
    throw bad("dimension " + std::to_string(c.header.dimension) + "; allowed: 2, 3");
  if (c.header.scalar_bytes != 4 && c.header.scalar_bytes != 8)
    throw bad(std::to_string(c.header.scalar_bytes) + "-byte scalars; allowed: 4, 8");
  return solver_state;
}

}  // namespace

Checkpoint decodeCheckpoint(std::string_view bytes, const std::string& file) {
  Checkpoint c;
  c.solver_state = std::string(decodeAllButState(bytes, file, c));
  return c;
}

void writeCheckpoint(const std::string& path, const CheckpointHeader& header,
                     const std::string& run_state, const std::function<void(StateWriter&)>& save) {
  std::uint64_t solver_state_bytes = 0;
  StateWriter count([&](const char*, std::size_t size) { solver_state_bytes += size; });
  save(count);
  const std::string head = checkpointHead(header, run_state, solver_state_bytes);
  const std::string temporary = path + ".tmp";
  const UnfinishedFile unfinished(temporary);
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) failWrite(temporary, errno, "");
  int error = 0;
  try {  // whatever fails from here on, the earlier checkpoint stays as it is
    ChecksummedFile file(fd);
    file.write(head.data(), head.size());
    std::uint64_t written = 0;
    StateWriter out([&](const char* bytes, std::size_t size) {
      file.write(bytes, size);
      written += size;
    });
    save(out);
    if (written != solver_state_bytes)
      throw std::logic_error(
          "the solver's state changed its length between its count and its write");
    const std::uint32_t crc = file.crc();
    file.write(reinterpret_cast<const char*>(&crc), sizeof crc);
    file.flush();
    error = file.error();
  } catch (...) {
    ::close(fd);
    ::unlink(temporary.c_str());
    throw;
  }
  if (error == 0 && ::fsync(fd) != 0) error = errno;
  if (::close(fd) != 0 && error == 0) error = errno;
  if (error != 0) failWrite(temporary, error, temporary);
  // The earlier checkpoint stays as .prev: path is complete at every moment of the rename.
  const std::string previous = path + ".prev";
  ::unlink(previous.c_str());
  if (::link(path.c_str(), previous.c_str()) != 0 && errno != ENOENT)
    failWrite(previous, errno, temporary);
  if (::rename(temporary.c_str(), path.c_str()) != 0) failWrite(path, errno, temporary);
  syncDirectory(path);
}

Checkpoint readCheckpoint(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read the checkpoint (" + std::strerror(errno) + ")");
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw InputError(path + ": cannot read the checkpoint (not a file)");
  const std::uintmax_t length = std::filesystem::file_size(path, error);
  if (error) throw InputError(path + ": cannot read the checkpoint (" + error.message() + ")");
  // Read once into one buffer, which then holds the solver state alone: a checkpoint of millions
  // of particles is not copied.
  std::string bytes(length, '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!in) throw InputError(path + ": cannot read the checkpoint");
  Checkpoint c;
  const std::string_view state = decodeAllButState(bytes, path, c);
  const std::size_t at = static_cast<std::size_t>(state.data() - bytes.data());
  const std::size_t size = state.size();
  bytes.resize(at + size);
  bytes.erase(0, at);
  c.solver_state = std::move(bytes);
  return c;
}

}  // namespace snowsim
