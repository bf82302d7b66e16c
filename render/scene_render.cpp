#include "render/scene_render.h"

#include "render/colour.h"

#include <algorithm>
#include <cmath>

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
    s.camera.custom = !camera->preset;
    if (camera->preset)
      s.camera.preset = parseCameraPreset(*camera->preset, "render.camera.preset");
    s.camera.eye = camera->eye;
    s.camera.target = camera->target;
    s.camera.up = camera->up;
    s.camera.fov_degrees = camera->fov.value_or(s.camera.fov_degrees);
  }
  if (render.color_range)
    s.color_range = ColourRange{(*render.color_range)[0], (*render.color_range)[1]};
  return s;
}

std::optional<ColourRange> physicalColourRange(const Scene& scene, ColorBy by) {
  if (by == ColorBy::Density && scene.solver == SolverType::Mpm) {
    double densest = 0;
    for (const Body& body : scene.bodies) densest = std::max(densest, body.density);
    return ColourRange{0, 2 * densest};
  }
  if (by == ColorBy::Plastic && scene.solver == SolverType::Mpm) return kPlasticRange;
  if (by == ColorBy::Speed) {
    double fastest = 0;
    for (const Body& body : scene.bodies)
      fastest = std::max(fastest, std::hypot(body.velocity[0], body.velocity[1], body.velocity[2]));
    const double g = std::hypot(scene.gravity[0], scene.gravity[1], scene.gravity[2]);
    const double high = fastest + std::sqrt(2 * g * scene.extent()[1]);
    if (high > 0) return ColourRange{0, high};
  }
  return std::nullopt;
}

namespace {

// The lowest and highest corners of a solid collider's bounding box.
std::array<Vec3, 2> colliderBounds(const ColliderParams& c) {
  if (c.shape == ColliderShape::Mesh)  // as posed at time 0
    return placed(*c.mesh.triangles, {c.position, c.rotation, c.mesh.scale}).bounds();
  std::array<Vec3, 2> box{};
  for (int a = 0; a < 3; ++a) {
    const double half = c.shape == ColliderShape::Box ? c.size[a] / 2 : c.radius;
    box[0][a] = c.position[a] - half;
    box[1][a] = c.position[a] + half;
  }
  return box;
}

}  // namespace

void fitToScene(RenderSettings& settings, const Scene& scene, const Snapshot& first) {
  if (!settings.color_range) settings.color_range = physicalColourRange(scene, settings.color_by);
  if (scene.dimension != 3 || settings.camera.custom) return;
  Bounds box = particleBounds(first);
  const Vec3 extent = scene.extent();
  for (const ColliderParams& c : scene.colliders) {
    if (c.shape == ColliderShape::HalfSpace) continue;
    Bounds solid;
    for (Vec3 corner : colliderBounds(c)) {
      for (int a = 0; a < 3; ++a) corner[a] = std::clamp(corner[a], 0.0, extent[a]);
      solid.add(corner);
    }
    box.include(solid);
  }
  if (box.empty()) return;
  // Where the snow goes: along its initial velocity for the run's duration (until a wall stops
  // it), and down to the ground.
  for (const Body& body : scene.bodies)
    for (int a = 0; a < 3; ++a) {
      const double travel = body.velocity[a] * scene.duration;
      box.lo[a] = std::max(0.0, std::min(box.lo[a], box.lo[a] + travel));
      box.hi[a] = std::min(extent[a], std::max(box.hi[a], box.hi[a] + travel));
    }
  if (scene.gravity[1] < 0) box.lo[1] = 0;
  settings.camera.frame = box;
}

}  // namespace snowsim
