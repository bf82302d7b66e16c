// Draws a Snapshot off-screen: the particles as shaded spheres over the simulation grid, as in
// the report's figures. 2D scenes get an orthographic front view of the domain, 3D scenes a
// perspective view from the front. 4x MSAA.
#pragma once

#include <memory>
#include <string>

#include "render/image.h"
#include "sim/snapshot.h"

namespace snowsim {

enum class ColorBy { White, Density, Speed };

// Parses "white", "density", "speed"; throws InputError listing the allowed names.
ColorBy parseColorBy(const std::string& name);

struct RenderSettings {
  int width = 1280;
  int height = 720;
  ColorBy color_by = ColorBy::White;
  bool show_grid = true;
  double sphere_radius = 0;  // metres; 0: half the particle spacing
};

// Checks sizes and values; throws InputError naming the setting and what is allowed.
void validate(const RenderSettings& settings);

class Renderer {
 public:
  explicit Renderer(const RenderSettings& settings);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  Image render(const Snapshot& snapshot);

 private:
  struct Gl;
  RenderSettings settings_;
  std::unique_ptr<Gl> gl_;
};

}  // namespace snowsim
