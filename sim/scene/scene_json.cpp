// A parsed scene written back as a scene file: every field, defaults included, so that the file
// parses to the same Scene (run.json records it to reproduce a run).
#include <filesystem>

#include "sim/scene/json_fields.h"
#include "sim/scene/scene.h"

namespace snowsim {

namespace {

// The first `dimension` entries: a scene's vectors have as many as its grid.cells.
Json entries(const Vec3& v, int dimension) {
  return Json(std::vector<double>(v.begin(), v.begin() + dimension));
}

const char* kernelName(KernelType k) {
  return k == KernelType::Cubic ? "cubic" : "quadratic";
}

const char* colliderTypeName(ColliderType t) {
  return t == ColliderType::Sticky ? "sticky" : t == ColliderType::Slip ? "slip" : "separating";
}

Json densityHybridJson(const DensityHybridParams& p) {
  return {{"flip_alpha", p.flip_alpha},
          {"critical_multiplier", p.critical_multiplier},
          {"critical_reference", p.critical_reference == CriticalReference::RestDensity
                                     ? "rest_density"
                                     : "particle_mass_per_cell"},
          {"walls", p.walls == WallRule::HoldGrid   ? "hold_grid"
                    : p.walls == WallRule::SlipGrid ? "slip_grid"
                                                    : "particles_only"},
          {"flip_reference",
           p.flip_reference == FlipReference::Rasterised ? "rasterised" : "equalised"},
          {"kernel", kernelName(p.kernel)}};
}

Json mpmJson(const MpmParams& p) {
  return {
      {"transfer", p.transfer == MpmTransfer::PicFlip ? "pic_flip"
                   : p.transfer == MpmTransfer::Apic  ? "apic"
                                                      : "mls"},
      {"flip_alpha", p.flip_alpha},
      {"kernel", kernelName(p.kernel)},
      {"integrator", p.integrator == MpmIntegrator::SemiImplicit ? "semi_implicit" : "explicit"},
      {"precision", p.precision == MpmPrecision::Float ? "float" : "double"},
      {"beta", p.implicit_beta},
      {"tolerance", p.implicit_tolerance},
      {"max_iterations", p.implicit_max_iterations},
      {"cfl", p.cfl},
      {"adaptive_dt", p.adaptive_dt},
      {"initial_volume", p.initial_volume == InitialVolume::Lattice ? "lattice" : "grid_density"},
      {"walls", {{"type", colliderTypeName(p.wall_type)}, {"friction", p.wall_friction}}},
      {"collider_inset", p.collider_inset},
      {"auto_sleep",
       {{"enabled", p.auto_sleep.enabled},
        {"speed", p.auto_sleep.speed},
        {"steps", p.auto_sleep.steps}}},
      {"open_cracks", p.open_cracks},
      {"crack_friction", p.crack_friction}};
}

void writeMesh(const SceneMesh& m, Json& j) {
  j["shape"] = "mesh";
  // Absolute: run.json's copy of the scene lies in another folder than the scene file.
  j["mesh"] = std::filesystem::absolute(m.file).string();
  if (m.rotation != Vec3{}) j["rotation"] = entries(m.rotation, 3);
  j["scale"] = m.scale;
}

// A rotation or angular velocity as the file gives it: z's alone in 2D.
Json rotationJson(const Vec3& degrees, int dimension) {
  return dimension == 2 ? Json(degrees[2]) : entries(degrees, 3);
}

Json colliderJson(const ColliderParams& c, int dimension) {
  Json j = {{"type", colliderTypeName(c.type)}, {"friction", c.friction}};
  if (c.keyframes.empty()) {
    j["position"] = entries(c.position, dimension);
    j["velocity"] = entries(c.velocity, dimension);
    j["rotation"] = rotationJson(c.rotation, dimension);
    j["angular_velocity"] = rotationJson(c.angular_velocity, dimension);
  }
  for (const PoseKey& k : c.keyframes)
    j["keyframes"].push_back({{"time", k.time},
                              {"position", entries(k.position, dimension)},
                              {"rotation", rotationJson(k.rotation, dimension)}});
  if (c.shape == ColliderShape::HalfSpace) {
    j["shape"] = "half_space";
    j["normal"] = entries(c.normal, dimension);
  } else if (c.shape == ColliderShape::Mesh) {
    writeMesh(c.mesh, j);
  } else if (c.shape == ColliderShape::Box) {
    j["shape"] = "box";
    j["size"] = entries(c.size, dimension);
  } else {
    j["shape"] = c.shape == ColliderShape::Sphere ? "sphere" : "drum";
    j["radius"] = c.radius;
  }
  return j;
}

Json bodyJson(const Body& b, int dimension) {
  if (b.shape == BodyShape::Points) {
    Json j = {{"name", b.name}, {"shape", "points"}, {"file", b.file}, {"density", b.density}};
    if (b.own_particles_per_cell) j["particles_per_cell"] = b.particles_per_cell;
    return j;
  }
  Json j = {{"name", b.name},
            {"shape", b.shape == BodyShape::Ball  ? "ball"
                      : b.shape == BodyShape::Box ? "box"
                                                  : "half_ball"},
            {"center", entries(b.center, dimension)},
            {"velocity", entries(b.velocity, dimension)},
            {"density", b.density}};
  if (b.shape == BodyShape::Mesh) {
    writeMesh(b.mesh, j);
    j["position"] = j["center"];
    j.erase("center");
    j["angular_velocity"] = entries(b.angular_velocity, 3);
  } else if (b.shape == BodyShape::Box)
    j["size"] = entries(b.size, dimension);
  else
    j["radius"] = b.radius;
  if (b.shape == BodyShape::HalfBall) j["cut_normal"] = entries(b.cut_normal, dimension);
  // A body without its own count takes the scene's, as it did here.
  if (b.own_particles_per_cell) j["particles_per_cell"] = b.particles_per_cell;
  j["seeding"] = seedingName(b.seeding);
  return j;
}

Json renderJson(const SceneRender& r) {
  Json j = Json::object();
  if (r.width) j["width"] = *r.width;
  if (r.height) j["height"] = *r.height;
  if (r.color_by) j["color_by"] = *r.color_by;
  if (r.sphere_radius) j["sphere_radius"] = *r.sphere_radius;
  if (r.grid) j["grid"] = *r.grid;
  if (r.density_cells) j["density_cells"] = *r.density_cells;
  if (r.camera) {
    Json& c = j["camera"] = Json::object();
    if (r.camera->preset) {
      c["preset"] = *r.camera->preset;
    } else {
      c = {{"eye", entries(r.camera->eye, 3)},
           {"target", entries(r.camera->target, 3)},
           {"up", entries(r.camera->up, 3)}};
    }
    if (r.camera->fov) c["fov"] = *r.camera->fov;
  }
  if (r.color_range) j["color_range"] = *r.color_range;
  if (r.look) j["look"] = *r.look;
  if (r.background) j["background"] = entries(*r.background, 3);
  if (r.shadows) j["shadows"] = *r.shadows;
  if (r.occlusion) j["occlusion"] = *r.occlusion;
  return j;
}

Json outputJson(const SceneOutput& o) {
  Json j = Json::object();
  if (o.checkpoint_minutes) j["checkpoint_minutes"] = *o.checkpoint_minutes;
  if (o.checkpoint_every_frames) j["checkpoint_every_frames"] = *o.checkpoint_every_frames;
  return j;
}

}  // namespace

Json sceneToJson(const Scene& s) {
  const int d = s.authored_dimension;
  Json grid = {{"cells", std::vector<int>(s.cells.begin(), s.cells.begin() + d)},
               {"cell_size", s.cell_size}};
  if (d == 2) grid["depth_cells"] = s.cells[2];
  Json j = {{"name", s.name},
            {"description", s.description},
            {"dimension", s.dimension},
            {"grid", grid},
            {"gravity", entries(s.gravity, d)},
            {"solver", s.solver == SolverType::Mpm ? "mpm" : "density_hybrid"},
            {"density_hybrid", densityHybridJson(s.density_hybrid)},
            {"mpm", mpmJson(s.mpm)},
            {"material",
             {{"preset", s.material_preset},
              {"E0", s.material.E0},
              {"nu", s.material.nu},
              {"theta_c", s.material.theta_c},
              {"theta_s", s.material.theta_s},
              {"xi", s.material.xi},
              {"hardening_min", s.material.hardening_min},
              {"hardening_max", s.material.hardening_max},
              {"viscosity", s.material.viscosity},
              {"fracture_strain", s.material.fracture_strain},
              {"fracture_length", s.material.fracture_length}}},
            {"colliders", Json::array()},
            {"time", {{"dt", s.dt}, {"duration", s.duration}, {"fps", s.fps}}},
            {"particles_per_cell", s.particles_per_cell},
            {"seeding", seedingName(s.seeding)},
            {"seed", s.seed},
            {"bodies", Json::array()},
            {"render", renderJson(s.render)},
            {"output", outputJson(s.output)}};
  for (const ColliderParams& c : s.colliders) j["colliders"].push_back(colliderJson(c, d));
  for (const Body& b : s.bodies) j["bodies"].push_back(bodyJson(b, d));
  return j;
}

}  // namespace snowsim
