// libFuzzer target: the PLY reader of `snowsim render`. Any input must end in a snapshot the
// renderer can draw (its grid checked, its arrays as long as the header says) or an InputError.
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "sim/core/errors.h"
#include "sim/io/ply.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    const snowsim::Snapshot s = snowsim::readPly(in, "fuzz.ply");
    const std::size_t n = s.position.size();
    if (s.velocity.size() != n || s.density.size() != n ||
        (!s.plastic_j.empty() && s.plastic_j.size() != n))
      std::abort();
  } catch (const snowsim::InputError&) {
  }
  return 0;
}
