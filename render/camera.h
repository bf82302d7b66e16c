// Where the renderer looks from. 2D: the whole domain, orthographic. 3D: a perspective camera,
// either placed by the user (eye, target) or framing a box (the snow's extent) from a preset
// direction: front, side, three-quarter or top.
#pragma once

#include <array>
#include <string>

#include <glm/glm.hpp>

#include "sim/core/snapshot.h"

namespace snowsim {

struct RenderSettings;

enum class CameraPreset { ThreeQuarter, Front, Side, Top };

// Parses "front", "side", "three_quarter", "top"; throws InputError listing the allowed names.
CameraPreset parseCameraPreset(const std::string& name, const std::string& where);
std::string presetName(CameraPreset preset);

// An axis-aligned box in world coordinates (metres); empty until a point is added.
struct Bounds {
  std::array<double, 3> lo{1, 1, 1}, hi{0, 0, 0};
  bool empty() const { return lo[0] > hi[0]; }
  void add(const std::array<double, 3>& p);
  void include(const Bounds& other);
};

// The box around the snapshot's particles and their spheres (empty without particles).
Bounds particleBounds(const Snapshot& s);

// A perspective camera for 3D scenes, in world coordinates (metres).
struct Camera {
  bool custom = false;  // eye, target and up are set; false: frame `frame` from `preset`
  std::array<double, 3> eye{}, target{}, up{0, 1, 0};
  double fov_degrees = 35;  // vertical field of view
  CameraPreset preset = CameraPreset::ThreeQuarter;
  Bounds frame;  // what the preset camera frames; empty: the whole domain
};

// The camera looking at the box's centre from the preset's direction, just far enough that every
// corner of the box lies inside the image of the given aspect ratio (with a small margin).
Camera framingCamera(const Bounds& box, CameraPreset preset, double fov_degrees, double aspect);

// The camera as placed: the settings' own when custom, else framing its box (the whole domain,
// extent in metres, when that is empty) from its preset at the image's aspect ratio.
Camera placedCamera(const RenderSettings& settings, const std::array<double, 3>& extent);

struct View {
  glm::mat4 view, projection;
};

// 2D: the whole domain, orthographic, with a margin. 3D: the settings' camera; one that is not
// custom frames its box (the whole domain when that is empty) from its preset.
View cameraFor(const Snapshot& s, const RenderSettings& settings, glm::vec3 extent);

}  // namespace snowsim
