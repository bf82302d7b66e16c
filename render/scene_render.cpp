#include "render/scene_render.h"

namespace snowsim {

RenderSettings renderSettingsFromScene(const SceneRender& render) {
  RenderSettings s;
  s.width = render.width.value_or(s.width);
  s.height = render.height.value_or(s.height);
  if (render.color_by) s.color_by = parseColorBy(*render.color_by, "render.color_by");
  s.sphere_radius = render.sphere_radius.value_or(s.sphere_radius);
  s.show_grid = render.grid.value_or(s.show_grid);
  s.density_cells = render.density_cells.value_or(s.density_cells);
  if (render.look) s.look = parseLook(*render.look, "render.look");
  if (render.background) s.background = *render.background;
  s.shadows = render.shadows.value_or(s.shadows);
  s.occlusion = render.occlusion.value_or(s.occlusion);
  if (const auto& camera = render.camera) {
    s.camera.custom = true;
    s.camera.eye = camera->eye;
    s.camera.target = camera->target;
    s.camera.up = camera->up;
    s.camera.fov_degrees = camera->fov.value_or(s.camera.fov_degrees);
  }
  return s;
}

}  // namespace snowsim
