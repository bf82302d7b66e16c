// libFuzzer target: the PNG reader of `snowsim diff`. Any input must end in an RGBA image whose
// pixels all exist or an InputError.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "render/image.h"
#include "sim/core/errors.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const snowsim::Image image =
        snowsim::decodePng(std::string(reinterpret_cast<const char*>(data), size), "fuzz.png");
    if (image.width < 1 || image.height < 1 ||
        image.rgba.size() != 4 * static_cast<std::size_t>(image.width) * image.height)
      std::abort();
  } catch (const snowsim::InputError&) {
  }
  return 0;
}
