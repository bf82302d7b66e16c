#include "render/image.h"

#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include "sim/errors.h"
#include "sim/files.h"

namespace snowsim {

void writePng(const std::string& path, const Image& image) {
  std::string bytes;
  auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), size);
  };
  if (!stbi_write_png_to_func(append, &bytes, image.width, image.height, 4, image.rgba.data(),
                              image.width * 4))
    throw InputError(path + ": cannot encode the PNG");
  writeFileAtomically(path, bytes);
}

Image readPng(const std::string& path) {
  int width = 0, height = 0, channels = 0;
  unsigned char* data = stbi_load(path.c_str(), &width, &height, &channels, 4);
  if (!data) throw InputError(path + ": cannot read the image (" + stbi_failure_reason() + ")");
  Image image{width, height, std::vector<std::uint8_t>(data, data + width * height * 4)};
  stbi_image_free(data);
  return image;
}

}  // namespace snowsim
