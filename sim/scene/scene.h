// A scene file, parsed and validated: the grid, the solver and its parameters, time stepping and
// the bodies of snow. See docs/scene-format.md for every field.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sim/core/bspline.h"
#include "sim/core/collider_kind.h"
#include "sim/core/math.h"
#include "sim/core/rigid_motion.h"
#include "sim/core/snapshot.h"
#include "sim/geometry/triangle_mesh.h"
#include "sim/mpm/snow_material.h"

namespace snowsim {

enum class SolverType { DensityHybrid, Mpm };
// Points: the particles of a PLY file (a frame of a run, or another tool's state), as they are.
enum class BodyShape { Ball, Box, HalfBall, Mesh, Points };
// Where a body's particles sit: at the centres of their lattice cells, each at a random point of
// its cell (which breaks the lattice's stripes in 3D), or Poisson-disk points (Bridson 2007), as
// many as the lattice's to a few percent but with no lattice at all; deterministic for the seed.
enum class Seeding { Lattice, Jittered, Poisson };
// The name a scene file gives the seeding: "lattice", "jittered" or "poisson".
const char* seedingName(Seeding seeding);

// The readings of the report's vague passages (docs/report-readings.md).
enum class CriticalReference {
  RestDensity,          // multiplier x the mean particle density of the first step
  ParticleMassPerCell,  // multiplier x one particle's mass over a cell, m_p / h^d
};
enum class WallRule {
  HoldGrid,       // grid velocity and force held at zero on and beyond the box walls
  SlipGrid,       // ... only their component across the wall
  ParticlesOnly,  // the literal text: only particles at the ground lose downward velocity
};
enum class FlipReference {
  Rasterised,  // FLIP increment v^{n+1} - v^n from the velocity as rasterised (before step 4)
  Equalised,   // ... from the velocity after the critical-density clamp of step 4
};

struct DensityHybridParams {
  double flip_alpha = 0.95;          // PIC/FLIP blend: 0 pure PIC, 1 pure FLIP
  double critical_multiplier = 4.0;  // critical density = multiplier x reference density
  CriticalReference critical_reference = CriticalReference::ParticleMassPerCell;
  WallRule walls = WallRule::HoldGrid;
  FlipReference flip_reference = FlipReference::Rasterised;
  KernelType kernel = KernelType::Cubic;
};

// MPM snow (Stomakhin et al. 2013): transfers, kernel, time integration, walls; docs/mpm.md.
enum class MpmTransfer { PicFlip, Apic, Mls };
enum class MpmIntegrator { Explicit, SemiImplicit };
// V_p^0: the particle's share of its body's volume (spacing^D of the sampling lattice), or the
// paper's estimate m_p / rho_p^0 with rho_p^0 rasterised to the grid (section 4 step 2), which
// overestimates the volume of particles near a free surface (docs/mpm.md).
enum class InitialVolume { Lattice, GridDensity };
// The precision of the MPM state and its step's arithmetic (docs/performance.md weighs them).
enum class MpmPrecision { Double, Float };

// Particles whose surroundings rest skip their gather, their F_E update and their advection
// (docs/mpm.md): one falls asleep after `steps` steps in a row in which it and every node of its
// stencil moved slower than `speed`, and wakes when a node of its stencil moves faster.
struct AutoSleep {
  bool enabled = false;
  double speed = 0.02;  // m/s: above the ringing of snow at rest under gravity (docs/mpm.md)
  int steps = 30;
};

struct MpmParams {
  MpmTransfer transfer = MpmTransfer::Mls;
  double flip_alpha = 0.95;  // PIC/FLIP blend (paper section 8: 0.95)
  KernelType kernel = KernelType::Quadratic;
  MpmIntegrator integrator = MpmIntegrator::Explicit;
  double implicit_beta = 1;          // semi-implicit: 1 backward Euler, 0.5 trapezoidal, 0 explicit
  double implicit_tolerance = 1e-5;  // semi-implicit: relative residual of the Krylov solve
  int implicit_max_iterations = 200;  // semi-implicit: Krylov iteration cap per step
  double cfl = 0.9;         // C of dt <= C h / (c + |v|max); docs/mpm.md has the measured limit
  bool adaptive_dt = true;  // false: time.dt is used as is (to study stability)
  InitialVolume initial_volume = InitialVolume::Lattice;
  MpmPrecision precision = MpmPrecision::Double;      // float: explicit integrator only
  ColliderType wall_type = ColliderType::Separating;  // the domain walls
  double wall_friction = 0.2;
  // Cells inside a collider's surface at which the grid's nodes meet it (Collider::grid_inset).
  // Snow comes to rest about 1.2 cells above the highest node a collider stops: a node on the
  // surface (a domain wall, a ground on a plane of nodes) holds it that far up, and one left free
  // lowers it to 0.2 cells. Beyond about 0.2 cells, snow on a surface between two planes of nodes
  // would rest below the grid's support and be pressed into the collider. 0 is the paper's rule.
  double collider_inset = 0.1;
  AutoSleep auto_sleep;
  // Two velocities a node across damaged snow and failed snow as loose grains (sim/mpm/
  // crack_opening.h): needs material.fracture_strain, the MLS transfer, the explicit integrator
  // and one process; runs with auto-sleep.
  bool open_cracks = false;
  double crack_friction = 0.6;  // Coulomb coefficient where the fields of open_cracks touch
};

// A closed triangle mesh file placed in the scene (3D scenes): scaled, rotated, then moved to the
// body's or collider's position (MeshPlacement, sim/geometry/triangle_mesh.h).
struct SceneMesh {
  std::string file;  // as resolved against the scene file's folder
  Vec3 rotation{};   // degrees about x, then y, then z (fixed axes)
  double scale = 1;
  std::shared_ptr<const TriangleMesh> triangles;  // as read from the file, checked watertight

  // The mesh scaled and rotated about its origin, then moved to `position`.
  TriangleMesh placedAt(const Vec3& position) const {
    return placed(*triangles, {position, rotation, scale});
  }
};

// A collider's shape is given in its local frame, placed in the world by its rigid motion (the
// base: a constant velocity and angular velocity from `position` and `rotation` at time 0, or
// keyframes; sim/core/rigid_motion.h). Its position is the local origin: a point of the plane,
// the shape's centre.
struct ColliderParams : RigidMotionDescription {
  ColliderShape shape = ColliderShape::HalfSpace;
  Vec3 normal{0, 1, 0};  // half space: outward normal in the local frame (the solid is behind it)
  double radius = 0;     // sphere; drum: the inner radius of its wall, axis along local z (m)
  Vec3 size{};           // box extents (m)
  SceneMesh mesh;        // mesh: its origin at position
  ColliderType type = ColliderType::Separating;
  double friction = 0.2;  // Coulomb coefficient
};

struct Body {
  std::string name;
  BodyShape shape = BodyShape::Ball;
  Vec3 center{};             // ball and half ball centre, box centre, mesh origin (m)
  double radius = 0;         // ball and half ball (m)
  Vec3 size{};               // box extents (m)
  Vec3 cut_normal{0, 1, 0};  // half ball: keeps the points with (x - center) . n >= 0
  SceneMesh mesh;            // mesh
  Vec3 velocity{};           // initial velocity (m/s)
  // Initial angular velocity (rad/s, mesh bodies): v = velocity + w x (x - centre of mass).
  Vec3 angular_velocity{};
  // Points: the PLY file (as resolved against the scene's directory) and its particles, read and
  // checked once when the scene is loaded: positions and velocities in the scene's y-up axes, and
  // the masses and J_P when the file has them.
  std::string file;
  std::shared_ptr<const Snapshot> points;
  int particles_per_cell = 27;         // particles per cell of the scene's authored dimension
  double density = 400;                // kg/m^3
  Seeding seeding = Seeding::Lattice;  // the scene's unless the body gives its own
  // The body gives its particles_per_cell; else it has the scene's default.
  bool own_particles_per_cell = false;
};

// A 3D camera of the `render` object: placed (eye and target, up optional) or a preset that
// frames the snow; either way an optional field of view.
struct SceneCamera {
  std::optional<std::string> preset;  // "front", "side", "three_quarter" or "top"; none: placed
  Vec3 eye{};                         // m
  Vec3 target{};                      // m, differs from eye
  Vec3 up{0, 1, 0};                   // the image's up direction
  std::optional<double> fov;          // vertical field of view, degrees in (0, 180)
};

// The scene's `render` object: how `snowsim run` draws it (docs/scene-format.md). A field left
// out takes the renderer's default; render/scene_render.h turns this into RenderSettings.
struct SceneRender {
  std::optional<int> width, height;                  // pixels, 16 to 8192
  std::optional<std::string> color_by;               // "white", "density", "speed" or "plastic"
  std::optional<double> sphere_radius;               // m in [0, 10]; 0: half the particle spacing
  std::optional<bool> grid;                          // draw the cell lines, walls and ground
  std::optional<bool> density_cells;                 // 2D: shade each cell by its density
  std::optional<SceneCamera> camera;                 // 3D; none: the three-quarter preset
  std::optional<std::array<double, 2>> color_range;  // the values the colour map spans, low < high
  std::optional<std::string> look;  // "studio" (dark background), "figure" or "volume"
  std::optional<Vec3> background;   // RGB, each in [0, 1]; none: the look's
  std::optional<bool> shadows;      // 3D: the key light casts shadows
  std::optional<bool> occlusion;    // 3D: ambient occlusion between spheres
};

// The scene's `output` object: when `snowsim run` writes checkpoints (docs/checkpoints.md). A
// field left out takes the run's default; the command-line options override both.
struct SceneOutput {
  std::optional<double> checkpoint_minutes;    // wall time between checkpoints; 0: not by time
  std::optional<int> checkpoint_every_frames;  // frames between checkpoints; 0: not by count
};

struct Scene {
  std::string file;  // where it was read from, for messages
  std::string name;
  std::string description;
  int dimension = 2;           // the dimension the simulation runs in
  int authored_dimension = 2;  // entries of grid.cells and of every vector in the file
  std::array<int, 3> cells{10, 12, 1};
  double cell_size = 0.01;
  Vec3 gravity{0, -9.81, 0};
  SolverType solver = SolverType::DensityHybrid;
  DensityHybridParams density_hybrid;
  MpmParams mpm;
  // MPM snow: the fields of the material preset the scene names (chunky if none) beneath its own
  // (sim/scene/material_presets.h). A Scene built in code has the paper's reference snow.
  std::string material_preset = "paper";
  SnowMaterial material;
  std::vector<ColliderParams> colliders;
  double dt = 0.001;      // time step (s)
  double duration = 1.0;  // simulated time (s)
  double fps = 50;        // frames written per simulated second
  // The particles per cell of every body that gives none: 9 in 2D, 27 in 3D unless the file says.
  int particles_per_cell = 9;
  // Jittered for scenes authored in 3D, else on the lattice, unless the file says; the seed makes
  // jittered and Poisson-disk seeding repeatable.
  Seeding seeding = Seeding::Lattice;
  int seed = 1;
  std::vector<Body> bodies;
  SceneRender render;
  SceneOutput output;

  Vec3 extent() const;
  int frameCount() const;  // frames after the initial one
};

// Reads a scene file, applies the overrides in order, then parses and validates it once. An
// override is "path=value" as given to --set: the path dotted (bodies.0.radius) or with indices
// (bodies[0].radius), the value JSON when it parses as JSON, else a string. Throws InputError
// naming the file and field, and the --set assignment when the field is one it set.
Scene loadScene(const std::string& path, const std::vector<std::string>& overrides = {});

// True when one of the overrides sets the field at `path` (dotted), a field inside it or an
// object holding it: what a program's own change to a scene must leave to the user.
bool overridesField(const std::vector<std::string>& overrides, const std::string& path);

// Typed changes to a parsed scene, for code that derives scenes from a scene (quality levels,
// the study's configurations): numbers keep every digit, and the scene stays valid (InputError
// naming the file and field otherwise).

// Sets the scene's particles per cell: the default and every body that gives none.
void setParticlesPerCell(Scene& scene, int count);

// `factor` times the cells of every authored axis, cell size / factor: the same domain, finer.
void refineGrid(Scene& scene, int factor);

// `factor` (> 0, e.g. 0.5 or 1.5) times the cells along every axis the scene runs in, the depth of
// a 2D scene's slab included, cell size / factor: the same domain, finer or coarser. Throws
// InputError unless every axis gets a whole number of cells from 1 to 4096.
void scaleGrid(Scene& scene, double factor);

// Throws InputError, naming the scene file, when `ranks` > 1 and the scene runs what is not
// distributed (the report's method, MPM's semi-implicit integrator): a caller checks it before it
// writes anything, the solvers again.
void refuseWhatIsNotDistributed(const Scene& scene, int ranks);

}  // namespace snowsim
