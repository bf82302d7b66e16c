// snowsim run SCENE: simulates a scene and writes its frames.
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <optional>

#include <nlohmann/json.hpp>

#include "app/collider_json.h"
#include "app/commands.h"
#include "app/cost_estimate.h"
#include "app/frame_sink.h"
#include "app/interrupt.h"
#include "app/memory_budget.h"
#include "app/options.h"
#include "app/progress.h"
#include "app/render_sink.h"
#include "app/run_checkpoint.h"
#include "app/run_directory.h"
#include "app/step_watch.h"
#include "render/colour.h"
#include "render/image.h"
#include "render/scene_render.h"
#include "sim/core/errors.h"
#include "sim/distributed/rank_exchange.h"
#include "sim/geometry/level_set.h"
#include "sim/geometry/snow_surface.h"
#include "sim/io/checkpoint.h"
#include "sim/io/files.h"
#include "sim/io/obj.h"
#include "sim/io/ply.h"
#include "sim/io/vdb.h"
#include "sim/scene/json_fields.h"
#include "sim/scene/resolve_scene.h"
#include "sim/scene/sampling.h"
#include "sim/scene/scene_colliders.h"
#include "sim/simulation.h"
#include "version.h"

namespace snowsim {

namespace {

struct RunOptions {
  std::string scene;
  std::string out = "out";
  std::vector<std::string> overrides;
  std::string quality;  // draft | figure | reference (sim/scene/quality.h); empty: as written
  double scale = 1;     // resolution factor (sim/scene/scale.h)
  bool estimate_only = false;  // --estimate: the cost and memory lines, no output
  std::string max_memory;      // --max-memory SIZE; empty: the memory available bounds a run
  int threads = 0;             // the solver's threads; 0: the OpenMP default
  std::string precision;       // double | float: mpm.precision; empty: the scene's
  bool ply = true;
  bool vdb = false;      // --vdb: frame_NNNNN.vdb density and velocity volumes (3D)
  bool surface = false;  // --surface: surface_NNNNN meshes, and the VDB's surface grid (3D)
  std::string surface_format = "ply";  // --surface-format: ply | obj
  bool z_up = false;       // --z-up: PLY and VDB turned to z up, (x, y, z) -> (x, -z, y)
  bool overwrite = false;  // remove an earlier run's files from `out` first
  RenderOptions render;
  // When to checkpoint, over the scene's output object: frames between checkpoints (0: not by
  // count) and wall time between them (0: not by time).
  std::optional<int> checkpoint_every;
  std::optional<double> checkpoint_minutes;
  std::vector<std::string> args;  // the command line after `run`, which resume parses again
};

// dir/PREFIXNNNNN.extension, PREFIX frame_ unless said.
std::string framePath(const std::string& dir, int frame, const std::string& extension,
                      const char* prefix = "frame_") {
  char name[48];
  std::snprintf(name, sizeof name, "/%s%05d.", prefix, frame);
  return dir + name + extension;
}

// Writes PREFIXNNNNN.EXT per frame with a writer of (path, snapshot, up axis): PLY, VDB or the
// surface's PLY.
class FileSink final : public FrameSink {
 public:
  using Writer = void (*)(const std::string&, const Snapshot&, UpAxis);
  // `stage`: a string literal (StageClock keeps the pointer), e.g. "write PLY".
  FileSink(std::string dir, std::string extension, Writer writer, UpAxis up, std::string_view stage,
           StageClock& clock, const char* prefix = "frame_")
      : dir_(std::move(dir)),
        extension_(std::move(extension)),
        prefix_(prefix),
        stage_(stage),
        writer_(writer),
        up_(up),
        clock_(clock) {}
  void write(const Snapshot& s) override {
    const StageClock::Scope time(&clock_, stage_);
    writer_(framePath(dir_, s.frame, extension_, prefix_), s, up_);
  }

 private:
  std::string dir_, extension_;
  const char* prefix_;
  std::string_view stage_;
  Writer writer_;
  UpAxis up_;
  StageClock& clock_;
};

// Where the run's wall time went, stage by stage: the solver's stages, then the main thread's own
// (setup, snapshots, PLY, rendering, waiting for encoding), each added to its time in `earlier`
// (the sessions before a resume, as stageTimes wrote them; stages new to this session follow).
nlohmann::json stageTimes(const Simulation& simulation, const StageClock& app,
                          nlohmann::json earlier) {
  nlohmann::json stages = std::move(earlier);
  const auto add = [&](const StageSeconds& s) {
    for (nlohmann::json& entry : stages)
      if (entry["stage"].get<std::string>() == s.stage) {
        entry["seconds"] = entry["seconds"].get<double>() + s.seconds;
        return;
      }
    stages.push_back({{"stage", s.stage}, {"seconds", s.seconds}});
  };
  for (const StageSeconds& s : simulation.stepStages()) add(s);
  for (const StageSeconds& s : app.stages()) add(s);
  return stages;
}

// The wall time and stage times of a run's sessions so far, which a checkpoint carries on
// (a killed session counts up to its last checkpoint).
struct SessionTimes {
  int sessions = 0;
  double wall = 0;
  nlohmann::json stages = nlohmann::json::array();

  // InputError naming the checkpoint when its record is not what toJson writes.
  static SessionTimes from(const SavedRun& saved) {
    SessionTimes t;
    if (!saved.run_state.contains("earlier_sessions")) return t;
    try {
      const nlohmann::json& e = saved.run_state["earlier_sessions"];
      t.sessions = e.at("sessions").get<int>();
      t.wall = e.at("wall_time").get<double>();
      for (const nlohmann::json& stage : e.at("stages"))
        t.stages.push_back({{"stage", stage.at("stage").get<std::string>()},
                            {"seconds", stage.at("seconds").get<double>()}});
    } catch (const nlohmann::json::exception&) {
      throw InputError(saved.file +
                       ": its record of the earlier sessions' times is not what "
                       "snowsim writes");
    }
    return t;
  }
  nlohmann::json toJson() const {
    return {{"sessions", sessions}, {"wall_time", wall}, {"stages", stages}};
  }
};

// Under mpirun: per rank, what it sent the others, a step on average and in all.
nlohmann::json rankSummary(const std::vector<RankTraffic>& ranks) {
  nlohmann::json list = nlohmann::json::array();
  for (const RankTraffic& t : ranks) {
    const double steps = std::max(1L, t.steps);
    list.push_back({{"halo_nodes_a_step", t.halo_nodes / steps},
                    {"halo_bytes_a_step", t.halo_bytes / steps},
                    {"particles_sent", t.particles_sent},
                    {"particle_bytes", t.particle_bytes},
                    {"rebalances", t.rebalances},
                    {"rebalances_that_moved_a_cut", t.moved_cuts}});
  }
  return list;
}

// A mesh collider whose box is too large for voxels of half a cell gets coarser ones: say so, as
// its details finer than them are lost.
void warnOfCoarseMeshColliders(const Scene& scene) {
  for (size_t i = 0; i < scene.colliders.size(); ++i) {
    const ColliderParams& c = scene.colliders[i];
    if (c.shape != ColliderShape::Mesh) continue;
    const double voxel = meshColliderVoxel(scene, c);
    if (voxel <= scene.cell_size / 2 * (1 + 1e-12)) continue;
    std::fprintf(stderr,
                 "snowsim: warning: %s: colliders[%zu] (%s): its distance field takes voxels of "
                 "%.3g mm, not half a cell (%.3g mm), as its box would need more than %ld of "
                 "them; its details finer than %.3g mm are lost\n",
                 scene.file.c_str(), i, c.mesh.file.c_str(), voxel * 1e3, scene.cell_size / 2 * 1e3,
                 LevelSet::kMaxVoxels, voxel * 1e3);
  }
}

// A collider that never moves and lies wholly outside the grid touches no snow: most likely a
// position in other units or a typo. Its bounding sphere about its origin, which its turning
// leaves alone, against the grid's box.
void warnOfCollidersOutsideTheGrid(const Scene& scene) {
  const Vec3 extent = scene.extent(), zero{0, 0, 0};
  const auto length = [](double x, double y, double z) { return std::sqrt(x * x + y * y + z * z); };
  for (size_t i = 0; i < scene.colliders.size(); ++i) {
    const ColliderParams& c = scene.colliders[i];
    const bool still = c.keyframes.empty() && c.velocity == zero && c.angular_velocity == zero;
    double reach = 0;
    if (c.shape == ColliderShape::Sphere) {
      reach = c.radius;
    } else if (c.shape == ColliderShape::Box) {
      reach = length(c.size[0], c.size[1], c.size[2]) / 2;
    } else if (c.shape == ColliderShape::Mesh) {
      for (const auto& v : c.mesh.placedAt(c.position).vertices)
        reach = std::max(reach,
                         length(v[0] - c.position[0], v[1] - c.position[1], v[2] - c.position[2]));
    } else {
      continue;  // a half space or a drum reaches across the grid
    }
    double outside2 = 0;  // squared distance from the position to the grid's box
    for (int a = 0; a < scene.authored_dimension; ++a) {
      const double d = std::max({0.0, -c.position[a], c.position[a] - extent[a]});
      outside2 += d * d;
    }
    if (!still || outside2 <= reach * reach) continue;
    std::fprintf(stderr,
                 "snowsim: warning: %s: colliders[%zu] lies wholly outside the grid (%.3g m "
                 "beyond it, %.3g m across at most) and never moves: it touches no snow\n",
                 scene.file.c_str(), i, std::sqrt(outside2) - reach, 2 * reach);
  }
}

// The particles and grid nodes up to which --estimate times the run's first steps on the scene
// itself; a larger scene's are timed on the scene at a coarser resolution (probeScene).
constexpr long kProbeParticles = 20000;
constexpr long kProbeNodes = 500000;

// The scene at `factor` (below 1) times its resolution, as --scale gives it but with the cells
// rounded up to whole ones (a domain at most a cell larger): the bodies, their particles per
// cell and everything tied to the cell follow.
Scene probeScene(Scene scene, double factor) {
  const double cell = scene.cell_size / factor;
  for (int a = 0; a < scene.dimension; ++a)
    if (a < scene.authored_dimension)
      scene.cells[a] = std::max(1, int(std::ceil(scene.cells[a] * scene.cell_size / cell - 1e-9)));
  scene.cell_size = cell;
  scene.dt /= factor;
  return scene;
}

// --estimate: the memory and the cost before the run, and the time of its first steps, from the
// scene itself where it is small, else from the scene at a resolution small enough to build at
// little cost: a large run's own arrays are never allocated. Writes nothing.
void estimateOnly(const Scene& scene, const RunMemory& memory, int threads, RankExchange& world) {
  const long particles = memory.simulation.particles;
  const double factor = std::min(
      {1.0, std::pow(double(kProbeParticles) / std::max(1L, particles), 1.0 / scene.dimension),
       std::pow(double(kProbeNodes) / memory.simulation.nodes, 1.0 / scene.dimension)});
  const Scene probe = factor < 1 ? probeScene(scene, factor) : scene;
  std::unique_ptr<Simulation> simulation;
  try {
    simulation = makeSimulation(probe, threads, world);
  } catch (const InputError& e) {  // its bodies too thin for the coarser cells
    CostEstimate estimate(scene, particles, StepLimit{});
    std::fprintf(stderr, "%s\n%s: its steps are not timed: at %.2g times its resolution: %s\n",
                 estimate.before().c_str(), scene.name.c_str(), factor, e.what());
    return;
  }
  // The first step follows the cell, as --scale's does.
  StepLimit start = simulation->stepLimit();
  start.step *= factor;
  CostEstimate estimate(scene, particles, start);
  std::fprintf(stderr, "%s\n", estimate.before().c_str());
  // A grid far larger than its snow leaves the probe too few particles for a rate that says
  // anything of the run's.
  if (factor < 1 && simulation->particleCount() < kProbeParticles / 20) {
    std::fprintf(stderr,
                 "%s: its steps are not timed: at %.2g times its resolution, which its grid of "
                 "%s nodes needs to be built at little cost, its snow is %d particles\n",
                 scene.name.c_str(), factor, roughCount(memory.simulation.nodes).c_str(),
                 simulation->particleCount());
    return;
  }
  if (factor < 1)
    std::fprintf(stderr,
                 "%s: timing its first steps at %.2g times its resolution (%d particles, "
                 "cells of %g m), not building the run's own arrays\n",
                 scene.name.c_str(), factor, simulation->particleCount(), probe.cell_size);
  std::string measured;
  simulation->advanceTo(probe.duration, [&] {
    measured = estimate.afterStep(*simulation);
    return !measured.empty();
  });
  if (!measured.empty()) std::fprintf(stderr, "%s\n", measured.c_str());
}

// How the frames are drawn, for `snowsim render` to reuse or change, whether or not this run
// draws them: the image size, the look and what is drawn, the 3D camera as placed and the
// colouring, fixed for the whole run.
void recordRendering(nlohmann::json& summary, const RenderSettings& render, const Scene& scene) {
  summary["image"] = {render.width, render.height};
  summary["drawing"] = drawingJson(render);
  if (scene.dimension == 3) summary["camera"] = cameraJson(placedCamera(render, scene.extent()));
  // White is the default; plastic needs an MPM run's J_P.
  if (render.color_by == ColorBy::White ||
      (render.color_by == ColorBy::Plastic && scene.solver != SolverType::Mpm))
    return;
  summary["color"] = {{"by", colorByName(render.color_by)}};
  if (render.color_range)
    summary["color"]["range"] = {render.color_range->low, render.color_range->high};
}

Scene resolvedScene(const RunOptions& options) {
  SceneOverrides overrides{options.overrides, options.quality, options.scale};
  if (!options.precision.empty())
    overrides.assignments.push_back("mpm.precision=" + options.precision);
  return resolveScene(options.scene, overrides);
}

// The frames an interrupted run wrote, into the video anew: a resumed run's MP4 holds each frame
// once. They are read back from the PNGs, or without PNGs drawn again from the PLY frames, as
// `snowsim render` draws them (the same images: a PLY holds what the drawing reads).
void replayFrames(const std::string& dir, int count, bool from_png, const Scene& scene,
                  RenderSink& sink) {
  for (int frame = 0; frame < count; ++frame) {
    const std::string path = framePath(dir, frame, from_png ? "png" : "ply");
    if (from_png) {
      sink.addToVideo(readPng(path));
      continue;
    }
    Snapshot snapshot = readPly(path);
    snapshot.colliders = collidersAt(scene, scene.dimension, snapshot.time);
    sink.write(snapshot);  // no PNG directory: into the video only
  }
}

// A checkpoint holds each rank's share of the state: it resumes across as many ranks as wrote it,
// which it records (one written before it did is left to the solver's own check).
void checkRanksOf(const SavedRun& saved, int ranks) {
  const nlohmann::json& wrote = saved.run_state.value("ranks", nlohmann::json());
  if (!wrote.is_number_integer() || wrote.get<int>() == ranks) return;
  const int n = wrote.get<int>();
  const std::string dir = std::filesystem::path(saved.file).parent_path().string();
  const std::string across = [](int r) {
    return r == 1 ? std::string("in one process") : "across " + std::to_string(r) + " MPI ranks";
  }(ranks);
  throw InputError(saved.file + ": written by a run " +
                   (n == 1 ? "in one process; resume it in one: snowsim resume " + dir
                           : "across " + std::to_string(n) +
                                 " MPI ranks; resume it across as many: mpirun -np " +
                                 std::to_string(n) + " snowsim resume " + dir) +
                   " (not " + across + ")");
}

// Every rank's refusal (`mine`, empty for none) refuses the run on every rank, with the message of
// the first rank that has one.
void refuseOnEveryRank(RankExchange& world, const std::string& mine) {
  const std::vector<std::string> messages = world.allGather(mine);
  for (size_t rank = 0; rank < messages.size(); ++rank)
    if (!messages[rank].empty())
      throw InputError(rank == 0 ? messages[rank]
                                 : "MPI rank " + std::to_string(rank) + ": " + messages[rank]);
}

// The scene as every rank read it: a rank that could not read it (no shared file system) refuses
// the run on every rank, with its message.
Scene sceneOnEveryRank(const RunOptions& options, RankExchange& world) {
  Scene scene;
  std::string unread;
  try {
    scene = resolvedScene(options);
  } catch (const InputError& e) {
    unread = e.what();
  }
  refuseOnEveryRank(world, unread);
  return scene;
}

// What a session of a run is asked for, checked before anything is written.
struct RunPlan {
  Scene scene;
  SessionTimes earlier;  // the sessions before a resume
  RenderSettings render;
  VideoSettings video;
  UpAxis up = UpAxis::Y;
  bool build_surface = false;  // each frame's surface, for --surface and the surface look
  SurfaceSettings surface;     // the render settings' with the run's threads
  std::string video_name;      // SCENE_NAME.mp4
  std::string resume_command;  // what continues the run when it stops short
  int first_frame = 0;         // the first frame this session writes
};

// The scene and every setting, checked before anything is written, with the warnings they call
// for.
RunPlan validatedRun(const RunOptions& options, const SavedRun* saved, RankExchange& world,
                     bool writes) {
  RunPlan plan;
  plan.scene =
      saved ? saved->scene
            : (world.ranks() > 1 ? sceneOnEveryRank(options, world) : resolvedScene(options));
  const Scene& scene = plan.scene;
  plan.earlier = saved ? SessionTimes::from(*saved) : SessionTimes{};
  if (saved) checkRanksOf(*saved, world.ranks());
  refuseWhatIsNotDistributed(scene, world.ranks());
  refuseBodiesNarrowerThanTheirParticles(scene);
  plan.render = options.render.settings(renderSettingsFromScene(scene.render));
  if (writes) options.render.warnAboutUnused(scene.dimension);
  if (plan.render.color_by == ColorBy::Plastic && scene.solver != SolverType::Mpm &&
      (options.render.png || options.render.mp4))
    throw InputError("--color-by plastic: " + scene.file +
                     " runs the report's method, which has no plastic compression; allowed: "
                     "white, density, speed (or --set solver=mpm)");
  plan.video = options.render.videoSettings(scene.fps, plan.render.width, plan.render.height);
  if (options.vdb && scene.dimension != 3)
    throw InputError("--vdb: " + scene.file + " runs in 2D; VDB volumes are written for 3D runs");
  if (options.surface && scene.dimension != 3)
    throw InputError("--surface: " + scene.file + " runs in 2D; surfaces are built for 3D runs");
  if (options.surface_format != "ply" && !options.surface)
    throw InputError("--surface-format " + options.surface_format +
                     ": no mesh is written without --surface; add it");
  plan.surface = plan.render.surface;
  plan.surface.threads = options.threads;
  plan.build_surface =
      scene.dimension == 3 && (options.surface || (plan.render.look == Look::Surface &&
                                                   (options.render.png || options.render.mp4)));
  plan.up = options.z_up ? UpAxis::Z : UpAxis::Y;
  warnOfCoarseMeshColliders(scene);
  warnOfCollidersOutsideTheGrid(scene);
  return plan;
}

// A resumed run's checks: its video's first frames are rebuilt from the frames written before
// the checkpoint, which must be there. Sets where the run goes on from.
void checkResumable(const RunOptions& options, SavedRun& saved, RunPlan& plan) {
  if (options.render.mp4 && !options.render.png && !options.ply)
    throw InputError(saved.file +
                     ": the run writes an MP4 but neither PNG nor PLY frames, from which resume "
                     "would rebuild the video's first frames; `" +
                     plan.resume_command + "` continues it without the video");
  plan.first_frame = saved.run_state["next_frame"].get<int>();
  if (!options.render.mp4) return;
  for (int frame = 0; frame < plan.first_frame; ++frame) {
    const std::string path = framePath(options.out, frame, options.render.png ? "png" : "ply");
    if (!std::filesystem::exists(path))
      throw InputError(path + ": missing, and the video's first frames are " +
                       "rebuilt from it; `" + plan.resume_command +
                       " --no-mp4` continues the run without the video");
  }
}

// Rank 0 handles the output directory, the others wait for its verdict.
template <class Handle>
void onTheOutputDirectory(RankExchange& world, bool writes, Handle&& handle) {
  std::string refused;
  if (writes) try {
      handle();
    } catch (const std::exception& e) {  // a file system error too
      refused = e.what();
    }
  if (world.maxOverRanks(refused.empty() ? 0 : 1) != 0) throw InputError(refused);
}

// The output directory made and locked until the run ends; one holding an earlier run is
// refused unless the run resumes or overwrites it.
void prepareOutput(const RunOptions& options, bool resumed, const std::string& video_name,
                   RankExchange& world, bool writes, std::optional<RunDirectoryLock>& lock) {
  onTheOutputDirectory(world, writes, [&] {
    prepareOutputDirectory(options.out);
    lock.emplace(options.out);
    if (!resumed && !options.overwrite) refuseEarlierRun(options.out, video_name);
  });
}

// Every rank samples every body, so a body that fills no particle is refused alike, before
// --overwrite removes an earlier run.
std::unique_ptr<Simulation> setUpSimulation(const RunOptions& options, const RunPlan& plan,
                                            bool resumed, RankExchange& world, bool writes,
                                            StageClock& clock) {
  const StageClock::Scope time(&clock, "setup");
  std::unique_ptr<Simulation> simulation = makeSimulation(plan.scene, options.threads, world);
  if (!resumed && options.overwrite)
    onTheOutputDirectory(world, writes, [&] { removeEarlierRun(options.out, plan.video_name); });
  return simulation;
}

// Where rank 0 writes each frame: PLY, VDB, and the renderer's PNG frames and video (into which
// a resumed run's earlier frames go first).
FrameSinks frameSinks(const RunOptions& options, const RunPlan& plan, StageClock& clock) {
  FrameSinks sinks;
  if (options.ply)
    sinks.push_back(
        std::make_unique<FileSink>(options.out, "ply", writePly, plan.up, "write PLY", clock));
  if (options.vdb)
    sinks.push_back(
        std::make_unique<FileSink>(options.out, "vdb", writeVdb, plan.up, "write VDB", clock));
  if (options.surface) {
    const bool obj = options.surface_format == "obj";
    FileSink::Writer write = [](const std::string& path, const Snapshot& s, UpAxis up) {
      writeSurfacePly(path, *s.surface, s, up);
    };
    if (obj)
      write = [](const std::string& path, const Snapshot& s, UpAxis up) {
        writeSurfaceObj(path, *s.surface, s, up);
      };
    sinks.push_back(std::make_unique<FileSink>(options.out, obj ? "obj" : "ply", write, plan.up,
                                               "write surface", clock, "surface_"));
  }
  if (options.render.png || options.render.mp4) {
    auto render_sink = std::make_unique<RenderSink>(
        plan.render, options.render.png ? options.out : "",
        options.render.mp4 ? options.out + "/" + plan.video_name : "", plan.video, &clock);
    if (options.render.mp4)
      replayFrames(options.out, plan.first_frame, options.render.png, plan.scene, *render_sink);
    sinks.push_back(std::move(render_sink));
  }
  return sinks;
}

// The video being encoded, VIDEO.part until the encoder finishes it: a second signal removes it
// (UnfinishedFile), and so does an error that ends the run before it is finished.
class PartialVideo {
 public:
  explicit PartialVideo(const std::string& video) : path_(video + ".part"), unfinished_(path_) {}
  ~PartialVideo() {
    std::error_code ignored;
    if (std::uncaught_exceptions() > exceptions_) std::filesystem::remove(path_, ignored);
  }
  PartialVideo(const PartialVideo&) = delete;
  PartialVideo& operator=(const PartialVideo&) = delete;

 private:
  std::string path_;
  UnfinishedFile unfinished_;
  int exceptions_ = std::uncaught_exceptions();
};

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// What the surfaces of a session's frames left to loose grains: the frame with the most.
struct SurfaceTally {
  int frames = 0;
  int worst_frame = -1;
  size_t loose = 0, particles = 0;
  int isolated = 0, smoothed_away = 0;

  void add(const SnowSurface& m, const Snapshot& s) {
    ++frames;
    if (worst_frame >= 0 && m.loose.size() <= loose) return;
    worst_frame = s.frame;
    loose = m.loose.size(), particles = s.position.size();
    isolated = m.isolated, smoothed_away = m.smoothed_away;
  }
  nlohmann::json toJson() const {
    return {{"frames", frames},
            {"most_loose",
             {{"frame", worst_frame},
              {"loose_grains", loose},
              {"particles", particles},
              {"isolated", isolated},
              {"smoothed_away", smoothed_away}}}};
  }
};

// A session's frames: steps to each frame and hands it to every sink, checkpoints at the
// cadence, and stops at the end of the step in which a signal comes (the frame it interrupts is
// not written, every earlier one is complete). Every rank stops at the same step, whichever got
// the signal.
class FrameLoop {
 public:
  FrameLoop(const RunOptions& options, const RunPlan& plan, const SavedRun* saved,
            Simulation& simulation, StageClock& clock, RankExchange& world, bool writes,
            std::chrono::steady_clock::time_point start, std::string& doing)
      : options_(options),
        plan_(plan),
        simulation_(simulation),
        clock_(clock),
        world_(world),
        writes_(writes),
        start_(start),
        doing_(doing),
        frames_(plan.scene.frameCount()),
        progress_(frames_, plan.scene.duration, isatty(STDERR_FILENO)),
        start_limit_(simulation.stepLimit()),
        estimate_(
            plan.scene, simulation.particleCount(), start_limit_,
            saved ? std::optional<CostEstimate::Resumed>({simulation.time(), simulation.steps()})
                  : std::nullopt),
        step_watch_(saved ? StepWatch(plan.scene, saved->run_state.at("step_watch"))
                          : StepWatch(plan.scene, estimate_.initialStep(), start_limit_)),
        cadence_(options.checkpoint_every.value_or(
                     plan.scene.output.checkpoint_every_frames.value_or(0)),
                 options.checkpoint_minutes.value_or(
                     plan.scene.output.checkpoint_minutes.value_or(kDefaultCheckpointMinutes))) {
    if (saved) progress_.resumedAt(simulation);
    if (const auto& forecast = estimate_.forecast())
      progress_.expectHardening(simulation.time() + std::max(0.0, forecast->impact_time),
                                forecast->hardened_step);
  }

  // Returns the frames written, those of the sessions before included.
  int run(FrameSinks& sinks) {
    announce();
    int written = plan_.first_frame;
    int frame = plan_.first_frame;
    const auto betweenSteps = [this] { return this->betweenSteps(); };
    for (; frame <= frames_ && !interrupted(); ++frame, ++written) {
      doing_ = "stepping to frame " + std::to_string(frame) + " of " + std::to_string(frames_);
      if (!simulation_.advanceTo(std::min(plan_.scene.duration, frame / plan_.scene.fps),
                                 betweenSteps))
        break;
      Snapshot snapshot;
      {
        const StageClock::Scope time(&clock_, "snapshot");
        snapshot = simulation_.snapshot(frame);
      }
      doing_ = "writing frame " + std::to_string(frame);
      if (plan_.build_surface && writes_) {
        const StageClock::Scope time(&clock_, "surface");
        snapshot.surface =
            std::make_shared<const SnowSurface>(buildSnowSurface(snapshot, plan_.surface));
        surfaces_.add(*snapshot.surface, snapshot);
      }
      for (auto& sink : sinks) sink->write(snapshot);
      progress_.frame(frame, simulation_);
      if (frame < frames_ && cadence_.due(written + 1)) {
        for (auto& sink : sinks) sink->flush();  // a checkpoint follows only complete frames
        checkpoint(frame + 1);
      }
    }
    for (auto& sink : sinks) sink->finish();
    // Stopped short: the state after the last step, from which resume lands on the same steps.
    if (written <= frames_)
      checkpoint(frame);
    else if (writes_)
      removeCheckpoints(options_.out);
    progress_.done();
    return written;
  }

  int frames() const { return frames_; }
  int stopSignal() const { return stop_signal_; }
  const SurfaceTally& surfaces() const { return surfaces_; }
  const StepWatch& stepWatch() const { return step_watch_; }

 private:
  void announce() {
    progress_.note(estimate_.before());
    if (world_.ranks() == 1) return;
    progress_.note(plan_.scene.name + ": split across " + std::to_string(world_.ranks()) +
                   " MPI ranks, rank 0 writing the output");
    if (mpirunMayKillTheCheckpoint())
      progress_.note(
          "snowsim: warning: stopped, mpirun kills the ranks 1 s after passing the stop on, "
          "likely before they write their checkpoint; launch it with --mca "
          "odls_base_sigkill_timeout 15 (seconds, a little more than a checkpoint takes) so "
          "that a stopped run can be resumed (docs/scale-out.md)");
  }

  bool interrupted() {
    stop_signal_ = static_cast<int>(world_.maxOverRanks(interruptSignal()));
    return stop_signal_ != 0;
  }

  bool betweenSteps() {
    for (const std::string& note :
         {estimate_.afterStep(simulation_), step_watch_.check(simulation_)})
      if (!note.empty()) progress_.note(note);
    progress_.step(simulation_);
    return interrupted();
  }

  // The run's own state beside the solver's; next_frame: the first frame not yet written.
  void checkpoint(int next_frame) {
    const StageClock::Scope time(&clock_, "checkpoint");
    doing_ = "writing a checkpoint";
    const SessionTimes& earlier = plan_.earlier;
    nlohmann::json state = {{"args", options_.args},
                            {"next_frame", next_frame},
                            {"step_watch", step_watch_.state()},
                            {"ranks", world_.ranks()}};
    state["earlier_sessions"] =
        SessionTimes{earlier.sessions + 1, earlier.wall + secondsSince(start_),
                     stageTimes(simulation_, clock_, earlier.stages)}
            .toJson();
    recordRendering(state, plan_.render, plan_.scene);
    if (writes_) {
      saveCheckpoint(options_.out, plan_.scene, simulation_, state, world_.ranks() > 1);
    } else {
      StateWriter rank_share([](const char*, std::size_t) {});  // which rank 0 gathers
      simulation_.saveState(rank_share);
    }
  }

  const RunOptions& options_;
  const RunPlan& plan_;
  Simulation& simulation_;
  StageClock& clock_;
  RankExchange& world_;
  const bool writes_;
  const std::chrono::steady_clock::time_point start_;
  std::string& doing_;  // what the loop is doing now, for the message of a failed allocation
  const int frames_;
  Progress progress_;
  const StepLimit start_limit_;
  CostEstimate estimate_;
  StepWatch step_watch_;
  CheckpointCadence cadence_;
  int stop_signal_ = 0;
  SurfaceTally surfaces_;
};

// A session of a run, once its output directory is ready: sets up the simulation and the
// sinks, runs the frames, records the run. `doing` says what it is doing, for the message of an
// allocation that fails.
void runSession(const RunOptions& options, RunPlan& plan, SavedRun* saved, RankExchange& world,
                bool writes, bool& alike, std::string& doing) {
  const Scene& scene = plan.scene;
  const auto start = std::chrono::steady_clock::now();
  StageClock clock;  // this thread's stages; the solver times its own
  const std::unique_ptr<Simulation> simulation =
      setUpSimulation(options, plan, saved != nullptr, world, writes, clock);
  FrameSinks sinks;
  {
    const StageClock::Scope time(&clock, "setup");
    alike = false;  // each rank reads its share of a checkpoint; rank 0 alone opens the outputs
    // From the initial state, resumed or not. Every rank takes part in the snapshot's gather;
    // only rank 0, which draws, gets the particles.
    fitToScene(plan.render, scene, simulation->snapshot(0));
    if (saved) {
      simulation->loadState(saved->solver_state, saved->file);
      std::string().swap(saved->solver_state);  // as large as the state: not kept for the run
    }
    doing = "setting up the drawing of its frames";
    if (writes) sinks = frameSinks(options, plan, clock);
  }
  std::optional<PartialVideo> partial_video;
  if (options.render.mp4 && writes) partial_video.emplace(options.out + "/" + plan.video_name);

  catchInterrupts();
  FrameLoop loop(options, plan, saved, *simulation, clock, world, writes, start, doing);
  const int written = loop.run(sinks);
  doing = "writing run.json";
  const int stop_signal = loop.stopSignal();
  const SessionTimes& earlier = plan.earlier;
  // A resumed run's times and step statistics are of all its sessions (the solver's state
  // carries the steps, their sizes and the solves on).
  const double wall = earlier.wall + secondsSince(start);
  nlohmann::json stages = stageTimes(*simulation, clock, earlier.stages);
  for (nlohmann::json& stage : stages) stage["share"] = stage["seconds"].get<double>() / wall;

  nlohmann::json summary = {{"scene", scene.name},
                            {"dimension", scene.dimension},
                            {"cell_size", scene.cell_size},
                            {"steps", simulation->steps()},
                            {"simulated_time", simulation->time()},
                            {"wall_time", wall},
                            {"particles", simulation->particleCount()},
                            {"frames", written},
                            {"fps", scene.fps},
                            {"stages", stages},
                            {"colliders", collidersToJson(collidersAt(scene, scene.dimension, 0))}};
  if (options.scale != 1) summary["scale"] = options.scale;
  summary["up_axis"] = options.z_up ? "z" : "y";
  if (options.vdb) summary["vdb"] = true;
  if (const SurfaceTally& surfaces = loop.surfaces(); surfaces.frames > 0) {
    summary["surface"] = surfaces.toJson();
    std::fprintf(stderr,
                 "snowsim: surface: at most %zu of %zu particles loose grains, drawn as spheres "
                 "(frame %d: %d isolated, %d smoothed away)\n",
                 surfaces.loose, surfaces.particles, surfaces.worst_frame, surfaces.isolated,
                 surfaces.smoothed_away);
  }
  if (saved) {
    summary["resumed_at_frame"] = plan.first_frame;
    summary["sessions"] = earlier.sessions + 1;
  }
  if (simulation->steps() > 0)
    summary["step_size"] = {{"smallest", simulation->chosenSteps().smallest},
                            {"largest", simulation->chosenSteps().largest},
                            {"mean", simulation->time() / double(simulation->steps())}};
  if (const SolveTally solves = simulation->statistics().implicit_solves; solves.solves > 0) {
    summary["implicit_solves"] = {{"solves", solves.solves},
                                  {"mean_iterations", double(solves.iterations) / solves.solves},
                                  {"most_iterations", solves.most_iterations},
                                  {"unconverged", solves.unconverged}};
    if (solves.unconverged > 0)
      std::fprintf(stderr,
                   "snowsim: warning: %s: %ld of %ld semi-implicit solves ended short of "
                   "mpm.tolerance (%g) within mpm.max_iterations (%d); run.json counts them\n",
                   scene.file.c_str(), solves.unconverged, solves.solves,
                   scene.mpm.implicit_tolerance, scene.mpm.implicit_max_iterations);
  }
  if (const SleepTally sleep = simulation->statistics().auto_sleep; sleep.particle_steps > 0)
    summary["auto_sleep"] = {
        {"asleep_share_of_particle_steps", double(sleep.asleep_steps) / sleep.particle_steps},
        {"asleep_share_at_end", double(sleep.asleep_now) / sleep.particles}};
  if (!loop.stepWatch().record().is_null()) summary["step_collapse"] = loop.stepWatch().record();
  recordRendering(summary, plan.render, scene);
  if (options.render.mp4) summary["video"] = plan.video_name;
  // What reproduces the run: the scene as run, how it was asked for, by which build.
  summary["resolved_scene"] = sceneToJson(scene);
  summary["overrides"] = options.overrides;
  summary["quality"] = options.quality;
  summary["snowsim"] = {{"version", SNOWSIM_VERSION}, {"commit", SNOWSIM_COMMIT}};
  summary["threads"] = options.threads > 0 ? options.threads : omp_get_max_threads();
  if (world.ranks() > 1)
    summary["ranks"] = rankSummary(gatherEach(world, simulation->statistics().rank_traffic));
  if (stop_signal) summary["interrupted_by_signal"] = stop_signal;
  if (writes && !scene.colliders.empty())
    writeFileAtomically(options.out + "/colliders.json",
                        colliderFramesJson(scene, written).dump(1) + "\n");
  if (writes) writeFileAtomically(options.out + "/run.json", summary.dump(2) + "\n");
  if (stop_signal)
    throw Interrupted(stop_signal, "interrupted after " + std::to_string(written) + " of " +
                                       std::to_string(loop.frames() + 1) +
                                       " frames; what was written is complete; " +
                                       plan.resume_command + " continues it");
}

// run, or resume from `saved` (the scene and state of a checkpoint of options.out): validate,
// prepare the output, set up the simulation and the sinks, run the frames, record the run.
// alike: set false once an error could be one rank's alone; until then an InputError is met by
// every rank at the same point (the scene, the settings, the output directory's agreed refusal,
// the solver's set-up, the agreed removal of an earlier run).
void run(const RunOptions& options, SavedRun* saved, bool& alike) {
  // Under mpirun every rank simulates its share; rank 0 alone writes and prints, the others'
  // stderr goes nowhere (an error they meet, rank 0 meets too).
  RankExchange& world = worldExchange();
  const bool writes = world.rank() == 0;
  if (!writes && !std::freopen("/dev/null", "w", stderr)) {
    alike = false;
    throw InputError("no /dev/null");
  }
  RunPlan plan = validatedRun(options, saved, world, writes);
  const Scene& scene = plan.scene;
  const std::optional<double> max_memory =
      options.max_memory.empty()
          ? std::nullopt
          : std::optional(parseMemorySize(options.max_memory, "--max-memory"));
  const bool draws = writes && (options.render.png || options.render.mp4);
  const RunMemory memory = runMemory(scene, countBodyParticles(scene),
                                     {options.render.png && draws, options.render.mp4 && draws,
                                      plan.render.width, plan.render.height});
  std::fprintf(stderr, "%s\n", memory.line().c_str());
  if (options.estimate_only) {
    try {
      refuseWhatCannotFit(memory, max_memory, options.max_memory);
    } catch (const InputError& e) {
      std::fprintf(stderr, "snowsim: warning: %s\n", e.what());
    }
    alike = false;  // it steps
    return estimateOnly(scene, memory, options.threads, world);
  }
  // Each rank holds the whole scene at first, and reads its own memory: one that cannot fit
  // refuses the run on every rank.
  std::string refused;
  try {
    refuseWhatCannotFit(memory, max_memory, options.max_memory);
  } catch (const InputError& e) {
    refused = e.what();
  }
  refuseOnEveryRank(world, refused);
  plan.video_name = scene.name + ".mp4";
  plan.resume_command =
      (world.ranks() > 1 ? "mpirun -np " + std::to_string(world.ranks()) + " " : std::string()) +
      "snowsim resume " + options.out +
      (options.render.mp4 && !options.render.png && !options.ply ? " --no-mp4" : "");
  if (saved) checkResumable(options, *saved, plan);
  std::optional<RunDirectoryLock> lock;  // held until the run ends
  prepareOutput(options, saved != nullptr, plan.video_name, world, writes, lock);
  std::string doing = "building the simulation";
  try {
    runSession(options, plan, saved, world, writes, alike, doing);
  } catch (const std::bad_alloc&) {
    const std::optional<double> available = availableMemory();
    throw OutOfMemory(scene.name + ": out of memory while " + doing +
                      ": the run was estimated to need about " + memoryText(memory.bytes()) +
                      " at its peak" +
                      (available ? ", " + memoryText(*available) + " is available now" : "") +
                      "; the frames written before are complete, the video is not written; a " +
                      "smaller --scale or grid.cells, or fewer particles_per_cell, take less");
  }
}

// The options of `snowsim run`; resume parses a run's recorded command line with them, its scene
// file no longer needed (the checkpoint holds the scene as run).
// Across ranks, an error one rank meets alone (rank 0's full disk) would leave the others waiting
// in their next exchange: it ends every rank, with the exit code of one process. One that every
// rank meets alike ends each normally, rank 0 with its message and exit code, which mpirun
// returns, the others quietly: MPI_Abort could end the launcher before it forwards the message.
// A signal needs none of this, as every rank stops at the same step.
void runOnEveryRank(const RunOptions& options, SavedRun* saved = nullptr) {
  bool alike = true;
  try {
    run(options, saved, alike);
  } catch (const Interrupted&) {
    throw;
  } catch (const std::exception& e) {
    RankExchange& world = worldExchange();
    const bool every_rank = alike && dynamic_cast<const InputError*>(&e);
    if (world.ranks() == 1 || (every_rank && world.rank() == 0)) throw;
    if (every_rank) std::exit(0);  // MPI_Finalize waits for rank 0 there
    world.abortAll(reportFailure(e));
  }
}

void addRunOptions(CLI::App* cmd, RunOptions* options, bool scene_must_exist) {
  CLI::Option* scene =
      cmd->add_option("scene", options->scene, "Scene file (JSON), e.g. scenes/snowball_drop.json")
          ->required();
  if (scene_must_exist) scene->check(CLI::ExistingFile);
  cmd->add_option("-o,--out", options->out,
                  "Output directory (created if missing); one holding an earlier run's files is "
                  "refused unless --overwrite")
      ->capture_default_str();
  cmd->add_flag("--overwrite", options->overwrite,
                "Remove an earlier run's frames, run.json, video and checkpoints from the output "
                "directory first (no other file)");
  cmd->add_option("--set", options->overrides,
                  "Override a scene field by its path, e.g. --set time.dt=0.01 "
                  "--set bodies.0.velocity=[1,0] or bodies[0].velocity=[1,0] (repeatable)");
  cmd->add_option("--quality", options->quality,
                  "draft | figure | reference: integrator, time step, particles per cell and "
                  "(MPM reference) cell size from the measured speed/accuracy front "
                  "(docs/study.md); --set overrides them");
  cmd->add_option("--scale", options->scale,
                  "Resolution: S times the cells along each axis, cells 1/S the size, the same "
                  "domain and bodies (about S^D times the particles); time.dt and the scene's "
                  "sphere radius follow the cell (docs/scene-format.md)");
  cmd->add_flag("--estimate", options->estimate_only,
                "Print the memory the run will need at its peak, its cost, and the time of its "
                "first 11 steps (of the scene at a coarser resolution when it is large, whose "
                "own arrays are then not allocated), then stop; writes nothing");
  cmd->add_option("--max-memory", options->max_memory,
                  "Refuse the run (exit code 2) when its estimated peak memory is more than SIZE, "
                  "e.g. 500M or 8G (K, M, G, T: powers of 1024); without it, more than the "
                  "memory available is refused")
      ->type_name("SIZE");
  addThreadsOption(*cmd, options->threads);
  cmd->add_option("--precision", options->precision,
                  "double | float: the precision of the MPM state and step (mpm.precision; "
                  "docs/performance.md); float runs the explicit integrator only")
      ->check(CLI::IsMember({"double", "float"}));
  addOffFlag(*cmd, "--no-ply", options->ply, "Do not write the per-frame PLY files");
  cmd->add_flag(
      "--vdb", options->vdb,
      "Also write frame_NNNNN.vdb per frame (3D runs): OpenVDB grids density (kg/m^3) and "
      "velocity (m/s) on voxels of the cell size, for volumetric rendering");
  cmd->add_flag(
      "--surface", options->surface,
      "Also write surface_NNNNN.ply (or .obj) per frame (3D runs): the snow's surface mesh, "
      "vertices with normals and triangles (settings: --surface-*), and with --vdb a "
      "level set grid `surface` in each VDB");
  cmd->add_option("--surface-format", options->surface_format,
                  "ply | obj: the file format of --surface's meshes (binary PLY, the default, "
                  "which the Blender loader reads; or Wavefront OBJ text, about 4 times larger)")
      ->check(CLI::IsMember({"ply", "obj"}));
  cmd->add_flag(
      "--z-up", options->z_up,
      "Write PLY, VDB and surface frames with z up, as Blender's z-up world expects (Houdini is y "
      "up, as snowsim): "
      "(x, y, z) -> (x, -z, y), a rotation about x (snowsim render reads them back)");
  options->render.addTo(*cmd);
  cmd->add_option("--checkpoint-every", options->checkpoint_every,
                  "Write a checkpoint (checkpoint.snowsim) every N frames, besides every "
                  "--checkpoint-minutes; `snowsim resume` continues from it (default: the "
                  "scene's output.checkpoint_every_frames, else 0: not by count)")
      ->check(zeroOrMore(true));
  cmd->add_option("--checkpoint-minutes", options->checkpoint_minutes,
                  "Write a checkpoint at the first frame after this much wall time (0: only "
                  "every --checkpoint-every frames and when stopped by a signal; default: the "
                  "scene's output.checkpoint_minutes, else 5)")
      ->check(zeroOrMore(false));
}

// snowsim resume DIR: the run in DIR continued from its checkpoint with its own command line.
// drop_video: the run goes on without its MP4 (resume --no-mp4), as if started with --no-mp4.
void resume(const std::string& dir, int threads, bool drop_video) {
  // Before its checkpoint, which a running run rewrites; by rank 0 alone, which takes the lock.
  if (launchedAsRankZero()) RunDirectoryLock::refuseIfHeld(dir);
  SavedRun saved = loadCheckpoint(dir);
  RunOptions options;
  CLI::App parser;
  addRunOptions(parser.add_subcommand("run"), &options, false);
  std::vector<std::string> args;
  try {
    args = saved.run_state["args"].get<std::vector<std::string>>();
    std::vector<std::string> reversed(args.rbegin(), args.rend());
    reversed.push_back("run");
    parser.parse(reversed);
  } catch (const std::exception& e) {
    throw InputError(saved.file + ": the run's command line it records does not parse (" +
                     e.what() + ")");
  }
  if (drop_video && options.render.mp4) {
    options.render.mp4 = false;
    args.push_back("--no-mp4");  // and so do later resumes
  }
  options.args = args;
  options.out = dir;
  if (threads > 0) options.threads = threads;
  runOnEveryRank(options, &saved);
}

}  // namespace

void addRunCommand(CLI::App& app) {
  auto options = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand("run", "Simulate a scene and write its frames to a directory");
  addRunOptions(cmd, options.get(), true);
  cmd->footer(
      "Writes frame_NNNNN.ply per frame (binary PLY: x y z vx vy vz density plastic_j (MPM) mass "
      "pscale id; docs/scene-format.md, \"Output files\"), frame_NNNNN.png "
      "(the particles as shaded spheres over the grid), SCENE_NAME.mp4 (those frames as a video) "
      "and run.json (steps, step sizes, simulated time, wall time and where it went stage by "
      "stage, particle count, dimension, cell size; a collapse of the time step and its cause; "
      "for a semi-implicit run, its linear solves: count, mean and most iterations, "
      "unconverged; how the frames are drawn, also when none are: image size, look, 3D camera, "
      "colouring and its range; to reproduce "
      "the run: the scene after --set, --quality and --scale, the overrides, the quality, the "
      "snowsim version and commit, the threads).\n"
      "Before the run starts it prints the particles, the grid and the particle-steps of the "
      "duration, and after the first steps an estimate of their time.\n"
      "A run writes checkpoint.snowsim every few minutes and when stopped by a signal; "
      "`snowsim resume DIR` continues it to the frames an uninterrupted run writes.\n"
      "Before anything is allocated it prints the memory the run will need at its peak, and "
      "refuses a run that needs more than is available or --max-memory.\n"
      "Exit codes: 0 done, 2 bad input or a run that cannot fit in memory, 3 the simulation "
      "diverged, 4 an internal error (a bug), 5 out of memory all the same (the frames written so "
      "far are complete), "
      "130/143 interrupted by Ctrl-C/SIGTERM (the frames and video written so far are complete; "
      "a second signal stops at once, leaving only complete files).");
  cmd->callback([options] {
    options->args = argumentsAfter("run");
    runOnEveryRank(*options);
  });
}

void addResumeCommand(CLI::App& app) {
  auto dir = std::make_shared<std::string>();
  auto threads = std::make_shared<int>(0);
  auto video = std::make_shared<bool>(true);
  CLI::App* cmd = app.add_subcommand(
      "resume", "Continue a stopped or killed run from the checkpoint in its output directory");
  cmd->add_option("dir", *dir, "The run's output directory (its --out)")->required();
  addThreadsOption(*cmd, *threads);
  addOffFlag(*cmd, "--no-mp4", *video,
             "Go on without the run's MP4 video, needed where the run writes neither PNG nor "
             "PLY frames to rebuild its first frames from (the video of the frames before the "
             "stop stays as it is)");
  cmd->footer(
      "Reads DIR/checkpoint.snowsim, which `snowsim run` writes every --checkpoint-minutes or "
      "--checkpoint-every frames and when stopped by Ctrl-C/SIGTERM, and continues the run with "
      "the scene and options it was started with: its frames are byte for byte those an "
      "uninterrupted run writes, the MP4 is rebuilt from the PNG (else PLY) frames already "
      "written. A "
      "missing, truncated or corrupted checkpoint, one of another snowsim version or of "
      "another scene than the run's is refused with exit code 2, before anything is written. "
      "Like a run, it first says what is left to simulate and, after its first steps, how long "
      "that will take.\n"
      "Exit codes: as `snowsim run`.");
  cmd->callback([dir, threads, video] { resume(*dir, *threads, !*video); });
}

}  // namespace snowsim
