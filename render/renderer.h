// Draws a Snapshot off-screen: the particles as shaded spheres over the simulation grid, as in
// the report's figures. 2D scenes get an orthographic front view of the domain, 3D scenes a
// perspective view (by default from the front, above and to the right). 4x MSAA. Spheres a few
// pixels wide are drawn as point sprites instead of ray-cast impostors (docs/rendering.md).
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>

#include "render/camera.h"
#include "render/image.h"
#include "sim/core/snapshot.h"

namespace snowsim {

// Plastic: MPM's plastic volume ratio J_P (white at 1, red where compressed, blue where
// stretched); the snapshot must carry plastic_j.
enum class ColorBy { White, Density, Speed, Plastic };

// Parses "white", "density", "speed", "plastic"; throws InputError listing the allowed names.
ColorBy parseColorBy(const std::string& name, const std::string& where = "--color-by");

// The values the colour map spans: low is its first colour, high its last.
struct ColourRange {
  double low = 0, high = 0;
};

struct RenderSettings {
  int width = 1280;
  int height = 720;
  ColorBy color_by = ColorBy::White;
  bool show_grid = true;
  bool density_cells = false;  // 2D: shade cells by density, those at the critical density marked
  double sphere_radius = 0;    // metres; 0: half the particle spacing
  double lod_pixels = 5.0;     // spheres of a smaller projected radius become point sprites
  Camera camera;
  // Fixed for a run so that colours mean the same in every frame; none: render/colour.h's
  // default for the attribute.
  std::optional<ColourRange> color_range;
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
