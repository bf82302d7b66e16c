// An RGBA8 image, rows top to bottom, and writing it as PNG.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace snowsim {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;  // width * height * 4, first row at the top

  const std::uint8_t* pixel(int x, int y) const { return &rgba[4 * (y * width + x)]; }
};

// Writes atomically (temporary file, then rename); throws InputError naming the path.
void writePng(const std::string& path, const Image& image);

// Reads a PNG as RGBA; throws InputError naming the path.
Image readPng(const std::string& path);
// The same from the file's bytes, `path` naming it in messages.
Image decodePng(const std::string& bytes, const std::string& path);

}  // namespace snowsim
