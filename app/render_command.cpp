// snowsim render DIR: renders saved PLY frames again, e.g. with another colour or size.
#include <algorithm>
#include <filesystem>
#include <memory>

#include "app/commands.h"
#include "app/png_sink.h"
#include "sim/errors.h"
#include "sim/files.h"
#include "sim/ply.h"

namespace snowsim {

namespace {

struct RenderCommandOptions {
  std::string frames;
  std::string out;
  RenderOptions render;
};

void renderFrames(const RenderCommandOptions& options) {
  const RenderSettings settings = options.render.settings();
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(options.frames))
    if (entry.path().extension() == ".ply") files.push_back(entry.path());
  if (files.empty()) throw InputError(options.frames + ": no .ply frames in this directory");
  std::sort(files.begin(), files.end());
  const std::string out = options.out.empty() ? options.frames : options.out;
  prepareOutputDirectory(out);
  PngSink sink(out, settings);
  for (const auto& file : files) sink.write(readPly(file.string()));
}

}  // namespace

void addRenderCommand(CLI::App& app) {
  auto options = std::make_shared<RenderCommandOptions>();
  CLI::App* cmd =
      app.add_subcommand("render", "Render saved PLY frames (from `snowsim run`) to PNG images");
  cmd->add_option("frames", options->frames, "Directory holding frame_NNNNN.ply files")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("-o,--out", options->out, "Output directory (default: the frames directory)");
  options->render.addTo(*cmd);
  cmd->footer("Exit codes: 0 done, 2 bad input.");
  cmd->callback([options] { renderFrames(*options); });
}

}  // namespace snowsim
