#include "sim/scene/scene.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <sstream>

#include "sim/core/errors.h"
#include "sim/io/ply.h"
#include "sim/scene/json_fields.h"
#include "sim/scene/material_presets.h"

namespace snowsim {

Vec3 Scene::extent() const {
  return {cells[0] * cell_size, cells[1] * cell_size, dimension == 3 ? cells[2] * cell_size : 0};
}

int Scene::frameCount() const {
  return static_cast<int>(std::lround(duration * fps));
}

namespace {

// An override split at its first '=': the dotted path and the value's text.
struct Assignment {
  std::string path;  // dotted: bodies.0.radius
  std::string value;
};

Assignment splitAssignment(const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError("--set " + assignment + ": expected key=value, e.g. time.dt=0.0005");
  const std::string path = assignment.substr(0, eq);
  int depth = 0;
  for (char c : path) {
    depth += c == '[' ? 1 : c == ']' ? -1 : 0;
    if (depth < 0 || depth > 1)
      throw InputError("--set " + assignment + ": unbalanced brackets in " + path);
  }
  const std::string dotted = dottedPath(path);
  if (depth != 0 || dotted.empty() || dotted.front() == '.' || dotted.back() == '.' ||
      dotted.find("..") != std::string::npos)
    throw InputError("--set " + assignment + ": " + path +
                     " is not a field path; write e.g. bodies.0.radius or bodies[0].radius");
  return {dotted, assignment.substr(eq + 1)};
}

// Sets the field at the assignment's path; the value is JSON when it parses as JSON, else a
// string.
void applyOverride(Json& root, const std::string& assignment, const std::string& file) {
  const Assignment a = splitAssignment(assignment);
  Json value = Json::parse(a.value, nullptr, /*allow_exceptions=*/false);
  if (value.is_discarded()) value = a.value;

  Json* node = &root;
  std::stringstream parts(a.path);
  std::string part, walked;
  while (std::getline(parts, part, '.')) {
    walked += (walked.empty() ? "" : ".") + part;
    if (node->is_array()) {
      char* end = nullptr;
      const long k = std::strtol(part.c_str(), &end, 10);
      if (part.empty() || *end || k < 0 || k >= static_cast<long>(node->size()))
        throw InputError("--set " + assignment + " on " + file + ": " + walked + ": no element " +
                         part + " (the array has " + std::to_string(node->size()) + ")");
      node = &(*node)[k];
    } else if (node->is_object() || node->is_null()) {
      node = &(*node)[part];
    } else {
      throw InputError("--set " + assignment + " on " + file + ": " + walked +
                       ": cannot set a field inside a " + node->type_name());
    }
  }
  *node = value;
}

// Whether one dotted path is the other or lies inside it.
bool overlaps(const std::string& a, const std::string& b) {
  const auto inside = [](const std::string& inner, const std::string& outer) {
    return inner.size() > outer.size() && inner.compare(0, outer.size(), outer) == 0 &&
           inner[outer.size()] == '.';
  };
  return a == b || inside(a, b) || inside(b, a);
}

}  // namespace

bool overridesField(const std::vector<std::string>& overrides, const std::string& path) {
  return std::any_of(overrides.begin(), overrides.end(),
                     [&](const std::string& o) { return overlaps(splitAssignment(o).path, path); });
}

namespace {

Vec3 toVec3(const std::vector<double>& v) {
  Vec3 r{0, 0, 0};
  for (size_t i = 0; i < v.size() && i < 3; ++i) r[i] = v[i];
  return r;
}

// Extents of a box: every one must be positive.
Vec3 positiveExtents(JsonFields& f, const std::string& key, int dimension) {
  const Vec3 size = toVec3(f.numbers(key, std::nullopt, {dimension}));
  for (int a = 0; a < dimension; ++a)
    if (!(size[a] > 0)) f.fail(key, "every extent must be positive; allowed: (0, inf) m");
  return size;
}

// A direction, normalised; the zero vector is refused.
Vec3 unitDirection(JsonFields& f, const std::string& key, Vec3 direction) {
  double n2 = 0;
  for (double x : direction) n2 += x * x;
  if (!(n2 > 0)) f.fail(key, "must not be the zero vector");
  for (double& x : direction) x /= std::sqrt(n2);
  return direction;
}

// The fields of a mesh: the file (relative to the scene file's folder), its rotation and scale;
// the file is read and checked here, so a bad mesh stops the scene before anything runs.
// `with_rotation`: a body's mesh is turned by its own "rotation"; a collider's by its motion's.
SceneMesh parseSceneMesh(JsonFields& f, const Scene& scene, bool with_rotation) {
  if (scene.authored_dimension != 3)
    f.fail("shape", "\"mesh\" needs a 3D scene (grid.cells with 3 entries)");
  SceneMesh m;
  const std::filesystem::path given = f.string("mesh", std::nullopt);
  if (given.empty()) f.fail("mesh", "must name a mesh file (OBJ, STL or PLY)");
  m.file = (std::filesystem::path(scene.file).parent_path() / given).lexically_normal().string();
  if (with_rotation) m.rotation = toVec3(f.numbers("rotation", std::vector<double>{0, 0, 0}, {3}));
  m.scale = f.number("scale", 1.0, 0, 1e6, true);
  try {
    m.triangles = std::make_shared<const TriangleMesh>(loadTriangleMesh(m.file));
  } catch (const InputError& e) {
    f.fail("mesh", e.what());
  }
  return m;
}

// "" when the placed mesh fits in the grid (`inside`: wholly within it; else only no larger than
// it), else what is wrong.
std::string meshFitProblem(const SceneMesh& m, const Vec3& position, const Vec3& extent,
                           bool inside) {
  const auto [lo, hi] = m.placedAt(position).bounds();
  std::ostringstream s;
  for (int a = 0; a < 3; ++a)
    if (hi[a] - lo[a] > extent[a]) {
      s << m.file << ": the mesh is larger than the grid: " << hi[a] - lo[a] << " m along "
        << "xyz"[a] << " at scale " << m.scale << ", the grid spans " << extent[a] << " m";
      return s.str();
    }
  if (!inside) return "";
  for (int a = 0; a < 3; ++a)
    if (lo[a] < -1e-12 || hi[a] > extent[a] + 1e-12) {
      s << m.file << ": the placed mesh reaches outside the grid along axis "
        << "xyz"[a] << " ([" << lo[a] << ", " << hi[a] << "] m; the grid spans [0, " << extent[a]
        << "] m)";
      return s.str();
    }
  return "";
}

DensityHybridParams parseDensityHybrid(const Json* j, const std::string& file) {
  DensityHybridParams p;
  if (!j) return p;
  JsonFields f(*j, "density_hybrid", file);
  p.flip_alpha = f.number("flip_alpha", p.flip_alpha, 0, 1);
  p.critical_multiplier = f.number("critical_multiplier", p.critical_multiplier, 0, 1e6, true);
  const auto reference = f.choice("critical_reference", {"particle_mass_per_cell", "rest_density"},
                                  "particle_mass_per_cell");
  p.critical_reference = reference == "rest_density" ? CriticalReference::RestDensity
                                                     : CriticalReference::ParticleMassPerCell;
  const auto walls = f.choice("walls", {"hold_grid", "slip_grid", "particles_only"}, "hold_grid");
  p.walls = walls == "hold_grid"   ? WallRule::HoldGrid
            : walls == "slip_grid" ? WallRule::SlipGrid
                                   : WallRule::ParticlesOnly;
  p.flip_reference =
      f.choice("flip_reference", {"rasterised", "equalised"}, "rasterised") == "rasterised"
          ? FlipReference::Rasterised
          : FlipReference::Equalised;
  p.kernel = f.choice("kernel", {"cubic", "quadratic"}, "cubic") == "cubic" ? KernelType::Cubic
                                                                            : KernelType::Quadratic;
  f.finish();
  return p;
}

ColliderType parseColliderType(JsonFields& f, const std::string& key, const std::string& fallback) {
  const auto t = f.choice(key, {"sticky", "slip", "separating"}, fallback);
  return t == "sticky" ? ColliderType::Sticky
         : t == "slip" ? ColliderType::Slip
                       : ColliderType::Separating;
}

MpmParams parseMpm(const Json* j, const std::string& file, int dimension) {
  MpmParams p;
  // Float by default where it pays, an explicit 3D step (docs/performance.md, "Precision");
  // double where the state is small (2D) or the solve needs it (semi-implicit).
  const auto defaultPrecision = [&] {
    return dimension == 3 && p.integrator == MpmIntegrator::Explicit ? MpmPrecision::Float
                                                                     : MpmPrecision::Double;
  };
  if (!j) {
    p.precision = defaultPrecision();
    return p;
  }
  JsonFields f(*j, "mpm", file);
  const auto transfer = f.choice("transfer", {"pic_flip", "apic", "mls"}, "mls");
  p.transfer = transfer == "pic_flip" ? MpmTransfer::PicFlip
               : transfer == "apic"   ? MpmTransfer::Apic
                                      : MpmTransfer::Mls;
  p.flip_alpha = f.number("flip_alpha", p.flip_alpha, 0, 1);
  p.kernel = f.choice("kernel", {"quadratic", "cubic"}, "quadratic") == "quadratic"
                 ? KernelType::Quadratic
                 : KernelType::Cubic;
  const auto integrator = f.choice("integrator", {"explicit", "semi_implicit"}, "explicit");
  p.integrator =
      integrator == "semi_implicit" ? MpmIntegrator::SemiImplicit : MpmIntegrator::Explicit;
  p.implicit_beta = f.number("beta", p.implicit_beta, 0, 1);
  p.implicit_tolerance = f.number("tolerance", p.implicit_tolerance, 0, 1, true);
  p.implicit_max_iterations = f.integer("max_iterations", p.implicit_max_iterations, 1, 100000);
  p.cfl = f.number("cfl", p.cfl, 0, 1, true);
  p.adaptive_dt = f.boolean("adaptive_dt", p.adaptive_dt);
  p.initial_volume = f.choice("initial_volume", {"lattice", "grid_density"}, "lattice") == "lattice"
                         ? InitialVolume::Lattice
                         : InitialVolume::GridDensity;
  p.precision = f.choice("precision", {"double", "float"},
                         defaultPrecision() == MpmPrecision::Float ? "float" : "double") == "double"
                    ? MpmPrecision::Double
                    : MpmPrecision::Float;
  if (p.precision == MpmPrecision::Float && p.integrator == MpmIntegrator::SemiImplicit)
    f.fail("precision",
           "\"float\" runs only mpm.integrator \"explicit\"; set it (or --precision) to "
           "\"double\" for the semi-implicit integrator");
  p.collider_inset = f.number("collider_inset", p.collider_inset, 0, 0.2);
  if (const Json* walls = f.object("walls", false)) {
    JsonFields w(*walls, "mpm.walls", file);
    p.wall_type = parseColliderType(w, "type", "separating");
    p.wall_friction = w.number("friction", p.wall_friction, 0, 1e3);
    w.finish();
  }
  if (const Json* sleep = f.object("auto_sleep", false)) {
    JsonFields a(*sleep, "mpm.auto_sleep", file);
    p.auto_sleep.enabled = a.boolean("enabled", true);
    p.auto_sleep.speed = a.number("speed", p.auto_sleep.speed, 0, 1e3, true);
    p.auto_sleep.steps = a.integer("steps", p.auto_sleep.steps, 1, 1000000);
    a.finish();
  }
  p.open_cracks = f.boolean("open_cracks", p.open_cracks);
  p.crack_friction = f.number("crack_friction", p.crack_friction, 0, 1e3);
  if (p.open_cracks && p.transfer != MpmTransfer::Mls)
    f.fail("open_cracks", "runs with mpm.transfer \"mls\" only");
  if (p.open_cracks && p.integrator != MpmIntegrator::Explicit)
    f.fail("open_cracks", "runs with mpm.integrator \"explicit\" only");
  f.finish();
  return p;
}

SnowMaterial parseMaterial(const Json* j, const std::string& file) {
  SnowMaterial m;
  if (!j) return m;
  JsonFields f(*j, "material", file);
  m.E0 = f.number("E0", m.E0, 0, 1e12, true);
  m.nu = f.number("nu", m.nu, -1, 0.5, true, true);
  m.theta_c = f.number("theta_c", m.theta_c, 0, 1, true, true);
  m.theta_s = f.number("theta_s", m.theta_s, 0, 1, true, true);
  m.xi = f.number("xi", m.xi, 0, 1e3);
  m.hardening_min = f.number("hardening_min", m.hardening_min, 0, 1);
  m.hardening_max = f.number("hardening_max", m.hardening_max, 1, 1e300);
  m.viscosity = f.number("viscosity", m.viscosity, 0, 1e6);
  m.fracture_strain = f.number("fracture_strain", m.fracture_strain, 0, 100);
  m.fracture_length = f.number("fracture_length", m.fracture_length, 0, 10);
  f.string("preset", std::nullopt);  // checked, and laid beneath, by presetOf
  if (m.fracture_length > 0 && !(m.fracture_strain > 0)) {
    FieldError e(file, "material.fracture_length",
                 "needs material.fracture_strain > 0 (the strain its band fails at)");
    e.also = {"material.fracture_strain"};  // a --set of either is blamed
    throw e;
  }
  f.finish();
  return m;
}

// The preset material.preset names, or the default.
const MaterialPreset& presetOf(const Json* material, const std::string& file) {
  if (!material || !material->contains("preset")) return defaultMaterialPreset();
  JsonFields f(*material, "material", file);
  return *findMaterialPreset(f.choice("preset", materialPresetNames(), std::nullopt));
}

// A string field's value, or the fallback when it is missing or not a string (which parseMpm
// then reports).
std::string stringOr(const Json& object, const std::string& key, const std::string& fallback) {
  const auto it = object.find(key);
  return it != object.end() && it->is_string() ? it->get<std::string>() : fallback;
}

// A preset's cracks or damper that the scene's own transfer or integrator cannot run, or a
// fracture the scene turns off under the preset's crack band: refused naming both, where
// parseMpm and parseMaterial would blame a field the scene does not write. A value that is no
// transfer or integrator at all is left for parseMpm to list the allowed ones.
void refusePresetConflicts(const MaterialPreset& preset, const Json& own_mpm,
                           const Json& own_material, const std::string& file) {
  const bool cracks = !own_mpm.contains("open_cracks") && preset.mpm.value("open_cracks", false);
  const bool damper =
      !own_material.contains("viscosity") && preset.material.value("viscosity", 0.0) > 0;
  const std::string integrator = stringOr(own_mpm, "integrator", "explicit");
  const std::string transfer = stringOr(own_mpm, "transfer", "mls");
  const std::string named =
      "\"" + preset.name + "\"" +
      (own_material.contains("preset") ? "" : " (the default when none is named)");
  const auto refuse = [&](const std::string& field, const std::string& problem) {
    FieldError e(file, "material.preset", named + " " + problem);
    e.also = {field};  // a --set of either is blamed
    throw e;
  };
  const auto presetsWithout = [](bool damper_too) {
    std::vector<std::string> names;
    for (const MaterialPreset& p : materialPresets())
      if (!p.mpm.value("open_cracks", false) &&
          !(damper_too && p.material.value("viscosity", 0.0) > 0))
        names.push_back(p.name);
    return joinNames(names);
  };
  if (integrator == "semi_implicit" && (cracks || damper))
    refuse("mpm.integrator",
           std::string(cracks ? "opens cracks (mpm.open_cracks), which need"
                              : "has a damper (material.viscosity), which needs") +
               " mpm.integrator \"explicit\", not \"semi_implicit\"; name a preset without "
               "either (" +
               presetsWithout(true) + ") or set mpm.open_cracks false and material.viscosity 0");
  if ((transfer == "apic" || transfer == "pic_flip") && cracks)
    refuse("mpm.transfer",
           "opens cracks (mpm.open_cracks), which need mpm.transfer \"mls\", not \"" + transfer +
               "\"; name a preset without them (" + presetsWithout(false) +
               ") or set mpm.open_cracks false");
  const auto strain = own_material.find("fracture_strain");
  if (strain != own_material.end() && strain->is_number() && !(strain->get<double>() > 0) &&
      !own_material.contains("fracture_length") &&
      preset.material.value("fracture_length", 0.0) > 0)
    refuse("material.fracture_strain",
           "fails snow over a crack band (material.fracture_length), which needs "
           "material.fracture_strain > 0; to turn fracture off set material.fracture_length 0 and "
           "mpm.open_cracks false as well, or name a preset without fracture (" +
               presetsWithout(false) + ")");
}

// A rotation (degrees) or angular velocity (degrees/s): a number in 2D (about z), x, y, z in 3D.
Vec3 parseRotation(JsonFields& f, const std::string& key, int dimension) {
  if (dimension == 2) return {0, 0, f.number(key, 0.0)};
  return toVec3(f.numbers(key, std::vector<double>(3, 0.0), {3}));
}

std::vector<PoseKey> parseKeyframes(const Json& keys, const JsonFields& collider,
                                    const Scene& scene) {
  const std::vector<int> dims{scene.authored_dimension};
  std::vector<PoseKey> out;
  if (keys.empty()) collider.fail("keyframes", "must hold at least one key");
  for (size_t i = 0; i < keys.size(); ++i) {
    JsonFields k(keys[i], collider.fieldPath("keyframes") + "[" + std::to_string(i) + "]",
                 scene.file);
    PoseKey key;
    key.time = k.number("time", std::nullopt, 0);
    if (!out.empty() && !(key.time > out.back().time))
      k.fail("time", "must be later than the key before (" + numberText(out.back().time) +
                         " s); keys are in time order");
    key.position = toVec3(k.numbers("position", std::nullopt, dims));
    key.rotation = parseRotation(k, "rotation", scene.authored_dimension);
    k.finish();
    out.push_back(key);
  }
  return out;
}

ColliderParams parseCollider(const Json& j, int index, const Scene& scene) {
  JsonFields f(j, "colliders[" + std::to_string(index) + "]", scene.file);
  const std::vector<int> dims{scene.authored_dimension};
  ColliderParams c;
  c.shape = f.choiceOf<ColliderShape>("shape",
                                      {{"half_space", ColliderShape::HalfSpace},
                                       {"sphere", ColliderShape::Sphere},
                                       {"box", ColliderShape::Box},
                                       {"drum", ColliderShape::Drum},
                                       {"mesh", ColliderShape::Mesh}},
                                      std::nullopt);
  if (const Json* keys = f.array("keyframes", false)) {
    for (const char* motion : {"position", "velocity", "rotation", "angular_velocity"})
      if (f.has(motion)) f.fail(motion, "cannot be given with keyframes; the keys set the motion");
    c.keyframes = parseKeyframes(*keys, f, scene);
    c.position = c.keyframes.front().position;
    c.rotation = c.keyframes.front().rotation;
  } else {
    c.position = toVec3(f.numbers("position", std::nullopt, dims));
    c.velocity = toVec3(f.numbers("velocity", std::vector<double>(dims[0], 0.0), dims));
    c.rotation = parseRotation(f, "rotation", scene.authored_dimension);
    c.angular_velocity = parseRotation(f, "angular_velocity", scene.authored_dimension);
  }
  if (c.shape == ColliderShape::Mesh) {
    c.mesh = parseSceneMesh(f, scene, false);
    // A collider may reach beyond the grid, but its distance field spans the whole mesh.
    if (const std::string problem = meshFitProblem(c.mesh, c.position, scene.extent(), false);
        !problem.empty())
      f.fail("scale", problem);
  } else if (c.shape == ColliderShape::HalfSpace) {
    c.normal = unitDirection(f, "normal", toVec3(f.numbers("normal", std::nullopt, dims)));
  } else if (c.shape == ColliderShape::Box) {
    c.size = positiveExtents(f, "size", scene.authored_dimension);
  } else {
    c.radius = f.number("radius", std::nullopt);
    if (!(c.radius > 0)) f.fail("radius", "must be positive; allowed: (0, inf) m");
  }
  c.type = parseColliderType(f, "type", "separating");
  c.friction = f.number("friction", c.friction, 0, 1e3);
  f.finish();
  return c;
}

// "" when `count` particles per cell fill a lattice in the dimension, else what is wrong.
std::string latticeProblem(int count, int dimension) {
  for (int root = 1; root <= count; ++root) {
    const int p = dimension == 2 ? root * root : root * root * root;
    if (p == count) return "";
    if (p > count) break;
  }
  return std::to_string(count) + " is not a " + (dimension == 2 ? "square" : "cube") +
         "; allowed: " + (dimension == 2 ? "1, 4, 9, 16, ..." : "1, 8, 27, 64, ...");
}

}  // namespace

const char* seedingName(Seeding seeding) {
  switch (seeding) {
    case Seeding::Lattice:
      return "lattice";
    case Seeding::Jittered:
      return "jittered";
    case Seeding::Poisson:
      return "poisson";
  }
  return "lattice";
}

namespace {

Seeding parseSeeding(JsonFields& f, Seeding fallback) {
  return f.choiceOf<Seeding>("seeding",
                             {{"lattice", Seeding::Lattice},
                              {"jittered", Seeding::Jittered},
                              {"poisson", Seeding::Poisson}},
                             seedingName(fallback));
}

// What every body gives: its lattice's particles per cell (a points body's particles take their
// mass from it when the file has none) and its rest density.
void parseParticlesPerCellAndDensity(JsonFields& f, Body& b, const Scene& scene,
                                     const JsonFields& scene_fields) {
  b.own_particles_per_cell = f.has("particles_per_cell");
  b.particles_per_cell = f.integer("particles_per_cell", scene.particles_per_cell, 1, 1000);
  if (const std::string problem = latticeProblem(b.particles_per_cell, scene.authored_dimension);
      !problem.empty())
    (b.own_particles_per_cell ? f : scene_fields).fail("particles_per_cell", problem);
  b.density = f.number("density", b.density, 0, 1e6, true);
}

// A points body: {"shape": "points", "file": "state.ply"}, the file's particles as they are. The
// file is read here, so that a missing file, missing columns or particles outside the grid fail
// before anything runs.
Body parsePointsBody(JsonFields& f, Body& b, const Scene& scene, const JsonFields& scene_fields) {
  const std::string given = f.string("file", std::nullopt);
  b.file = std::filesystem::absolute(std::filesystem::path(scene.file).parent_path() / given)
               .lexically_normal()
               .string();
  parseParticlesPerCellAndDensity(f, b, scene, scene_fields);
  f.finish();
  try {
    b.points = std::make_shared<const Snapshot>(readPly(b.file, PlyContent::Particles));
  } catch (const InputError& e) {
    f.fail("file", e.what());
  }
  if (b.points->size() == 0) f.fail("file", b.file + ": holds no particles");
  const Vec3 extent = scene.extent();
  for (int i = 0; i < b.points->size(); ++i)
    for (int a = 0; a < scene.dimension; ++a) {
      const double x = b.points->position[i][a];
      if (!std::isfinite(x)) {
        std::ostringstream s;
        s << b.file << ": particle " << i << ": its "
          << "xyz"[a] << " coordinate (" << x << ") is not a finite number; allowed: [0, "
          << extent[a] << ") m, inside the grid";
        f.fail("file", s.str());
      }
      if (!(x >= 0 && x < extent[a])) {
        std::ostringstream s;
        s << b.file << ": particle " << i << " lies outside the grid along axis "
          << "xyz"[a] << " (" << x << " m; the grid spans [0, " << extent[a] << ") m)";
        f.fail("file", s.str());
      }
    }
  for (const auto& v : b.points->velocity)
    if (!(std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2])))
      f.fail("file", b.file + ": a velocity is not a finite number");
  for (const auto* column : {&b.points->mass, &b.points->plastic_j})
    for (float value : *column)
      if (!(value > 0 && std::isfinite(value)))
        f.fail("file", b.file + ": a mass or plastic_j is not a positive number");
  return b;
}

// `scene_fields` reads the scene's top level: a default count that fills no lattice is its fault.
Body parseBody(const Json& j, int index, const Scene& scene, const JsonFields& scene_fields) {
  const std::string path = "bodies[" + std::to_string(index) + "]";
  JsonFields f(j, path, scene.file);
  const std::vector<int> dims{scene.authored_dimension};
  Body b;
  b.density = findMaterialPreset(scene.material_preset)->density;
  b.name = f.string("name", "body" + std::to_string(index));
  b.shape = f.choiceOf<BodyShape>("shape",
                                  {{"ball", BodyShape::Ball},
                                   {"box", BodyShape::Box},
                                   {"half_ball", BodyShape::HalfBall},
                                   {"mesh", BodyShape::Mesh},
                                   {"points", BodyShape::Points}},
                                  std::nullopt);
  if (b.shape == BodyShape::Points) return parsePointsBody(f, b, scene, scene_fields);
  if (b.shape == BodyShape::Mesh) {
    b.mesh = parseSceneMesh(f, scene, true);
    b.center = toVec3(f.numbers("position", std::nullopt, dims));
    b.angular_velocity = toVec3(f.numbers("angular_velocity", std::vector<double>{0, 0, 0}, {3}));
  } else {
    b.center = toVec3(f.numbers("center", std::nullopt, dims));
  }
  if (b.shape == BodyShape::Mesh) {
    if (const std::string problem = meshFitProblem(b.mesh, b.center, scene.extent(), true);
        !problem.empty())
      f.fail(problem.find("larger") != std::string::npos ? "scale" : "position", problem);
  } else if (b.shape == BodyShape::Box) {
    b.size = positiveExtents(f, "size", scene.authored_dimension);
  } else {
    b.radius = f.number("radius", std::nullopt, 0, 1e6, true);
  }
  if (b.shape == BodyShape::HalfBall) {
    Vec3 cut = toVec3(f.numbers("cut_normal", std::vector<double>(dims[0], 0.0), dims));
    if (!f.has("cut_normal")) cut[1] = 1;
    b.cut_normal = unitDirection(f, "cut_normal", cut);
  }
  b.velocity = toVec3(f.numbers("velocity", std::vector<double>(dims[0], 0.0), dims));
  parseParticlesPerCellAndDensity(f, b, scene, scene_fields);
  b.seeding = parseSeeding(f, scene.seeding);
  f.finish();

  // The body's bounding box must lie inside the domain (a mesh's was checked above).
  const Vec3 extent = scene.extent();
  for (int a = 0; a < scene.authored_dimension && b.shape != BodyShape::Mesh; ++a) {
    const double half = b.shape == BodyShape::Box ? b.size[a] / 2 : b.radius;
    if (b.center[a] - half < -1e-12 || b.center[a] + half > extent[a] + 1e-12) {
      std::ostringstream s;
      s << "the body (its center and " << (b.shape == BodyShape::Box ? "size" : "radius")
        << ") reaches outside the grid along axis "
        << "xyz"[a] << " ([" << b.center[a] - half << ", " << b.center[a] + half
        << "] m; the grid spans [0, " << extent[a] << "] m)";
      f.fail("center", s.str(), {b.shape == BodyShape::Box ? "size" : "radius"});
    }
  }
  return b;
}

Vec3 point(JsonFields& f, const std::string& key, std::optional<std::vector<double>> fallback) {
  return toVec3(f.numbers(key, fallback, {3}));
}

SceneRender parseRender(const Json* j, const std::string& file) {
  SceneRender r;
  if (!j) return r;
  JsonFields f(*j, "render", file);
  if (f.given("width")) r.width = f.integer("width", std::nullopt, 16, 8192);
  if (f.given("height")) r.height = f.integer("height", std::nullopt, 16, 8192);
  if (f.given("color_by"))
    r.color_by = f.choice("color_by", {"white", "density", "speed", "plastic"}, std::nullopt);
  if (f.given("sphere_radius")) r.sphere_radius = f.number("sphere_radius", std::nullopt, 0, 10);
  if (f.given("grid")) r.grid = f.boolean("grid", std::nullopt);
  if (f.given("density_cells")) r.density_cells = f.boolean("density_cells", std::nullopt);
  if (f.given("look"))
    r.look = f.choice("look", {"studio", "figure", "surface", "volume"}, std::nullopt);
  if (f.given("background")) {
    r.background = point(f, "background", std::nullopt);
    for (double c : *r.background)
      if (!(c >= 0 && c <= 1)) f.fail("background", "each of red, green, blue must be in [0, 1]");
  }
  if (f.given("shadows")) r.shadows = f.boolean("shadows", std::nullopt);
  if (f.given("occlusion")) r.occlusion = f.boolean("occlusion", std::nullopt);
  if (const Json* camera = f.object("camera", false)) {
    JsonFields c(*camera, "render.camera", file);
    SceneCamera& view = r.camera.emplace();
    if (c.given("preset")) {
      view.preset = c.choice("preset", {"front", "side", "three_quarter", "top"}, std::nullopt);
      for (const char* placed : {"eye", "target", "up"})
        if (c.has(placed))
          c.fail(placed, "a camera has a preset or is placed (eye, target, up), not both");
    } else {
      view.eye = point(c, "eye", std::nullopt);
      view.target = point(c, "target", std::nullopt);
      view.up = point(c, "up", std::vector<double>{0, 1, 0});
      if (view.eye == view.target) c.fail("target", "must differ from eye");
    }
    if (c.given("fov")) view.fov = c.number("fov", std::nullopt, 0, 180, true, true);
    c.finish();
  }
  if (f.given("color_range")) {
    const std::vector<double> range = f.numbers("color_range", std::nullopt, {2});
    if (!(range[0] < range[1])) f.fail("color_range", "must be [low, high] with low < high");
    r.color_range = {range[0], range[1]};
  }
  f.finish();
  return r;
}

SceneOutput parseOutput(const Json* j, const std::string& file) {
  SceneOutput o;
  if (!j) return o;
  JsonFields f(*j, "output", file);
  if (f.given("checkpoint_minutes"))
    o.checkpoint_minutes = f.number("checkpoint_minutes", std::nullopt, 0, 1e6);
  if (f.given("checkpoint_every_frames"))
    o.checkpoint_every_frames = f.integer("checkpoint_every_frames", std::nullopt, 0, 1000000);
  f.finish();
  return o;
}

// The first body centre or collider position given with 3 numbers ("bodies[0].center"), or "".
std::string firstPlacedIn3D(const Json& root) {
  for (const auto& [list, field] : {std::pair{"bodies", "center"}, {"colliders", "position"}}) {
    const auto it = root.find(list);
    if (it == root.end() || !it->is_array()) continue;
    for (size_t i = 0; i < it->size(); ++i) {
      const Json& item = (*it)[i];
      if (item.is_object() && item.contains(field) && item[field].is_array() &&
          item[field].size() == 3)
        return std::string(list) + "[" + std::to_string(i) + "]." + field;
    }
  }
  return "";
}

}  // namespace

Scene parseScene(const Json& root, const std::string& file) {
  Scene s;
  s.file = file;
  JsonFields f(root, "", file);
  s.name = f.string("name", std::nullopt);
  s.description = f.string("description", "");
  s.dimension = f.integer("dimension", 2, 2, 3);

  const Json* grid = f.object("grid", false);
  const Json empty = Json::object();
  JsonFields g(grid ? *grid : empty, "grid", file);
  const auto cells = g.numbers("cells", std::vector<double>{10, 12}, {2, 3});
  s.authored_dimension = static_cast<int>(cells.size());
  if (s.authored_dimension == 3 && s.dimension == 2)
    g.fail("cells", "has 3 entries but the scene's dimension is 2 (a 3D scene cannot run in 2D)");
  if (const std::string placed = firstPlacedIn3D(root);
      s.authored_dimension == 2 && s.dimension == 3 && !placed.empty())
    g.fail("cells",
           "has 2 entries, which makes the scene 2D (extruded through a slab when run in "
           "3D), but " +
               placed + " has 3; a 3D scene gives grid.cells 3 entries");
  for (size_t a = 0; a < cells.size(); ++a) {
    if (cells[a] != std::floor(cells[a]) || cells[a] < 1 || cells[a] > 4096)
      g.fail("cells", "each entry must be a whole number from 1 to 4096");
    s.cells[a] = static_cast<int>(cells[a]);
  }
  // A 2D scene run in 3D is a slab this many cells deep, bodies extruded through it (the report
  // ran its 2D method on a 10x12x1 grid).
  s.cells[2] = s.authored_dimension == 3 ? s.cells[2] : g.integer("depth_cells", 1, 1, 4096);
  s.cell_size = g.number("cell_size", 0.01, 0, 1e3, true);
  g.finish();

  s.gravity = toVec3(f.numbers(
      "gravity",
      s.authored_dimension == 2 ? std::vector<double>{0, -9.81} : std::vector<double>{0, -9.81, 0},
      {s.authored_dimension}));

  s.solver = f.choice("solver", {"density_hybrid", "mpm"}, "density_hybrid") == "mpm"
                 ? SolverType::Mpm
                 : SolverType::DensityHybrid;
  s.density_hybrid = parseDensityHybrid(f.object("density_hybrid", false), file);
  const Json* own_mpm = f.object("mpm", false);
  const Json* own_material = f.object("material", false);
  const MaterialPreset& preset = presetOf(own_material, file);
  // The preset's crack settings only where MPM runs: a scene of the report's method keeps its
  // mpm object as written.
  const bool mpm_runs = s.solver == SolverType::Mpm;
  if (mpm_runs)
    refusePresetConflicts(preset, own_mpm ? *own_mpm : empty, own_material ? *own_material : empty,
                          file);
  s.material_preset = preset.name;
  const Json mpm =
      mpm_runs ? beneath(own_mpm ? *own_mpm : empty, preset.mpm) : (own_mpm ? *own_mpm : empty);
  s.mpm = parseMpm(&mpm, file, s.dimension);
  Json material = beneath(own_material ? *own_material : empty, preset.material);
  material["preset"] = preset.name;
  s.material = parseMaterial(&material, file);
  if (s.material.viscosity > 0 && s.mpm.integrator == MpmIntegrator::SemiImplicit)
    throw InputError(file +
                     ": material.viscosity runs only mpm.integrator \"explicit\" (the "
                     "semi-implicit solve has no damper in its stress differential); set it to 0");
  if (s.mpm.open_cracks && !(s.material.fracture_strain > 0)) {
    FieldError e(file, "mpm.open_cracks",
                 "needs material.fracture_strain > 0 (the strain at which snow fails and a "
                 "crack can open)");
    e.also = {"material.fracture_strain"};  // a --set of either is blamed
    throw e;
  }
  if (const Json* colliders = f.array("colliders", false))
    for (size_t i = 0; i < colliders->size(); ++i)
      s.colliders.push_back(parseCollider((*colliders)[i], static_cast<int>(i), s));

  const Json* time = f.object("time", false);
  JsonFields t(time ? *time : empty, "time", file);
  s.dt = t.number("dt", 0.001, 0, 10, true);
  s.duration = t.number("duration", 1.0, 0, 1e6);
  s.fps = t.number("fps", 50, 0, 1e4, true);
  t.finish();

  s.particles_per_cell =
      f.integer("particles_per_cell", s.authored_dimension == 2 ? 9 : 27, 1, 1000);
  s.seeding = parseSeeding(f, s.authored_dimension == 3 ? Seeding::Jittered : Seeding::Lattice);
  s.seed = f.integer("seed", s.seed, 0, std::numeric_limits<int>::max());
  const Json* bodies = f.array("bodies", true);
  if (bodies->empty()) f.fail("bodies", "needs at least one body");
  for (size_t i = 0; i < bodies->size(); ++i)
    s.bodies.push_back(parseBody((*bodies)[i], static_cast<int>(i), s, f));

  s.render = parseRender(f.object("render", false), file);
  s.output = parseOutput(f.object("output", false), file);
  f.finish();
  return s;
}

Scene loadScene(const std::string& path, const std::vector<std::string>& overrides) {
  return loadScene(readJsonFile(path), path, overrides);
}

Scene loadScene(Json root, const std::string& path, const std::vector<std::string>& overrides) {
  for (const std::string& o : overrides) applyOverride(root, o, path);
  try {
    return parseScene(root, path);
  } catch (const FieldError& e) {
    // A field an override wrote: blame the last assignment to it, not the file.
    for (auto o = overrides.rbegin(); o != overrides.rend(); ++o) {
      const std::string set = splitAssignment(*o).path;
      const bool blamed = overlaps(set, e.field) ||
                          std::any_of(e.also.begin(), e.also.end(),
                                      [&](const std::string& f) { return overlaps(set, f); });
      if (blamed) throw InputError("--set " + *o + " on " + path + ": " + e.problem);
    }
    throw;
  }
}

void setParticlesPerCell(Scene& scene, int count) {
  std::string problem = latticeProblem(count, scene.authored_dimension);
  if (count < 1 || count > 1000)
    problem = std::to_string(count) + " is out of range; allowed: 1 to 1000";
  if (!problem.empty()) throw InputError(scene.file + ": particles_per_cell: " + problem);
  scene.particles_per_cell = count;
  for (Body& body : scene.bodies)
    if (!body.own_particles_per_cell) body.particles_per_cell = count;
}

void refineGrid(Scene& scene, int factor) {
  for (int a = 0; a < scene.authored_dimension; ++a)
    if (factor < 1 || static_cast<long>(scene.cells[a]) * factor > 4096)
      throw InputError(scene.file + ": grid.cells: " + std::to_string(factor) + " times " +
                       std::to_string(scene.cells[a]) +
                       " cells is out of range; allowed: 1 to 4096 along each axis");
  for (int a = 0; a < scene.authored_dimension; ++a) scene.cells[a] *= factor;
  scene.cell_size /= factor;
}

void scaleGrid(Scene& scene, double factor) {
  std::array<int, 3> cells = scene.cells;
  for (int a = 0; a < scene.dimension; ++a) {
    const double scaled = scene.cells[a] * factor;
    cells[a] = static_cast<int>(std::lround(scaled));
    if (!(factor > 0) || std::abs(scaled - cells[a]) > 1e-9 * scaled || cells[a] < 1 ||
        cells[a] > 4096) {
      std::ostringstream problem;
      problem << scene.file << ": grid.cells: " << factor << " times " << scene.cells[a]
              << " cells is " << scaled << "; allowed: a whole number from 1 to 4096 along each "
              << "axis";
      throw InputError(problem.str());
    }
  }
  scene.cells = cells;
  scene.cell_size /= factor;
}

void refuseWhatIsNotDistributed(const Scene& scene, int ranks) {
  if (ranks <= 1) return;
  if (scene.solver != SolverType::Mpm)
    throw InputError(scene.file +
                     ": the report's method runs in one process; across MPI ranks only "
                     "\"solver\": \"mpm\" is distributed");
  // MpmSolver's semiImplicit(): the semi-implicit integrator runs in double only.
  if (scene.mpm.integrator == MpmIntegrator::SemiImplicit &&
      scene.mpm.precision == MpmPrecision::Double)
    throw InputError(scene.file + ": mpm.integrator \"semi_implicit\" runs in one process; " +
                     "across MPI ranks only \"explicit\" is distributed");
}

}  // namespace snowsim
