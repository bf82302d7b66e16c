// Rendering speed: milliseconds per 1920x1080 frame of 3D snow (perspective) for 10k, 250k and 1M
// spheres, plain (no shadows, no occlusion), with shadows, with occlusion, and with both; a 2D
// frame (orthographic, the report's look) of 1M; and per frame for each encoder (PNG, MP4).
// Medians. Usage: render_bench [repetitions=5]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <vector>

#include "bench/median.h"
#include "render/image.h"
#include "render/renderer.h"
#include "render/video_encoder.h"

using namespace snowsim;

namespace {

// n particles filling the lower half of a 1 m domain at the spacing such a count would have.
Snapshot packedSnow(int dimension, int n) {
  Snapshot s;
  s.grid.dimension = dimension;
  s.grid.cells = {64, 64, dimension == 3 ? 64 : 1};
  s.grid.cell_size = 1.0 / 64;
  const double region = dimension == 2 ? 0.5 : 0.5 * 1.0;  // area (2D) or volume (3D) filled
  s.grid.particle_spacing = std::pow(region / n, 1.0 / dimension);
  std::mt19937 random(1);
  std::uniform_real_distribution<float> u(0, 1);
  for (int i = 0; i < n; ++i) {
    s.position.push_back({u(random), 0.5f * u(random), dimension == 3 ? u(random) : 0.f});
    s.velocity.push_back({0, -u(random), 0});
    s.density.push_back(400 * u(random));
  }
  return s;
}

RenderSettings fullHd(bool shadows, bool occlusion) {
  RenderSettings settings;
  settings.width = 1920;
  settings.height = 1080;
  settings.shadows = shadows;
  settings.occlusion = occlusion;
  return settings;
}

}  // namespace

int main(int argc, char** argv) {
  const int repetitions = argc > 1 ? std::atoi(argv[1]) : 5;
  std::printf("1920x1080, ms/frame (median of %d)   plain  shadows  occlusion   both\n",
              repetitions);
  Renderer plain(fullHd(false, false)), shadows(fullHd(true, false)),
      occlusion(fullHd(false, true)), both(fullHd(true, true));
  for (int n : {10'000, 250'000, 1'000'000}) {
    const Snapshot s = packedSnow(3, n);
    std::printf("3D %8d spheres %-15s", n, n == 10'000 ? "(impostors)" : "(sprites)");
    for (Renderer* renderer : {&plain, &shadows, &occlusion, &both}) {
      renderer->render(s);  // the first frame compiles shaders and sizes the targets
      std::printf(" %8.1f", medianMs(repetitions, [&] { renderer->render(s); }));
    }
    std::printf("\n");
  }
  const Snapshot flat = packedSnow(2, 1'000'000);
  plain.render(flat);
  std::printf("2D  1000000 spheres (sprites)       %8.1f\n",
              medianMs(repetitions, [&] { plain.render(flat); }));

  const Image frame = plain.render(packedSnow(2, 10'000));
  const auto dir = std::filesystem::temp_directory_path();
  const double png =
      medianMs(repetitions, [&] { writePng((dir / "snowsim_bench.png").string(), frame); });
  std::printf("PNG (libpng level 1, written atomically): %.1f ms/frame\n", png);
  VideoEncoder video((dir / "snowsim_bench.mp4").string(), frame.width, frame.height, {});
  const double mp4 = medianMs(4 * repetitions, [&] { video.addFrame(frame); });
  video.finish();
  std::printf("MP4 (%s, crf 20, veryfast, yuv420p): %.1f ms/frame\n", video.codecName().c_str(),
              mp4);
  std::filesystem::remove(dir / "snowsim_bench.png");
  std::filesystem::remove(dir / "snowsim_bench.mp4");
}
