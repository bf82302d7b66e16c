// snowsim render DIR: renders saved PLY frames again, e.g. with another colour or size.
#include <filesystem>
#include <fstream>
#include <memory>

#include <nlohmann/json.hpp>

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

// The frame rate and scene name recorded by `snowsim run`, if the directory has its run.json.
void readRunSummary(const std::filesystem::path& dir, double& fps, std::string& name) {
  std::ifstream in(dir / "run.json");
  if (!in) return;
  const auto summary = nlohmann::json::parse(in, nullptr, false);
  if (summary.is_discarded()) return;
  fps = summary.value("fps", fps);
  name = summary.value("scene", name);
}

void renderFrames(const RenderCommandOptions& options) {
  const std::vector<std::string> files = plyFramesIn(options.frames);
  double fps = 30;
  std::string name = "frames";
  readRunSummary(options.frames, fps, name);
  // Every setting is checked before anything is written.
  const RenderSettings settings = options.render.settings(RenderSettings{});
  if (settings.color_by == ColorBy::Plastic && readPly(files.front()).plastic_j.empty())
    throw InputError("--color-by plastic: " + files.front() +
                     " has no plastic compression (J_P); only MPM runs write it");
  const VideoSettings video = options.render.videoSettings(fps);
  const std::string out = options.out.empty() ? options.frames : options.out;
  prepareOutputDirectory(out);
  RenderSink sink(settings, options.render.png ? out : "",
                  options.render.mp4 ? out + "/" + name + ".mp4" : "", video);
  for (const auto& file : files) sink.write(readPly(file));
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
