#include "app/collider_json.h"

#include <algorithm>
#include <filesystem>
#include <memory>

#include "sim/core/errors.h"
#include "sim/scene/scene_colliders.h"

namespace snowsim {

namespace {

using Shape = SnapshotCollider::Shape;
constexpr std::array kShapes{Shape::Plane, Shape::Sphere, Shape::Box, Shape::Drum, Shape::Mesh};

const char* shapeName(Shape shape) {
  return shape == Shape::Plane    ? "plane"
         : shape == Shape::Sphere ? "sphere"
         : shape == Shape::Drum   ? "drum"
         : shape == Shape::Mesh   ? "mesh"
                                  : "box";
}

// The rotation matrix of unit quaternion q = (w, x, y, z), row by row.
nlohmann::json rotationMatrix(const std::array<double, 4>& q) {
  const auto [w, x, y, z] = q;
  return {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
          {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
          {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
}

}  // namespace

nlohmann::json collidersToJson(const std::vector<SnapshotCollider>& colliders) {
  nlohmann::json out = nlohmann::json::array();
  for (const SnapshotCollider& c : colliders) {
    out.push_back({{"shape", shapeName(c.shape)},
                   {"position", c.position},
                   {"rotation", c.rotation},
                   {"matrix", rotationMatrix(c.rotation)},
                   {"normal", c.normal},
                   {"radius", c.radius},
                   {"size", c.size},
                   {"velocity", c.velocity}});
    // The file, not its triangles: `snowsim render` reads it again.
    if (c.shape == Shape::Mesh)
      out.back().update(
          {{"mesh", std::filesystem::absolute(c.mesh_file).string()}, {"scale", c.scale}});
  }
  return out;
}

nlohmann::json colliderFramesJson(const Scene& scene, int frames) {
  nlohmann::json out = {
      {"format", "snowsim colliders 1"},
      {"axes",
       "metres and seconds, right-handed, y up (a 2D run: x, y and z = 0); each collider's shape "
       "is in its local frame, x_world = R x_local + position, R the rotation, given as a unit "
       "quaternion [w, x, y, z] and as the matrix row by row"},
      {"fps", scene.fps},
      {"frames", nlohmann::json::array()}};
  for (int frame = 0; frame < frames; ++frame) {
    const double time = std::min(scene.duration, frame / scene.fps);
    out["frames"].push_back(
        {{"frame", frame},
         {"time", time},
         {"colliders", collidersToJson(collidersAt(scene, scene.dimension, time))}});
  }
  return out;
}

std::vector<SnapshotCollider> collidersFromJson(const nlohmann::json& colliders,
                                                const std::string& file) {
  std::vector<SnapshotCollider> out;
  if (!colliders.is_array())
    throw InputError(file + ": colliders: must be an array (as snowsim run writes it)");
  for (size_t i = 0; i < colliders.size(); ++i) {
    const std::string where = file + ": colliders[" + std::to_string(i) + "]";
    try {
      const nlohmann::json& j = colliders[i];
      SnapshotCollider c;
      const std::string shape = j.at("shape").get<std::string>();
      const auto known = std::find_if(kShapes.begin(), kShapes.end(),
                                      [&](Shape s) { return shape == shapeName(s); });
      if (known == kShapes.end())
        throw InputError(where + ".shape: \"" + shape +
                         "\"; allowed: plane, sphere, box, drum, mesh");
      c.shape = *known;
      c.position = j.at("position").get<std::array<double, 3>>();
      // Runs before colliders turned recorded no rotation.
      c.rotation = j.value("rotation", c.rotation);
      c.normal = j.at("normal").get<std::array<double, 3>>();
      c.radius = j.at("radius").get<double>();
      c.size = j.at("size").get<std::array<double, 3>>();
      c.velocity = j.at("velocity").get<std::array<double, 3>>();
      if (c.shape == Shape::Mesh) {
        c.mesh_file = j.at("mesh").get<std::string>();
        c.scale = j.at("scale").get<double>();
        c.mesh = std::make_shared<const TriangleMesh>(loadTriangleMesh(c.mesh_file));
      }
      out.push_back(c);
    } catch (const nlohmann::json::exception& e) {
      throw InputError(where + ": " + e.what() +
                       "; expected shape, position, normal, radius, size, velocity (rotation "
                       "optional; a mesh's mesh and scale)");
    }
  }
  return out;
}

}  // namespace snowsim
