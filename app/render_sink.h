// Rendering frames to images and a video, shared by `snowsim run` and `snowsim render`: each
// snapshot is rendered once and handed to the PNG sequence and the MP4 encoder.
#pragma once

#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "app/frame_sink.h"
#include "app/frame_writer.h"
#include "render/renderer.h"
#include "render/video_encoder.h"
#include "sim/core/stage_clock.h"

namespace snowsim {

// The image and video options of the command line. Those given override the scene's `render`
// object (render/scene_render.h), which overrides the defaults.
struct RenderOptions {
  int width = 1280;
  int height = 720;
  std::string color_by = "white";
  bool no_grid = false;
  bool density_cells = false;
  double sphere_radius = 0;
  std::vector<double> camera_eye, camera_target, camera_up;
  double fov = 35;
  std::string look = "studio";
  std::vector<double> background;
  bool shadows = true;
  bool occlusion = true;
  bool supersample = false;
  bool no_supersample = false;
  std::string camera_preset;
  std::vector<double> color_range;
  SurfaceSettings surface;  // --surface-*: how the surface look and --surface build the surface
  std::string surface_filter = "gaussian";
  bool png = true;
  bool mp4 = true;
  VideoSettings video;
  double video_fps = 0;  // when --mp4-fps is given; else the scene's frame rate

  // The image options (size, colouring, grid, camera) and the PNG/MP4 outputs' options.
  void addTo(CLI::App& command);
  void addImageOptionsTo(CLI::App& command);
  // Whether the command line places the camera, chooses a preset, or fixes the colour range.
  bool placesCamera() const;
  bool choosesPreset() const;
  bool givesColourRange() const;
  bool givesFov() const;
  bool givesCameraUp() const;
  // The scene's settings with the options given on the command line applied; throws InputError
  // for a bad value.
  RenderSettings settings(RenderSettings scene) const;
  // A warning on stderr naming the options given that frames of this dimension do not use (the
  // camera's and the 3D lighting's in 2D, --density-cells in 3D), so that none is ignored
  // silently.
  void warnAboutUnused(int dimension) const;
  // The video settings for frames simulated at scene_fps, drawn at width x height (the image
  // settings' size); checked (InputError) when MP4 is on.
  VideoSettings videoSettings(double scene_fps, int width, int height) const;

 private:
  bool given(const char* name) const;
  CLI::App* command_ = nullptr;
};

// A camera as run.json records it (eye, target, up, fov, preset) and back.
nlohmann::json cameraJson(const Camera& camera);
Camera cameraFromJson(const nlohmann::json& json);
// What is drawn beside the snow and how, as run.json records it ("drawing": look, background,
// sphere radius, grid, density cells, shadows, occlusion, the surface's settings), and back onto
// settings (a run.json without the surface's keeps the defaults). Reading throws
// nlohmann's exceptions for a missing or mistyped field and InputError (naming `where`) for a bad
// value.
nlohmann::json drawingJson(const RenderSettings& settings);
void applyDrawing(const nlohmann::json& json, const std::string& where, RenderSettings& settings);

class RenderSink final : public FrameSink {
 public:
  // png_dir empty: no PNG sequence; mp4_path empty: no video. clock: if given, takes the time
  // this thread spends rendering ("render") and waiting for the encoder thread ("wait for
  // encoding", when it falls behind, and at the end).
  RenderSink(const RenderSettings& settings, std::string png_dir, const std::string& mp4_path,
             const VideoSettings& video, StageClock* clock = nullptr);
  void write(const Snapshot& snapshot) override;
  // An image already drawn, into the video only (resume replays a run's earlier frames).
  void addToVideo(Image image);
  void flush() override;
  void finish() override;

 private:
  std::string png_dir_;
  StageClock* clock_;
  Renderer renderer_;
  std::unique_ptr<VideoEncoder> video_;
  BackgroundFrameWriter writer_;  // after video_: its thread ends before the encoder does
};

}  // namespace snowsim
