// snowsim run SCENE: simulates a scene and writes its frames.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "app/commands.h"
#include "app/frame_sink.h"
#include "app/png_sink.h"
#include "app/quality.h"
#include "sim/errors.h"
#include "sim/files.h"
#include "sim/ply.h"
#include "sim/simulation.h"

namespace snowsim {

namespace {

struct RunOptions {
  std::string scene;
  std::string out = "out";
  std::vector<std::string> overrides;
  std::string quality;  // draft | figure | reference (app/quality.h); empty: the scene as written
  bool ply = true;
  bool png = true;
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

// One line redrawn in place on a terminal, nothing otherwise.
class Progress {
 public:
  explicit Progress(int total) : total_(total), enabled_(isatty(STDERR_FILENO)) {}
  void update(int frame, double time) {
    if (!enabled_) return;
    std::fprintf(stderr, "\rframe %d/%d  t = %.3f s", frame, total_, time);
    std::fflush(stderr);
  }
  void done() {
    if (enabled_) std::fprintf(stderr, "\n");
  }

 private:
  int total_;
  bool enabled_;
};

void run(const RunOptions& options) {
  // The quality level's settings first, so the user's --set still wins.
  std::vector<std::string> overrides = qualityOverrides(options.quality);
  overrides.insert(overrides.end(), options.overrides.begin(), options.overrides.end());
  const Scene scene = loadScene(options.scene, overrides);
  const RenderSettings render = options.render.settings();  // checked before anything is written
  prepareOutputDirectory(options.out);
  auto simulation = makeSimulation(scene);

  FrameSinks sinks;
  if (options.ply) sinks.push_back(std::make_unique<PlySink>(options.out));
  if (options.png) sinks.push_back(std::make_unique<PngSink>(options.out, render));

  const auto start = std::chrono::steady_clock::now();
  const int frames = scene.frameCount();
  Progress progress(frames);
  for (int frame = 0; frame <= frames; ++frame) {
    simulation->advanceTo(std::min(scene.duration, frame / scene.fps));
    const Snapshot snapshot = simulation->snapshot(frame);
    for (auto& sink : sinks) sink->write(snapshot);
    progress.update(frame, simulation->time());
  }
  for (auto& sink : sinks) sink->finish();
  progress.done();
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  nlohmann::json summary = {{"scene", scene.name},
                            {"dimension", scene.dimension},
                            {"steps", simulation->steps()},
                            {"simulated_time", simulation->time()},
                            {"wall_time", wall},
                            {"particles", simulation->particleCount()},
                            {"frames", frames + 1}};
  writeFileAtomically(options.out + "/run.json", summary.dump(2) + "\n");
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
                  "Override a scene field by its dotted path, e.g. --set time.dt=0.01 "
                  "--set bodies.0.velocity=[1,0] (repeatable)");
  cmd->add_option("--quality", options->quality,
                  "draft | figure | reference: time step and particles per cell from the "
                  "measured speed/accuracy front (docs/study.md); --set overrides them");
  cmd->add_flag("!--no-ply", options->ply, "Do not write the per-frame PLY files");
  cmd->add_flag("!--no-png", options->png, "Do not render the per-frame PNG images");
  options->render.addTo(*cmd);
  cmd->footer(
      "Writes frame_NNNNN.ply per frame (binary PLY: x y z vx vy vz density), frame_NNNNN.png "
      "(the particles as shaded spheres over the grid) and run.json "
      "(steps, simulated time, wall time, particle count, dimension).\n"
      "Exit codes: 0 done, 2 bad input, 3 the simulation diverged.");
  cmd->callback([options] { run(*options); });
}

}  // namespace snowsim
