// libFuzzer target: the PLY reader of `snowsim render` and of points bodies. Any input must end in
// a snapshot the renderer can draw (its grid checked, its arrays as long as the header says), or
// particles whose arrays are as long as the header says, or an InputError.
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "sim/core/errors.h"
#include "sim/io/ply.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  for (const auto content : {snowsim::PlyContent::Frame, snowsim::PlyContent::Particles}) {
    std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
    try {
      const snowsim::Snapshot s = snowsim::readPly(in, "fuzz.ply", content);
      const std::size_t n = s.position.size();
      const bool frame = content == snowsim::PlyContent::Frame;
      if (s.velocity.size() != n || (frame && s.density.size() != n)) std::abort();
      for (const auto* column : {&s.density, &s.plastic_j, &s.mass, &s.radius})
        if (!column->empty() && column->size() != n) std::abort();
    } catch (const snowsim::InputError&) {
    }
  }
  return 0;
}
