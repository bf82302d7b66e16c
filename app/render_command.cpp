// snowsim render DIR: renders saved PLY frames again, e.g. with another colour or size.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <memory>

#include <nlohmann/json.hpp>

#include "app/collider_json.h"
#include "app/commands.h"
#include "app/render_sink.h"
#include "sim/core/errors.h"
#include "sim/io/files.h"
#include "sim/io/ply.h"

namespace snowsim {

namespace {

struct RenderCommandOptions {
  std::string frames;
  std::string out;
  RenderOptions render;
};

// The frame rate, scene name and colliders (at time 0) recorded by `snowsim run`, if the
// directory has its run.json.
void readRunSummary(const std::filesystem::path& dir, double& fps, std::string& name,
                    std::vector<SnapshotCollider>& colliders) {
  std::ifstream in(dir / "run.json");
  if (!in) return;
  const auto summary = nlohmann::json::parse(in, nullptr, false);
  if (summary.is_discarded()) return;
  fps = summary.value("fps", fps);
  name = summary.value("scene", name);
  if (summary.contains("colliders"))
    colliders = collidersFromJson(summary["colliders"], (dir / "run.json").string());
}

void renderFrames(const RenderCommandOptions& options) {
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(options.frames))
    if (entry.path().extension() == ".ply") files.push_back(entry.path());
  if (files.empty()) throw InputError(options.frames + ": no .ply frames in this directory");
  std::sort(files.begin(), files.end());
  double fps = 30;
  std::string name = "frames";
  std::vector<SnapshotCollider> colliders;
  readRunSummary(options.frames, fps, name, colliders);
  // Every setting is checked before anything is written.
  const RenderSettings settings = options.render.settings(RenderSettings{});
  if (settings.color_by == ColorBy::Plastic && readPly(files.front().string()).plastic_j.empty())
    throw InputError("--color-by plastic: " + files.front().string() +
                     " has no plastic compression (J_P); only MPM runs write it");
  const VideoSettings video = options.render.videoSettings(fps);
  const std::string out = options.out.empty() ? options.frames : options.out;
  prepareOutputDirectory(out);
  RenderSink sink(settings, options.render.png ? out : "",
                  options.render.mp4 ? out + "/" + name + ".mp4" : "", video);
  for (const auto& file : files) {
    Snapshot frame = readPly(file.string());
    for (const SnapshotCollider& c : colliders) frame.colliders.push_back(c.movedBy(frame.time));
    sink.write(frame);
  }
  sink.finish();
}

}  // namespace

void addRenderCommand(CLI::App& app) {
  auto options = std::make_shared<RenderCommandOptions>();
  CLI::App* cmd = app.add_subcommand(
      "render", "Render saved PLY frames (from `snowsim run`) to PNG images and an MP4");
  cmd->add_option("frames", options->frames, "Directory holding frame_NNNNN.ply files")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("-o,--out", options->out, "Output directory (default: the frames directory)");
  options->render.addTo(*cmd);
  cmd->footer("Exit codes: 0 done, 2 bad input.");
  cmd->callback([options] { renderFrames(*options); });
}

}  // namespace snowsim
