#include "render/image.h"

#include <png.h>

#include <csetjmp>

#include <fstream>
#include <limits>
#include <sstream>

// PNG only (the reader's one format), and no image larger than the largest frame (8192 pixels a
// side) with room to spare: a forged header cannot make stb allocate gigabytes.
#define STBI_ONLY_PNG
#define STBI_MAX_DIMENSIONS 16384
#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>

#include "sim/core/errors.h"
#include "sim/io/files.h"

namespace snowsim {

namespace {

void appendToString(png_structp png, png_bytep data, png_size_t size) {
  static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<const char*>(data), size);
}
void noFlush(png_structp) {}

// libpng at zlib level 1 with the Up filter: several times faster than stb_image_write and a
// smaller file (bench/png_bench prints both). Frames are opaque, so RGB.
bool encodePng(const Image& image, std::string& bytes) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    return false;
  }
  std::vector<png_byte> row(3 * static_cast<size_t>(image.width));
  if (setjmp(png_jmpbuf(png))) {  // libpng reports errors by longjmp
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, &bytes, appendToString, noFlush);
  png_set_IHDR(png, info, image.width, image.height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(png, 1);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_UP);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y) {
    const std::uint8_t* rgba = image.pixel(0, y);
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) row[3 * x + c] = rgba[4 * x + c];
    png_write_row(png, row.data());
  }
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

void writePng(const std::string& path, const Image& image) {
  std::string bytes;
  if (!encodePng(image, bytes)) throw InputError(path + ": cannot encode the PNG");
  writeFileAtomically(path, bytes);
}

Image readPng(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read the image (cannot open the file)");
  std::stringstream bytes;
  bytes << in.rdbuf();
  return decodePng(bytes.str(), path);
}

namespace {

// stb_image trusts a chunk's length and grows its buffer to it before reading: a 200-byte file
// whose IDAT claims 1.2 GB made it allocate 2 GB. And a first IDAT of no bytes makes it memcpy
// from a null buffer (undefined behaviour). Both found by fuzz/png_fuzzer. Every chunk must fit
// in the bytes that follow it; empty IDAT chunks (valid, and meaningless) are dropped from
// `stripped`, which stays empty when there are none.
void checkPngChunks(const std::string& bytes, const std::string& path, std::string& stripped) {
  static const std::string signature = "\x89PNG\r\n\x1a\n";
  if (bytes.compare(0, signature.size(), signature) != 0)
    throw InputError(path + ": cannot read the image (not a PNG file)");
  size_t kept_until = 0;  // bytes before this offset are copied to `stripped` when it is used
  for (size_t at = signature.size(); at < bytes.size();) {
    if (bytes.size() - at < 12)
      throw InputError(path + ": cannot read the image (truncated chunk at byte " +
                       std::to_string(at) + ")");
    size_t length = 0;
    for (int i = 0; i < 4; ++i) length = length << 8 | static_cast<unsigned char>(bytes[at + i]);
    const std::string type = bytes.substr(at + 4, 4);
    if (length > bytes.size() - at - 12)
      throw InputError(path + ": cannot read the image (chunk " + type + " at byte " +
                       std::to_string(at) + " claims " + std::to_string(length) +
                       " bytes; the file has " + std::to_string(bytes.size() - at - 12) + ")");
    if (type == "IDAT" && length == 0) {
      stripped.append(bytes, kept_until, at - kept_until);
      kept_until = at + 12;
    }
    if (type == "IEND") break;
    at += 12 + length;
  }
  if (kept_until > 0) stripped.append(bytes, kept_until, std::string::npos);
}

}  // namespace

Image decodePng(const std::string& bytes, const std::string& path) {
  if (bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max()))
    throw InputError(path + ": cannot read the image (larger than 2 GiB)");
  std::string stripped;
  checkPngChunks(bytes, path, stripped);
  const std::string& png = stripped.empty() ? bytes : stripped;
  int width = 0, height = 0, channels = 0;
  unsigned char* data =
      stbi_load_from_memory(reinterpret_cast<const stbi_uc*>(png.data()),
                            static_cast<int>(png.size()), &width, &height, &channels, 4);
  if (!data) throw InputError(path + ": cannot read the image (" + stbi_failure_reason() + ")");
  Image image{width, height,
              std::vector<std::uint8_t>(data, data + static_cast<size_t>(width) * height * 4)};
  stbi_image_free(data);
  return image;
}

}  // namespace snowsim
