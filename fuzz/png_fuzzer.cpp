// libFuzzer target: the PNG reader of `snowsim diff`. Any input must end in an RGBA image whose
// pixels all exist or an InputError.
#include <cstdint>
#include <cstdlib>
#include <string>

#include <stb/stb_image.h>

#include "render/image.h"
#include "sim/core/errors.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Decoding a large image takes milliseconds to seconds under ASan; the decoder's paths are
  // the same for small images, so the fuzzer skips the large ones (as OSS-Fuzz's image targets do).
  int width = 0, height = 0, channels = 0;
  if (size <= 1u << 20 &&
      stbi_info_from_memory(data, static_cast<int>(size), &width, &height, &channels) &&
      static_cast<long>(width) * height > 128 * 128)
    return 0;
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
