#include "app/collider_json.h"

#include <filesystem>
#include <memory>

#include "sim/core/errors.h"

namespace snowsim {

namespace {

using Shape = SnapshotCollider::Shape;

const char* shapeName(Shape shape) {
  return shape == Shape::Plane    ? "plane"
         : shape == Shape::Sphere ? "sphere"
         : shape == Shape::Box    ? "box"
                                  : "mesh";
}

}  // namespace

nlohmann::json collidersToJson(const std::vector<SnapshotCollider>& colliders) {
  nlohmann::json out = nlohmann::json::array();
  for (const SnapshotCollider& c : colliders) {
    out.push_back({{"shape", shapeName(c.shape)},
                   {"position", c.position},
                   {"normal", c.normal},
                   {"radius", c.radius},
                   {"size", c.size},
                   {"velocity", c.velocity}});
    // The file, not its triangles: `snowsim render` reads it again.
    if (c.shape == Shape::Mesh)
      out.back().update({{"mesh", std::filesystem::absolute(c.mesh_file).string()},
                         {"rotation", c.rotation},
                         {"scale", c.scale}});
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
      if (shape != "plane" && shape != "sphere" && shape != "box" && shape != "mesh")
        throw InputError(where + ".shape: \"" + shape + "\"; allowed: plane, sphere, box, mesh");
      c.shape = shape == "plane"    ? Shape::Plane
                : shape == "sphere" ? Shape::Sphere
                : shape == "box"    ? Shape::Box
                                    : Shape::Mesh;
      c.position = j.at("position").get<std::array<double, 3>>();
      c.normal = j.at("normal").get<std::array<double, 3>>();
      c.radius = j.at("radius").get<double>();
      c.size = j.at("size").get<std::array<double, 3>>();
      c.velocity = j.at("velocity").get<std::array<double, 3>>();
      if (c.shape == Shape::Mesh) {
        c.mesh_file = j.at("mesh").get<std::string>();
        c.rotation = j.at("rotation").get<std::array<double, 3>>();
        c.scale = j.at("scale").get<double>();
        c.mesh = std::make_shared<const TriangleMesh>(loadTriangleMesh(c.mesh_file));
      }
      out.push_back(c);
    } catch (const nlohmann::json::exception& e) {
      throw InputError(where + ": " + e.what() +
                       "; expected shape, position, normal, radius, size, velocity (and a mesh's "
                       "mesh, rotation, scale)");
    }
  }
  return out;
}

}  // namespace snowsim
