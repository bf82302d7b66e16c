// snowsim run SCENE: simulates a scene and writes its frames.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "app/commands.h"
#include "app/frame_sink.h"
#include "app/interrupt.h"
#include "app/options.h"
#include "app/progress.h"
#include "app/quality.h"
#include "app/render_sink.h"
#include "render/scene_render.h"
#include "sim/core/errors.h"
#include "sim/io/files.h"
#include "sim/io/ply.h"
#include "sim/simulation.h"

namespace snowsim {

namespace {

struct RunOptions {
  std::string scene;
  std::string out = "out";
  std::vector<std::string> overrides;
  std::string quality;    // draft | figure | reference (app/quality.h); empty: the scene as written
  int threads = 0;        // the solver's threads; 0: the OpenMP default
  std::string precision;  // double | float: mpm.precision; empty: the scene's
  bool ply = true;
  RenderOptions render;
};

class PlySink final : public FrameSink {
 public:
  explicit PlySink(std::string dir) : dir_(std::move(dir)) {}
  void write(const Snapshot& s) override {
    char name[32];
    std::snprintf(name, sizeof name, "/frame_%05d.ply", s.frame);
    writePly(dir_ + name, s);
  }

 private:
  std::string dir_;
};

void run(const RunOptions& options) {
  // Read and checked once, with the user's --set; the quality level (for the scene's solver and
  // dimension) then leaves alone what --set gave.
  checkQualityLevel(options.quality);
  std::vector<std::string> overrides = options.overrides;
  if (!options.precision.empty()) overrides.push_back("mpm.precision=" + options.precision);
  Scene scene = loadScene(options.scene, overrides);
  applyQuality(options.quality, overrides, scene);
  // Every setting is checked before anything is written.
  const RenderSettings render = options.render.settings(renderSettingsFromScene(scene.render));
  if (render.color_by == ColorBy::Plastic && scene.solver != SolverType::Mpm &&
      (options.render.png || options.render.mp4))
    throw InputError("--color-by plastic: " + scene.file +
                     " runs the report's method, which has no plastic compression; allowed: "
                     "white, density, speed (or --set solver=mpm)");
  const VideoSettings video = options.render.videoSettings(scene.fps);
  prepareOutputDirectory(options.out);
  auto simulation = makeSimulation(scene, options.threads);

  FrameSinks sinks;
  if (options.ply) sinks.push_back(std::make_unique<PlySink>(options.out));
  if (options.render.png || options.render.mp4)
    sinks.push_back(std::make_unique<RenderSink>(
        render, options.render.png ? options.out : "",
        options.render.mp4 ? options.out + "/" + scene.name + ".mp4" : "", video));

  catchInterrupts();
  const auto start = std::chrono::steady_clock::now();
  const int frames = scene.frameCount();
  Progress progress(frames, scene.duration, isatty(STDERR_FILENO));
  int written = 0;
  // A signal stops the run at the end of the current step: the frame it interrupts is not
  // written, every earlier one is complete.
  const auto interrupted = [] { return interruptSignal() != 0; };
  const auto betweenSteps = [&] {
    progress.step(*simulation);
    return interrupted();
  };
  for (int frame = 0; frame <= frames && !interrupted(); ++frame, ++written) {
    if (!simulation->advanceTo(std::min(scene.duration, frame / scene.fps), betweenSteps)) break;
    const Snapshot snapshot = simulation->snapshot(frame);
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
                            {"fps", scene.fps}};
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
  if (const int sig = interruptSignal()) summary["interrupted_by_signal"] = sig;
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
  cmd->add_option("-o,--out", options->out, "Output directory (created if missing)")
      ->capture_default_str();
  cmd->add_option("--set", options->overrides,
                  "Override a scene field by its path, e.g. --set time.dt=0.01 "
                  "--set bodies.0.velocity=[1,0] or bodies[0].velocity=[1,0] (repeatable)");
  cmd->add_option("--quality", options->quality,
                  "draft | figure | reference: integrator, time step, particles per cell and "
                  "(MPM reference) cell size from the measured speed/accuracy front "
                  "(docs/study.md); --set overrides them");
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
      "and run.json (steps, simulated time, wall time, particle count, dimension, cell size; for a "
      "semi-implicit run, its linear solves: count, mean and most iterations, unconverged).\n"
      "Exit codes: 0 done, 2 bad input, 3 the simulation diverged, 130/143 interrupted by "
      "Ctrl-C/SIGTERM (the frames and video written so far are complete).");
  cmd->callback([options] { run(*options); });
}

}  // namespace snowsim
