#include "app/png_sink.h"

#include <cstdio>

namespace snowsim {

void RenderOptions::addTo(CLI::App& command) {
  command.add_option("--width", width, "Image width in pixels (16 to 8192)")->capture_default_str();
  command.add_option("--height", height, "Image height in pixels (16 to 8192)")
      ->capture_default_str();
  command.add_option("--color-by", color_by, "Particle colour: white, density or speed")
      ->capture_default_str();
  command.add_flag("!--no-grid", grid, "Do not draw the simulation grid behind the particles");
}

RenderSettings RenderOptions::settings() const {
  RenderSettings s;
  s.width = width;
  s.height = height;
  s.color_by = parseColorBy(color_by);
  s.show_grid = grid;
  validate(s);
  return s;
}

PngSink::PngSink(std::string dir, const RenderSettings& settings)
    : dir_(std::move(dir)), renderer_(settings) {}

void PngSink::write(const Snapshot& snapshot) {
  char name[32];
  std::snprintf(name, sizeof name, "/frame_%05d.png", snapshot.frame);
  writePng(dir_ + name, renderer_.render(snapshot));
}

}  // namespace snowsim
