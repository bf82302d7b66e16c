// Draws a Snapshot off-screen: the particles as shaded spheres, the colliders and the simulation
// grid. 2D scenes get the report's look: an orthographic front view of the domain, drawn forward
// with 4x MSAA. 3D scenes get a perspective view (by default from the front, above and to the
// right), drawn deferred: a G-buffer of the spheres, ground and colliders, then one lighting pass
// with a key light and its shadow map, a sky fill and screen-space ambient occlusion. Spheres a
// few pixels wide are point sprites instead of ray-cast impostors; particles buried in packed snow
// are left out of the passes that cannot see them (docs/rendering.md). The surface look draws the
// snow's surface mesh (sim/geometry/snow_surface.h) in place of the spheres, and its loose grains
// as spheres; the volume look marches the snow's density over the lit ground and colliders.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>

#include "render/camera.h"
#include "render/image.h"
#include "sim/core/snapshot.h"
#include "sim/geometry/snow_surface.h"

namespace snowsim {

// Plastic: MPM's plastic volume ratio J_P (light grey at 1, red where compressed, blue where
// stretched, render/colour.h); the snapshot must carry plastic_j.
enum class ColorBy { White, Density, Speed, Plastic };

// Parses "white", "density", "speed", "plastic"; throws InputError listing the allowed names.
ColorBy parseColorBy(const std::string& name, const std::string& where = "--color-by");

// Studio: a dark background (the report's). Figure: white, like a paper's figure. Surface: the
// studio's background and light, the 3D snow drawn as its surface (2D frames: as studio).
// Volume (3D): the studio's, with the snow as a ray-marched density volume instead of spheres.
enum class Look { Studio, Figure, Surface, Volume };

// Parses "studio", "figure", "surface", "volume"; throws InputError listing the allowed names.
Look parseLook(const std::string& name, const std::string& where = "--look");

// The name parseLook reads.
std::string lookName(Look look);

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
  Look look = Look::Studio;
  std::optional<std::array<double, 3>> background;  // RGB in [0, 1]; none: the look's
  bool shadows = true;                              // 3D: the key light casts shadows (shadow map)
  bool occlusion = true;                            // 3D: screen-space ambient occlusion
  bool supersample = false;  // 3D impostor frames drawn at 2x2 the size (else FXAA; renderer.cpp)
  // Fixed for a run so that colours mean the same in every frame; none: render/colour.h's
  // default for the attribute.
  std::optional<ColourRange> color_range;
  SurfaceSettings surface;  // the surface look's, for frames that carry no surface
};

// "studio", "figure" or "surface": the name parseLook reads.
std::string lookName(Look look);

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
