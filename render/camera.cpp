#include "render/camera.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

#include "render/renderer.h"
#include "sim/core/errors.h"

namespace snowsim {

namespace {

// From the target towards the eye, and the image's up direction.
struct Direction {
  glm::dvec3 back, up;
};

Direction directionOf(CameraPreset preset) {
  switch (preset) {
    case CameraPreset::Front:
      return {glm::normalize(glm::dvec3(0, 0.25, 1)), {0, 1, 0}};
    case CameraPreset::Side:
      return {glm::normalize(glm::dvec3(1, 0.25, 0)), {0, 1, 0}};
    case CameraPreset::Top:
      return {{0, 1, 0}, {0, 0, -1}};
    case CameraPreset::ThreeQuarter:
      break;
  }
  return {glm::normalize(glm::dvec3(0.6, 0.5, 1)), {0, 1, 0}};
}

glm::dvec3 vec(const std::array<double, 3>& a) {
  return {a[0], a[1], a[2]};
}
std::array<double, 3> array(glm::dvec3 v) {
  return {v.x, v.y, v.z};
}

}  // namespace

CameraPreset parseCameraPreset(const std::string& name, const std::string& where) {
  for (CameraPreset p :
       {CameraPreset::ThreeQuarter, CameraPreset::Front, CameraPreset::Side, CameraPreset::Top})
    if (name == presetName(p)) return p;
  throw InputError(where + ": \"" + name +
                   "\" is not allowed; allowed: front, side, three_quarter, top");
}

std::string presetName(CameraPreset preset) {
  switch (preset) {
    case CameraPreset::Front:
      return "front";
    case CameraPreset::Side:
      return "side";
    case CameraPreset::Top:
      return "top";
    case CameraPreset::ThreeQuarter:
      break;
  }
  return "three_quarter";
}

void Bounds::add(const std::array<double, 3>& p) {
  if (empty()) lo = hi = p;
  for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
}

void Bounds::include(const Bounds& other) {
  if (other.empty()) return;
  add(other.lo);
  add(other.hi);
}

Bounds particleBounds(const Snapshot& s) {
  Bounds box;
  for (const auto& p : s.position) box.add(std::array<double, 3>{p[0], p[1], p[2]});
  // The spheres (radius half the spacing by default) reach beyond their centres.
  const double pad = 0.5 * s.grid.particle_spacing;
  for (int a = 0; a < 3 && !box.empty(); ++a) box.lo[a] -= pad, box.hi[a] += pad;
  return box;
}

Camera framingCamera(const Bounds& box, CameraPreset preset, double fov_degrees, double aspect) {
  const Direction d = directionOf(preset);
  const glm::dvec3 centre = 0.5 * (vec(box.lo) + vec(box.hi));
  const glm::dvec3 right = glm::normalize(glm::cross(d.up, d.back));
  const glm::dvec3 up = glm::cross(d.back, right);
  const double margin = 1.1;
  const double tan_v = std::tan(glm::radians(fov_degrees) / 2) / margin, tan_h = tan_v * aspect;
  // A corner at offset c from the centre lies in the image when the eye, at distance t along
  // `back`, sees it within the half-angles: |c.right| <= tan_h (t - c.back), likewise up.
  double distance = 0;
  for (int corner = 0; corner < 8; ++corner) {
    const glm::dvec3 c =
        glm::dvec3(corner & 1 ? box.hi[0] : box.lo[0], corner & 2 ? box.hi[1] : box.lo[1],
                   corner & 4 ? box.hi[2] : box.lo[2]) -
        centre;
    const double along = glm::dot(c, d.back);
    distance = std::max({distance, along + std::abs(glm::dot(c, right)) / tan_h,
                         along + std::abs(glm::dot(c, up)) / tan_v});
  }
  // A box of one point (a single particle) still needs the eye away from it.
  distance = std::max(distance, 1e-3);
  Camera camera;
  camera.custom = true;
  camera.eye = array(centre + distance * d.back);
  camera.target = array(centre);
  camera.up = array(d.up);
  camera.fov_degrees = fov_degrees;
  camera.preset = preset;
  camera.frame = box;
  return camera;
}

Camera placedCamera(const RenderSettings& settings, const std::array<double, 3>& extent) {
  const Camera& c = settings.camera;
  if (c.custom) return c;
  Bounds domain;
  domain.add(std::array<double, 3>{0, 0, 0});
  domain.add(extent);
  return framingCamera(c.frame.empty() ? domain : c.frame, c.preset, c.fov_degrees,
                       double(settings.width) / settings.height);
}

View cameraFor(const Snapshot& s, const RenderSettings& settings, glm::vec3 extent) {
  const glm::vec3 centre = 0.5f * extent;
  const float aspect = float(settings.width) / float(settings.height);
  if (s.grid.dimension == 2) {
    const float half_height = 0.55f * std::max(extent.y, extent.x / aspect);
    return {glm::translate(glm::mat4(1), -glm::vec3(centre.x, centre.y, 1.f)),
            glm::ortho(-half_height * aspect, half_height * aspect, -half_height, half_height,
                       0.01f, 10.f)};
  }
  const Camera c = placedCamera(settings, {extent.x, extent.y, extent.z});
  const float size = std::max({extent.x, extent.y, extent.z});
  const glm::vec3 eye(vec(c.eye)), target(vec(c.target));
  const float distance = glm::length(eye - target) + size;
  return {
      glm::lookAt(eye, target, glm::vec3(vec(c.up))),
      glm::perspective(glm::radians(float(c.fov_degrees)), aspect, 0.01f * size, 4.f * distance)};
}

}  // namespace snowsim
