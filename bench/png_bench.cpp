// PNG writing speed: stb_image_write (RGBA, its default) against snowsim's writer (libpng, zlib
// level 1, Up filter, RGB) on a rendered 1280x720 frame of the snowball drop. Medians.
// Usage: png_bench [repetitions=9]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <vector>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>

#include "bench/median.h"
#include "render/image.h"
#include "render/renderer.h"
#include "sim/simulation.h"

using namespace snowsim;

int main(int argc, char** argv) {
  const int repetitions = argc > 1 ? std::atoi(argv[1]) : 9;
  auto simulation =
      makeSimulation(loadScene(std::string(SNOWSIM_SOURCE_DIR) + "/scenes/snowball_drop.json"));
  simulation->advanceTo(0.5);
  RenderSettings settings;
  settings.width = 1280;
  settings.height = 720;
  Renderer renderer(settings);
  const Image image = renderer.render(simulation->snapshot(0));
  const auto path = std::filesystem::temp_directory_path() / "snowsim_png_bench.png";

  int stb_bytes = 0;
  const double stb = medianMs(repetitions, [&] {
    unsigned char* png = stbi_write_png_to_mem(image.rgba.data(), 4 * image.width, image.width,
                                               image.height, 4, &stb_bytes);
    std::free(png);
  });
  const double ours = medianMs(repetitions, [&] { writePng(path.string(), image); });
  std::printf(
      "1280x720 frame: stb_image_write %.1f ms (%d bytes, encode only), "
      "snowsim writePng %.1f ms (%ju bytes, encode + atomic write), x%.1f\n",
      stb, stb_bytes, ours, static_cast<std::uintmax_t>(std::filesystem::file_size(path)),
      stb / ours);
  std::filesystem::remove(path);
}
