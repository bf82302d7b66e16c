#include "render/camera.h"

#include <algorithm>

#include <glm/gtc/matrix_transform.hpp>

#include "render/renderer.h"

namespace snowsim {

View cameraFor(const Snapshot& s, const RenderSettings& settings, glm::vec3 extent) {
  const glm::vec3 centre = 0.5f * extent;
  const float aspect = float(settings.width) / float(settings.height);
  if (s.grid.dimension == 2) {
    const float half_height = 0.55f * std::max(extent.y, extent.x / aspect);
    return {glm::translate(glm::mat4(1), -glm::vec3(centre.x, centre.y, 1.f)),
            glm::ortho(-half_height * aspect, half_height * aspect, -half_height, half_height,
                       0.01f, 10.f)};
  }
  const float size = std::max({extent.x, extent.y, extent.z});
  const Camera& c = settings.camera;
  auto vec = [](const std::array<double, 3>& a) { return glm::vec3(a[0], a[1], a[2]); };
  const glm::vec3 eye =
      c.custom ? vec(c.eye) : centre + glm::vec3(0.6f * size, 0.5f * size, 2.2f * size);
  const glm::vec3 target = c.custom ? vec(c.target) : centre;
  const float distance = glm::length(eye - target) + size;
  return {
      glm::lookAt(eye, target, c.custom ? vec(c.up) : glm::vec3(0, 1, 0)),
      glm::perspective(glm::radians(float(c.fov_degrees)), aspect, 0.01f * size, 4.f * distance)};
}

}  // namespace snowsim
