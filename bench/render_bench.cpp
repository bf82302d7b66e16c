// Rendering speed: milliseconds per 1920x1080 frame of 3D snow (perspective) for 10k, 250k and 1M
// spheres, plain (no shadows, no occlusion), with shadows, with occlusion, and with both; the
// flagship smash's ball (268k particles at cell 5 mm) in the volume look, and in the surface look:
// building its surface, then drawing it; a 2D frame (orthographic, the report's look) of 1M; and
// per frame for each encoder (PNG, MP4).
// Medians of the wall time, and the process's CPU time a frame (all of llvmpipe's threads; on a
// shared machine it tells the work apart from the waiting). Usage:
//   render_bench [repetitions=5] [frames_directory]
// With a directory, the 3D frames with shadows and occlusion are also written there as PNGs
// (both_250000.png, ...), and the volume frame (volume_268000.png), to look at or to compare
// across builds with `snowsim diff`.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>

#include <sys/resource.h>
#include <random>
#include <string>
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

// The flagship smash's snowball (scenes/flagship/smash_wall.json): a ball of radius 0.1 m in
// 120x80x80 cells of 5 mm, about 268k particles a jittered 2.5 mm apart.
Snapshot flagshipBall() {
  Snapshot s;
  s.grid.dimension = 3;
  s.grid.cells = {120, 80, 80};
  s.grid.cell_size = 0.005;
  s.grid.particle_spacing = 0.0025;
  std::mt19937 random(1);
  std::uniform_real_distribution<float> jitter(-0.4f, 0.4f);
  for (int i = -40; i <= 40; ++i)
    for (int j = -40; j <= 40; ++j)
      for (int k = -40; k <= 40; ++k) {
        if (i * i + j * j + k * k > 40 * 40) continue;
        s.position.push_back({0.3f + 0.0025f * (i + jitter(random)),
                              0.2f + 0.0025f * (j + jitter(random)),
                              0.2f + 0.0025f * (k + jitter(random))});
        s.velocity.push_back({4, 0, 0});
        s.density.push_back(400);
      }
  return s;
}

double cpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + usage.ru_stime.tv_sec +
         1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

// "wall (cpu)" in ms a frame: the median wall time and the mean CPU time of `repetitions` frames.
std::string timeFrames(Renderer& renderer, const Snapshot& s, int repetitions) {
  renderer.render(s);  // the first frame compiles shaders and sizes the targets
  const double cpu0 = cpuSeconds();
  const double wall = medianMs(repetitions, [&] { renderer.render(s); });
  const double cpu = 1e3 * (cpuSeconds() - cpu0) / repetitions;
  char text[32];
  std::snprintf(text, sizeof text, "%6.0f (%5.0f)", wall, cpu);
  return text;
}

RenderSettings fullHd(bool shadows, bool occlusion, bool supersample = false) {
  RenderSettings settings;
  settings.width = 1920;
  settings.height = 1080;
  settings.shadows = shadows;
  settings.occlusion = occlusion;
  settings.supersample = supersample;
  return settings;
}

}  // namespace

int main(int argc, char** argv) {
  const int repetitions = argc > 1 ? std::atoi(argv[1]) : 5;
  const char* frames_directory = argc > 2 ? argv[2] : nullptr;
  std::printf("1920x1080, ms a frame: wall (cpu)    %-14s %-14s %-14s %-14s\n", "plain", "shadows",
              "occlusion", "both");
  Renderer plain(fullHd(false, false)), shadows(fullHd(true, false)),
      occlusion(fullHd(false, true)), both(fullHd(true, true));
  for (int n : {10'000, 250'000, 1'000'000}) {
    const Snapshot s = packedSnow(3, n);
    std::printf("3D %8d spheres %-12s", n, n == 10'000 ? "(impostors)" : "(sprites)");
    for (Renderer* renderer : {&plain, &shadows, &occlusion, &both})
      std::printf(" %-14s", timeFrames(*renderer, s, repetitions).c_str());
    std::printf("\n");
    if (frames_directory)
      writePng(std::string(frames_directory) + "/both_" + std::to_string(n) + ".png",
               both.render(s));
    if (n == 10'000) {  // the same impostors anti-aliased by supersampling rather than FXAA
      Renderer ss_plain(fullHd(false, false, true)), ss_shadows(fullHd(true, false, true)),
          ss_occlusion(fullHd(false, true, true)), ss_both(fullHd(true, true, true));
      std::printf("3D %8d spheres %-12s", n, "(supersample)");
      for (Renderer* renderer : {&ss_plain, &ss_shadows, &ss_occlusion, &ss_both})
        std::printf(" %-14s", timeFrames(*renderer, s, repetitions).c_str());
      std::printf("\n");
    }
  }
  RenderSettings volume_settings = fullHd(true, true);
  volume_settings.look = Look::Volume;
  Renderer volume(volume_settings);
  const Snapshot ball = flagshipBall();
  std::printf("3D %8d particles (--look volume) %s\n", ball.size(),
              timeFrames(volume, ball, repetitions).c_str());
  if (frames_directory)
    writePng(std::string(frames_directory) + "/volume_" + std::to_string(ball.size()) + ".png",
             volume.render(ball));
  std::printf("2D  1000000 spheres (sprites)    %s\n",
              timeFrames(plain, packedSnow(2, 1'000'000), repetitions).c_str());

  {
    // The surface is built once per frame, then drawn: the two parts apart, then a whole frame.
    Snapshot ball = flagshipBall();
    RenderSettings settings = fullHd(true, true);
    settings.look = Look::Surface;
    std::shared_ptr<const SnowSurface> surface;
    const double cpu0 = cpuSeconds();
    const double build = medianMs(repetitions, [&] {
      surface = std::make_shared<const SnowSurface>(buildSnowSurface(ball, settings.surface));
    });
    const double build_cpu = 1e3 * (cpuSeconds() - cpu0) / repetitions;
    ball.surface = surface;
    Renderer renderer(settings);
    std::printf("surface of %d particles: %zu triangles, %zu loose grains\n", ball.size(),
                surface->triangles.size(), surface->loose.size());
    std::printf("  build the surface     %6.0f (%5.0f)\n", build, build_cpu);
    std::printf("  draw it (both)        %s\n", timeFrames(renderer, ball, repetitions).c_str());
    ball.surface = nullptr;
    std::printf("  build and draw        %s\n", timeFrames(renderer, ball, repetitions).c_str());
    if (frames_directory)
      writePng(std::string(frames_directory) + "/surface_ball.png", renderer.render(ball));
  }

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
