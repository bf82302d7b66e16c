// snowsim run SCENE: simulates a scene and writes its frames.
#include <omp.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "app/collider_json.h"
#include "app/commands.h"
#include "app/cost_estimate.h"
#include "app/frame_sink.h"
#include "app/interrupt.h"
#include "app/options.h"
#include "app/progress.h"
#include "app/quality.h"
#include "app/render_sink.h"
#include "app/run_directory.h"
#include "app/scale.h"
#include "app/step_watch.h"
#include "render/colour.h"
#include "render/scene_render.h"
#include "sim/core/collider.h"
#include "sim/core/errors.h"
#include "sim/io/files.h"
#include "sim/io/ply.h"
#include "sim/scene/json_fields.h"
#include "sim/simulation.h"
#include "version.h"

namespace snowsim {

namespace {

struct RunOptions {
  std::string scene;
  std::string out = "out";
  std::vector<std::string> overrides;
  std::string quality;  // draft | figure | reference (app/quality.h); empty: the scene as written
  double scale = 1;     // resolution factor (app/scale.h)
  bool estimate_only = false;  // --estimate: the cost lines from the first steps, no output
  int threads = 0;             // the solver's threads; 0: the OpenMP default
  std::string precision;       // double | float: mpm.precision; empty: the scene's
  bool ply = true;
  bool overwrite = false;  // remove an earlier run's files from `out` first
  RenderOptions render;
};

class PlySink final : public FrameSink {
 public:
  PlySink(std::string dir, StageClock& clock) : dir_(std::move(dir)), clock_(clock) {}
  void write(const Snapshot& s) override {
    const StageClock::Scope time(&clock_, "write PLY");
    char name[32];
    std::snprintf(name, sizeof name, "/frame_%05d.ply", s.frame);
    writePly(dir_ + name, s);
  }

 private:
  std::string dir_;
  StageClock& clock_;
};

// Where the run's wall time went, stage by stage, with each stage's share of it: the solver's
// stages, then the main thread's own (setup, snapshots, PLY, rendering, waiting for encoding).
nlohmann::json stageTimes(const Simulation& simulation, const StageClock& app, double wall) {
  nlohmann::json stages = nlohmann::json::array();
  const auto add = [&](const StageSeconds& s) {
    stages.push_back({{"stage", s.stage}, {"seconds", s.seconds}, {"share", s.seconds / wall}});
  };
  for (const StageSeconds& s : simulation.stepStages()) add(s);
  for (const StageSeconds& s : app.stages()) add(s);
  return stages;
}

// --estimate: the cost before the run and the time from its first steps; writes nothing.
void estimateOnly(const Scene& scene, int threads) {
  const auto simulation = makeSimulation(scene, threads);
  CostEstimate estimate(scene, simulation->particleCount(), simulation->stepLimit());
  std::fprintf(stderr, "%s\n", estimate.before().c_str());
  std::string measured;
  simulation->advanceTo(scene.duration, [&] {
    measured = estimate.afterStep(*simulation);
    return !measured.empty();
  });
  if (!measured.empty()) std::fprintf(stderr, "%s\n", measured.c_str());
}

// How the frames were drawn, for `snowsim render` to reuse or change: the 3D camera as placed
// and the colour range, fixed for the whole run.
void recordRendering(nlohmann::json& summary, const RenderSettings& render, const Scene& scene) {
  if (scene.dimension == 3) summary["camera"] = cameraJson(placedCamera(render, scene.extent()));
  if (render.color_by == ColorBy::White) return;
  summary["color"] = {{"by", colorByName(render.color_by)}};
  if (render.color_range)
    summary["color"]["range"] = {render.color_range->low, render.color_range->high};
}

void run(const RunOptions& options) {
  // Read and checked once, with the user's --set; the quality level (for the scene's solver and
  // dimension) then leaves alone what --set gave.
  checkQualityLevel(options.quality);
  std::vector<std::string> overrides = options.overrides;
  if (!options.precision.empty()) overrides.push_back("mpm.precision=" + options.precision);
  Scene scene = loadScene(options.scene, overrides);
  applyQuality(options.quality, overrides, scene);
  if (options.scale != 1) applyScale(options.scale, overrides, scene);
  // Every setting is checked before anything is written.
  RenderSettings render = options.render.settings(renderSettingsFromScene(scene.render));
  if (render.color_by == ColorBy::Plastic && scene.solver != SolverType::Mpm &&
      (options.render.png || options.render.mp4))
    throw InputError("--color-by plastic: " + scene.file +
                     " runs the report's method, which has no plastic compression; allowed: "
                     "white, density, speed (or --set solver=mpm)");
  const VideoSettings video = options.render.videoSettings(scene.fps);
  if (options.estimate_only) return estimateOnly(scene, options.threads);
  const std::string video_name = scene.name + ".mp4";
  prepareRunDirectory(options.out, video_name, options.overwrite);
  const auto start = std::chrono::steady_clock::now();
  StageClock clock;  // this thread's stages; the solver times its own
  std::unique_ptr<Simulation> simulation;
  FrameSinks sinks;
  {
    const StageClock::Scope time(&clock, "setup");
    simulation = makeSimulation(scene, options.threads);
    fitToScene(render, scene, simulation->snapshot(0));
    if (options.ply) sinks.push_back(std::make_unique<PlySink>(options.out, clock));
    if (options.render.png || options.render.mp4)
      sinks.push_back(std::make_unique<RenderSink>(
          render, options.render.png ? options.out : "",
          options.render.mp4 ? options.out + "/" + video_name : "", video, &clock));
  }

  catchInterrupts();
  const int frames = scene.frameCount();
  Progress progress(frames, scene.duration, isatty(STDERR_FILENO));
  const StepLimit start_limit = simulation->stepLimit();
  CostEstimate estimate(scene, simulation->particleCount(), start_limit);
  StepWatch step_watch(scene, estimate.initialStep(), start_limit);
  progress.note(estimate.before());
  int written = 0;
  // A signal stops the run at the end of the current step: the frame it interrupts is not
  // written, every earlier one is complete.
  const auto interrupted = [] { return interruptSignal() != 0; };
  const auto betweenSteps = [&] {
    for (const std::string& note : {estimate.afterStep(*simulation), step_watch.check(*simulation)})
      if (!note.empty()) progress.note(note);
    progress.step(*simulation);
    return interrupted();
  };
  for (int frame = 0; frame <= frames && !interrupted(); ++frame, ++written) {
    if (!simulation->advanceTo(std::min(scene.duration, frame / scene.fps), betweenSteps)) break;
    Snapshot snapshot;
    {
      const StageClock::Scope time(&clock, "snapshot");
      snapshot = simulation->snapshot(frame);
    }
    for (auto& sink : sinks) sink->write(snapshot);
    progress.frame(frame, *simulation);
  }
  for (auto& sink : sinks) sink->finish();
  progress.done();
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  nlohmann::json summary = {{"scene", scene.name},
                            {"dimension", scene.dimension},
                            {"cell_size", scene.cell_size},
                            {"steps", simulation->steps()},
                            {"simulated_time", simulation->time()},
                            {"wall_time", wall},
                            {"particles", simulation->particleCount()},
                            {"frames", written},
                            {"fps", scene.fps},
                            {"stages", stageTimes(*simulation, clock, wall)},
                            {"colliders", collidersToJson(collidersAt(scene, scene.dimension, 0))}};
  if (options.scale != 1) summary["scale"] = options.scale;
  if (simulation->steps() > 0)
    summary["step_size"] = {{"smallest", simulation->chosenSteps().smallest},
                            {"largest", simulation->chosenSteps().largest},
                            {"mean", simulation->time() / double(simulation->steps())}};
  if (const SolveTally solves = simulation->implicitSolves(); solves.solves > 0) {
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
  if (!step_watch.record().is_null()) summary["step_collapse"] = step_watch.record();
  if (options.render.png || options.render.mp4) recordRendering(summary, render, scene);
  if (options.render.mp4) summary["video"] = video_name;
  // What reproduces the run: the scene as run, how it was asked for, by which build.
  summary["resolved_scene"] = sceneToJson(scene);
  summary["overrides"] = options.overrides;
  summary["quality"] = options.quality;
  summary["snowsim"] = {{"version", SNOWSIM_VERSION}, {"commit", SNOWSIM_COMMIT}};
  summary["threads"] = options.threads > 0 ? options.threads : omp_get_max_threads();
  if (const int sig = interruptSignal()) summary["interrupted_by_signal"] = sig;
  if (!scene.colliders.empty())
    writeFileAtomically(options.out + "/colliders.json",
                        colliderFramesJson(scene, written).dump(1) + "\n");
  writeFileAtomically(options.out + "/run.json", summary.dump(2) + "\n");
  if (const int sig = interruptSignal())
    throw Interrupted(sig, "interrupted after " + std::to_string(written) + " of " +
                               std::to_string(frames + 1) +
                               " frames; what was written is complete");
}

}  // namespace

void addRunCommand(CLI::App& app) {
  auto options = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand("run", "Simulate a scene and write its frames to a directory");
  cmd->add_option("scene", options->scene, "Scene file (JSON), e.g. scenes/snowball_drop.json")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("-o,--out", options->out,
                  "Output directory (created if missing); one holding an earlier run's files is "
                  "refused unless --overwrite")
      ->capture_default_str();
  cmd->add_flag("--overwrite", options->overwrite,
                "Remove an earlier run's frames, run.json and video from the output directory "
                "first (no other file)");
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
                "Print the cost and time estimate from the first 11 steps, then stop; writes "
                "nothing");
  addThreadsOption(*cmd, options->threads);
  cmd->add_option("--precision", options->precision,
                  "double | float: the precision of the MPM state and step (mpm.precision; "
                  "docs/performance.md); float runs the explicit integrator only")
      ->check(CLI::IsMember({"double", "float"}));
  addOffFlag(*cmd, "--no-ply", options->ply, "Do not write the per-frame PLY files");
  options->render.addTo(*cmd);
  cmd->footer(
      "Writes frame_NNNNN.ply per frame (binary PLY: x y z vx vy vz density), frame_NNNNN.png "
      "(the particles as shaded spheres over the grid), SCENE_NAME.mp4 (those frames as a video) "
      "and run.json (steps, step sizes, simulated time, wall time and where it went stage by "
      "stage, particle count, dimension, cell size; a collapse of the time step and its cause; "
      "for a semi-implicit run, its linear solves: count, mean and most iterations, "
      "unconverged; the 3D camera and the colour range the frames were drawn with; to reproduce "
      "the run: the scene after --set, --quality and --scale, the overrides, the quality, the "
      "snowsim version and commit, the threads).\n"
      "Before the run starts it prints the particles, the grid and the particle-steps of the "
      "duration, and after the first steps an estimate of their time.\n"
      "Exit codes: 0 done, 2 bad input, 3 the simulation diverged, 130/143 interrupted by "
      "Ctrl-C/SIGTERM (the frames and video written so far are complete).");
  cmd->callback([options] { run(*options); });
}

}  // namespace snowsim
