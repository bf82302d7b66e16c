// libFuzzer target: the checkpoint reader of `snowsim resume`. Any input must decode to a
// checkpoint whose parts re-encode to the same bytes, or end in an InputError. Inputs whose first
// byte is odd get their CRC-32 set right first, so that the fuzzer reaches the layout past it.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#include "sim/core/errors.h"
#include "sim/io/checkpoint.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string bytes(reinterpret_cast<const char*>(data), size);
  if (size >= 4 && (data[0] & 1)) {
    const std::uint32_t crc = snowsim::crc32(std::string_view(bytes).substr(0, size - 4));
    std::memcpy(bytes.data() + size - 4, &crc, 4);
  }
  try {
    const snowsim::Checkpoint c = snowsim::decodeCheckpoint(bytes, "fuzz.checkpoint");
    if (snowsim::encodeCheckpoint(c) != bytes) std::abort();
    // The state's reader: arrays and values of whatever lengths the bytes claim.
    snowsim::StateReader in(c.solver_state, "fuzz.checkpoint");
    std::vector<double> array;
    in.value<long>();
    in.array(array);
    in.array(array, 3);
    in.text<std::uint32_t>();
    in.finish();
  } catch (const snowsim::InputError&) {
  }
  return 0;
}
