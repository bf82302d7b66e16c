// Checkpoints: the whole state of a run in one file, from which `snowsim resume` continues it to
// the same frames, byte for byte. The file is
//   magic "SNOWCKPT", format version (u32), dimension (u32), bytes per scalar of the solver's
//   state (u32), hash of the resolved scene (u64), snowsim version (u32 length + text),
//   the run's own state (u32 length + JSON text), the solver's state (u64 length + bytes),
//   CRC-32 (IEEE, u32) of every byte before it,
// all little-endian, arrays as their raw elements. It is written to NAME.tmp, synced and renamed
// over NAME; the earlier checkpoint stays as NAME.prev until the next one is complete.
#pragma once

#include <cstdint>
#include <cstring>
#include <functional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "sim/core/errors.h"

namespace snowsim {

// The layout of the file; a checkpoint of another format version is refused.
inline constexpr std::uint32_t kCheckpointFormat = 6;

// CRC-32 (the IEEE polynomial, as zlib and PNG compute it) of bytes.
std::uint32_t crc32(std::string_view bytes, std::uint32_t crc = 0);
// FNV-1a, 64 bits: the scene's hash.
std::uint64_t fnv1a(std::string_view bytes);

// Values held as plain bytes: scalars, structs of them, fixed-size Eigen vectors and matrices
// (whose copy is user-declared, so not "trivially copyable", but a copy of their bytes).
template <class T>
inline constexpr bool kPlainBytes =
    std::is_trivially_destructible_v<T>&& std::is_standard_layout_v<T>;

// Where a StateWriter passes its bytes on as they come (a file, a count).
using ByteSink = std::function<void(const char* bytes, std::size_t size)>;

// A solver's state as bytes: scalars and arrays of plain values, in the order a StateReader reads
// them back. It keeps them (bytes()), or passes them on to a sink without holding them: a
// checkpoint of millions of particles then costs no copy of their arrays.
class StateWriter {
 public:
  StateWriter() = default;
  explicit StateWriter(ByteSink sink) : sink_(std::move(sink)) {}

  template <class T>
  void value(const T& v) {
    static_assert(kPlainBytes<T>);
    put(reinterpret_cast<const char*>(&v), sizeof v);
  }
  template <class T, class A>
  void array(const std::vector<T, A>& a) {
    value(static_cast<std::uint64_t>(a.size()));
    if (!a.empty()) put(reinterpret_cast<const char*>(a.data()), a.size() * sizeof(T));
  }
  // Bytes another StateWriter kept, as they are.
  void append(std::string_view kept) { put(kept.data(), kept.size()); }
  // What it kept (nothing with a sink).
  const std::string& bytes() const { return bytes_; }

 private:
  void put(const char* bytes, std::size_t size) {
    if (sink_)
      sink_(bytes, size);
    else
      bytes_.append(bytes, size);
  }

  ByteSink sink_;
  std::string bytes_;
};

// Reads what a StateWriter wrote; a read past the end, an array of an unexpected length or bytes
// left over throw InputError naming the file.
class StateReader {
 public:
  StateReader(std::string_view bytes, std::string file) : bytes_(bytes), file_(std::move(file)) {}

  template <class T>
  T value() {
    static_assert(kPlainBytes<T>);
    T v;
    std::memcpy(static_cast<void*>(&v), take(sizeof v), sizeof v);
    return v;
  }
  template <class T>
  void value(T& v) {
    v = value<T>();
  }
  // expected: the length the array must have; -1: any that the bytes hold.
  template <class T, class A>
  void array(std::vector<T, A>& a, long expected = -1) {
    const auto n = value<std::uint64_t>();
    if ((expected >= 0 && n != static_cast<std::uint64_t>(expected)) ||
        n > (bytes_.size() - at_) / sizeof(T))
      fail("an array of " + std::to_string(n) + " elements does not fit the state");
    a.resize(n);
    const char* bytes = take(n * sizeof(T));
    if (n > 0) std::memcpy(static_cast<void*>(a.data()), bytes, n * sizeof(T));  // empty: null
  }
  // A text of `Length` bytes' length; textView: a view of it in the bytes read.
  template <class Length>
  std::string text() {
    return std::string(textView<Length>());
  }
  template <class Length>
  std::string_view textView() {
    const auto n = value<Length>();
    if (n > bytes_.size() - at_) fail("a text of " + std::to_string(n) + " bytes does not fit");
    return std::string_view(take(n), n);
  }
  // Throws unless every byte was read.
  void finish() const;
  const std::string& file() const { return file_; }
  [[noreturn]] void fail(const std::string& problem) const;

 private:
  const char* take(std::size_t n);

  std::string_view bytes_;
  std::size_t at_ = 0;
  std::string file_;
};

// Every per-particle array of a particle container (its forEachArray), then back into a container
// built from the same scene: each array as long as it is there, every id one of its particles.
template <class P>
void saveParticleArrays(StateWriter& out, const P& particles) {
  // forEachArray hands out the arrays to change them; here they are only read.
  const_cast<P&>(particles).forEachArray([&](const auto& a) { out.array(a); });
}
template <class P>
void loadParticleArrays(StateReader& in, P& particles) {
  particles.forEachArray([&](auto& a) { in.array(a, static_cast<long>(a.size())); });
  for (const int id : particles.id)
    if (id < 0 || id >= particles.size()) in.fail("particle id " + std::to_string(id));
}

// What a checkpoint holds besides the solver's state.
struct CheckpointHeader {
  std::uint32_t dimension = 2;
  std::uint32_t scalar_bytes = 8;  // of the solver's state: 8 double, 4 float
  std::uint64_t scene_hash = 0;
  std::string snowsim_version;
};

struct Checkpoint {
  CheckpointHeader header;
  std::string run_state;     // the run layer's JSON
  std::string solver_state;  // StateWriter bytes
};

// The file's bytes.
std::string encodeCheckpoint(const Checkpoint& checkpoint);
// The checkpoint in `bytes`, read from `file` (named in messages). Throws InputError for
// anything but a complete, intact checkpoint of this format version; the snowsim version, the
// scene and the dimension are the caller's to check.
Checkpoint decodeCheckpoint(std::string_view bytes, const std::string& file);
// What decodeCheckpoint throws for a file cut short or changed (its CRC-32 does not match): the
// checkpoint before it may still serve.
struct DamagedCheckpoint : InputError {
  using InputError::InputError;
};

// Writes the checkpoint of `header` and `run_state` whose solver state save(out) writes, without
// holding that state's bytes: save runs twice, first to count them (their length comes before
// them), then into the file. It goes to path.tmp, which is synced; the earlier checkpoint at path
// is linked as path.prev, path.tmp renamed over path and the directory synced: a crash at any
// moment leaves a complete checkpoint at path (once there was one). Throws InputError naming the
// file when a write fails; path.tmp is then removed and the earlier checkpoint left as it was.
void writeCheckpoint(const std::string& path, const CheckpointHeader& header,
                     const std::string& run_state, const std::function<void(StateWriter&)>& save);
// Reads and decodes path; InputError naming it when it is missing, unreadable or damaged.
Checkpoint readCheckpoint(const std::string& path);

}  // namespace snowsim
