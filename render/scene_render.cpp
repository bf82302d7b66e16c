#include "render/scene_render.h"

namespace snowsim {

namespace {

std::array<double, 3> point(JsonFields& f, const std::string& key,
                            std::optional<std::vector<double>> fallback) {
  const std::vector<double> v = f.numbers(key, fallback, {3});
  return {v[0], v[1], v[2]};
}

}  // namespace

RenderSettings renderSettingsFromScene(const Json& render, const std::string& file) {
  RenderSettings s;
  JsonFields f(render, "render", file);
  s.width = f.integer("width", s.width, 16, 8192);
  s.height = f.integer("height", s.height, 16, 8192);
  s.color_by =
      parseColorBy(f.choice("color_by", {"white", "density", "speed", "plastic"}, "white"), file);
  s.sphere_radius = f.number("sphere_radius", s.sphere_radius, 0, 10);
  s.show_grid = f.boolean("grid", s.show_grid);
  s.density_cells = f.boolean("density_cells", s.density_cells);
  if (const Json* camera = f.object("camera", false)) {
    JsonFields c(*camera, "render.camera", file);
    s.camera.custom = true;
    s.camera.eye = point(c, "eye", std::nullopt);
    s.camera.target = point(c, "target", std::nullopt);
    s.camera.up = point(c, "up", std::vector<double>{0, 1, 0});
    s.camera.fov_degrees = c.number("fov", s.camera.fov_degrees, 0, 180, true, true);
    if (s.camera.eye == s.camera.target) c.fail("target", "must differ from eye");
    c.finish();
  }
  f.finish();
  return s;
}

}  // namespace snowsim
