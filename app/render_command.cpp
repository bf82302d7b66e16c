// snowsim render DIR: renders saved PLY frames again, e.g. with another colour or size.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>

#include <nlohmann/json.hpp>

#include "app/collider_json.h"
#include "app/commands.h"
#include "app/render_sink.h"
#include "app/run_directory.h"
#include "render/colour.h"
#include "sim/core/errors.h"
#include "sim/io/files.h"
#include "sim/io/ply.h"

namespace snowsim {

namespace {

struct RenderCommandOptions {
  std::string frames;
  std::string out;
  bool overwrite = false;
  RenderOptions render;
};

// What `snowsim run` recorded in the directory's run.json, if it has one.
struct RunSummary {
  double fps = 30;
  std::string name = "frames";
  int dimension = 3;  // unknown without run.json: frame the snow in case
  bool dimension_known = false;
  // How the run drew its frames, or would have: the image size, the 3D camera as placed, the
  // colouring (none recorded: white) and its range (none recorded: the renderer's default).
  std::optional<std::array<int, 2>> image;
  nlohmann::json drawing;  // drawingJson's; null: the defaults
  std::optional<Camera> camera;
  std::optional<ColorBy> colour_by;
  std::optional<ColourRange> colour_range;
  std::vector<SnapshotCollider> colliders;  // at time 0
  // colliders.json: the times of its frames and the colliders at each (empty: none written).
  std::vector<double> collider_times;
  std::vector<std::vector<SnapshotCollider>> collider_frames;

  // The colliders at `time`: colliders.json's nearest frame, else run.json's moved on.
  std::vector<SnapshotCollider> collidersAt(double time) const {
    if (collider_times.empty()) {
      std::vector<SnapshotCollider> moved;
      for (const SnapshotCollider& c : colliders) moved.push_back(c.movedBy(time));
      return moved;
    }
    size_t nearest = 0;
    for (size_t i = 1; i < collider_times.size(); ++i)
      if (std::abs(collider_times[i] - time) < std::abs(collider_times[nearest] - time))
        nearest = i;
    return collider_frames[nearest];
  }
};

void readColliderFrames(const std::filesystem::path& file, RunSummary& run) {
  std::ifstream in(file);
  if (!in) return;
  const auto json = nlohmann::json::parse(in, nullptr, false);
  if (json.is_discarded() || !json.contains("frames") || !json["frames"].is_array())
    throw InputError(file.string() + ": not a colliders file as snowsim run writes it");
  for (const nlohmann::json& frame : json["frames"]) {
    if (!frame.contains("time") || !frame["time"].is_number() || !frame.contains("colliders"))
      throw InputError(file.string() + ": frames: every frame needs a time and colliders");
    run.collider_times.push_back(frame["time"].get<double>());
    run.collider_frames.push_back(collidersFromJson(frame["colliders"], file.string()));
  }
}

// run.json's settings and colliders at time 0, where the run wrote one.
void readRunJson(const std::filesystem::path& dir, RunSummary& run) {
  std::ifstream in(dir / "run.json");
  if (!in) return;
  const auto summary = nlohmann::json::parse(in, nullptr, false);
  if (summary.is_discarded()) return;
  run.fps = summary.value("fps", run.fps);
  run.name = summary.value("scene", run.name);
  run.dimension = summary.value("dimension", run.dimension);
  run.dimension_known = summary.contains("dimension");
  const std::string file = (dir / "run.json").string();
  try {
    if (summary.contains("image")) run.image = summary["image"].get<std::array<int, 2>>();
    if (summary.contains("drawing")) {
      run.drawing = summary["drawing"];
      RenderSettings check;
      applyDrawing(run.drawing, file + ": drawing", check);
    }
    if (summary.contains("camera")) run.camera = cameraFromJson(summary["camera"]);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(file + ": image, drawing or camera: " + e.what());
  }
  if (run.image)
    for (const int side : *run.image)
      if (side < 16 || side > 8192)
        throw InputError(file + ": image: each side must be from 16 to 8192 pixels");
  if (summary.contains("color")) {
    const nlohmann::json& color = summary["color"];
    if (!color.is_object() || !color.contains("by") || !color["by"].is_string())
      throw InputError(file + ": color: needs \"by\", the quantity the frames are coloured by");
    run.colour_by = parseColorBy(color["by"].get<std::string>(), file + ": color.by");
    if (color.contains("range")) {
      const nlohmann::json& range = color["range"];
      if (!range.is_array() || range.size() != 2 || !range[0].is_number() ||
          !range[1].is_number() || !(range[0].get<double>() < range[1].get<double>()))
        throw InputError(file + ": color.range: must be [low, high] with low < high");
      run.colour_range = ColourRange{range[0].get<double>(), range[1].get<double>()};
    }
  }
  if (summary.contains("colliders"))
    run.colliders = collidersFromJson(summary["colliders"], (dir / "run.json").string());
}

// colliders.json is read with or without a run.json beside it (frames from another program).
RunSummary readRunSummary(const std::filesystem::path& dir) {
  RunSummary run;
  readRunJson(dir, run);
  readColliderFrames(dir / "colliders.json", run);
  return run;
}

// The snow's extent over all frames and the extremes of the colouring quantity: density and
// speed from 0 to the largest, J_P from the smallest to the largest (made symmetric in log
// about 1 by the caller).
void scanFrames(const std::vector<std::string>& files, ColorBy by, Bounds& bounds,
                ColourRange& range) {
  range = {by == ColorBy::Plastic ? 1e30 : 0, -1e30};
  for (const auto& file : files) {
    const Snapshot s = readPly(file);
    bounds.include(particleBounds(s));
    for (int i = 0; i < s.size(); ++i) {
      const double value = by == ColorBy::Density ? (s.density.empty() ? 0 : s.density[i])
                           : by == ColorBy::Speed
                               ? std::hypot(s.velocity[i][0], s.velocity[i][1], s.velocity[i][2])
                           : by == ColorBy::Plastic ? s.plastic_j[i]
                                                    : 0;
      range.low = std::min(range.low, value);
      range.high = std::max(range.high, value);
    }
  }
}

void renderFrames(const RenderCommandOptions& options) {
  if (!options.render.png && !options.render.mp4)
    throw InputError("--no-png and --no-mp4: nothing left to write; drop one of them");
  const std::vector<std::string> files = plyFramesIn(options.frames);
  const RunSummary run = readRunSummary(options.frames);
  // Every setting is checked before anything is written. What the command line does not give
  // comes from how the run drew its frames.
  RenderSettings run_drawing;
  if (run.image) run_drawing.width = (*run.image)[0], run_drawing.height = (*run.image)[1];
  if (!run.drawing.is_null()) applyDrawing(run.drawing, "run.json: drawing", run_drawing);
  if (run.colour_by) run_drawing.color_by = *run.colour_by;
  RenderSettings settings = options.render.settings(run_drawing);
  if (run.dimension_known) options.render.warnAboutUnused(run.dimension);
  const bool runs_colouring = run.colour_by && settings.color_by == *run.colour_by;
  if (runs_colouring && !options.render.givesColourRange()) settings.color_range = run.colour_range;
  if (settings.color_by == ColorBy::Plastic && readPly(files.front()).plastic_j.empty())
    throw InputError("--color-by plastic: " + files.front() +
                     " has no plastic compression (J_P); only MPM runs write it");
  // The run's own PNGs and video, or an earlier render's, are kept unless --overwrite says; said
  // once the options are checked, before the frames are read.
  const std::string out = options.out.empty() ? options.frames : options.out;
  const std::string video = options.render.mp4 ? run.name + ".mp4" : "";
  if (!options.overwrite) refuseEarlierRender(out, options.render.png, video);
  // The run's camera unless the command line places or frames one; a framing camera, and the
  // colour range of a quantity the run did not colour by, then come from every frame, so that
  // all are drawn alike.
  const bool reuse_camera =
      run.camera && !options.render.placesCamera() && !options.render.choosesPreset();
  if (reuse_camera) {
    const Camera given = settings.camera;
    settings.camera = *run.camera;
    if (options.render.givesFov()) settings.camera.fov_degrees = given.fov_degrees;
    if (options.render.givesCameraUp()) settings.camera.up = given.up;
  }
  // Every frame is read before the first image is written, also when nothing is taken from
  // them: a damaged one stops the command with nothing written.
  const bool scan_range =
      !options.render.givesColourRange() && !runs_colouring && settings.color_by != ColorBy::White;
  const bool frame_snow = run.dimension == 3 && !settings.camera.custom;
  Bounds bounds;
  ColourRange range;
  scanFrames(files, settings.color_by, bounds, range);
  if (frame_snow) settings.camera.frame = bounds;
  if (scan_range && settings.color_by == ColorBy::Plastic && range.low > 0)
    range = plasticRangeSpanning(range.low, range.high);
  if (scan_range && range.high > range.low) settings.color_range = range;
  const VideoSettings video_settings =
      options.render.videoSettings(run.fps, settings.width, settings.height);
  prepareOutputDirectory(out);
  if (options.overwrite) removeEarlierRender(out, options.render.png, video);
  RenderSink sink(settings, options.render.png ? out : "", video.empty() ? "" : out + "/" + video,
                  video_settings);
  for (const auto& file : files) {
    Snapshot frame = readPly(file);
    frame.colliders = run.collidersAt(frame.time);
    sink.write(frame);
  }
  sink.finish();
  std::string written = options.render.png ? "frame_NNNNN.png" : "";
  if (options.render.mp4) written += (written.empty() ? "" : " and ") + run.name + ".mp4";
  std::printf("%zu frames drawn into %s: %s\n", files.size(), out.c_str(), written.c_str());
}

}  // namespace

void addRenderCommand(CLI::App& app) {
  auto options = std::make_shared<RenderCommandOptions>();
  CLI::App* cmd = app.add_subcommand(
      "render", "Render saved PLY frames (from `snowsim run`) to PNG images and an MP4");
  cmd->add_option("frames", options->frames, "Directory holding frame_NNNNN.ply files")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("-o,--out", options->out,
                  "Output directory (default: the frames directory); one holding PNG frames or "
                  "the video this would write is refused unless --overwrite");
  cmd->add_flag("--overwrite", options->overwrite,
                "Remove the PNG frames and the video already in the output directory (the run's "
                "own or an earlier render's) first, and no other file");
  options->render.addTo(*cmd);
  cmd->footer(
      "The frames are drawn as the run drew them, or would have (run.json: the image size, the "
      "look and what is drawn, the camera and the colouring), unless the options above say "
      "otherwise; a quantity the run did not colour by takes a range over the extremes of all "
      "the frames.\nPNG frames or a video already in the output directory (the run's own too) "
      "are not written over: render elsewhere with --out, or pass --overwrite.\nExit codes: 0 "
      "done, 2 bad input (nothing written).");
  cmd->callback([options] { renderFrames(*options); });
}

}  // namespace snowsim
