#include "app/render_sink.h"

#include <cstdio>
#include <optional>
#include <type_traits>

#include "app/options.h"
#include "sim/core/errors.h"

namespace snowsim {

void RenderOptions::addTo(CLI::App& command) {
  addImageOptionsTo(command);
  addOffFlag(command, "--no-png", png, "Do not write the per-frame PNG images");
  addOffFlag(command, "--no-mp4", mp4, "Do not encode the frames into an MP4 video");
  command.add_option("--mp4-fps", video_fps,
                     "Video frame rate (default: the scene's frames per second, real time)");
  command.add_option("--mp4-crf", video.crf, "Video quality, 0 (lossless) to 51 (worst)")
      ->capture_default_str();
  command
      .add_option("--mp4-codec", video.codec,
                  "auto (libx264 if present, else mpeg4) or a libavcodec encoder name")
      ->capture_default_str();
}

void RenderOptions::addImageOptionsTo(CLI::App& command) {
  command_ = &command;
  command.add_option("--width", width, "Image width in pixels (16 to 8192; default 1280)");
  command.add_option("--height", height, "Image height in pixels (16 to 8192; default 720)");
  command.add_option("--color-by,--colour-by", color_by,
                     "Particle colour: white, density, speed or plastic (MPM's J_P)");
  command.add_flag("--no-grid", no_grid, "Do not draw the simulation grid behind the particles");
  command.add_flag("--density-cells", density_cells,
                   "2D: shade the cells by density, amber at or above the critical density");
  command.add_option("--sphere-radius", sphere_radius,
                     "Sphere radius in metres (default: half the particle spacing)");
  command.add_option("--camera-eye", camera_eye, "3D camera position x,y,z (metres)")
      ->delimiter(',')
      ->expected(3);
  command.add_option("--camera-target", camera_target, "3D camera target x,y,z (metres)")
      ->delimiter(',')
      ->expected(3);
  command.add_option("--camera-up", camera_up, "3D camera up direction x,y,z (default 0,1,0)")
      ->delimiter(',')
      ->expected(3);
  command.add_option("--fov", fov, "3D camera vertical field of view, degrees (default 35)");
  command.add_option("--camera-preset", camera_preset,
                     "3D camera framing the snow: front, side, three_quarter (default) or top");
  command.add_option("--look", look,
                     "studio (dark background, default), figure (white, like a paper's figure), "
                     "surface (3D: the snow's surface in "
                     "place of its particles, loose grains as spheres) or volume (3D: the snow as "
                     "a lit density volume); docs/rendering.md");
  command.add_option("--background", background, "Background colour r,g,b, each 0 to 1")
      ->delimiter(',')
      ->expected(3);
  addOffFlag(command, "--no-shadows", shadows, "3D: the key light casts no shadows");
  addOffFlag(command, "--no-occlusion", occlusion, "3D: no ambient occlusion between spheres");
  command.add_flag("--supersample", supersample,
                   "3D: anti-alias the spheres by drawing at twice the width and height and "
                   "filtering down (smoother edges and finer lines, about three times the drawing "
                   "time; default: FXAA at the image's size; the surface look always is)");
  command.add_flag("--no-supersample", no_supersample,
                   "3D: FXAA at the image's size, for a run that was drawn with --supersample");
  command
      .add_option("--color-range,--colour-range", color_range,
                  "low,high: the values the colour map spans, fixed for every frame (default: "
                  "the scene's render.color_range, else a physical range; docs/rendering.md)")
      ->delimiter(',')
      ->expected(2);
  const SurfaceSettings d;
  auto fixed = [](double x) { return numberText(x); };
  command.add_option(
      "--surface-voxel", surface.voxel,
      "Surface: voxel side, a fraction of the cell (default " + fixed(d.voxel) + ")");
  command.add_option("--surface-radius", surface.radius,
                     "Surface: each particle's sphere radius, in particle spacings (default " +
                         fixed(d.radius) + ")");
  command.add_option("--surface-erode", surface.erode,
                     "Surface: how far the smoothed surface moves in, in particle spacings "
                     "(negative: out; default " +
                         fixed(d.erode) + ")");
  command.add_option("--surface-filter", surface_filter,
                     "Surface: smoothing filter, gaussian (default), mean-curvature or none");
  command.add_option("--surface-smoothing", surface.smoothing,
                     "Surface: filter iterations (default " + std::to_string(d.smoothing) + ")");
  command.add_option("--surface-adaptivity", surface.adaptivity,
                     "Surface: mesh adaptivity, 0 (uniform, default) to 1 (fewer, larger "
                     "triangles)");
  command.add_option("--surface-min-neighbours", surface.min_neighbours,
                     "Surface: particles with fewer others in the 3x3x3 cells around are loose "
                     "grains, drawn as spheres (default " +
                         std::to_string(d.min_neighbours) + ")");
}

bool RenderOptions::given(const char* name) const {
  return command_ && command_->count(name) > 0;
}

RenderSettings RenderOptions::settings(RenderSettings s) const {
  auto point = [](const std::vector<double>& v) { return std::array<double, 3>{v[0], v[1], v[2]}; };
  if (given("--width")) s.width = width;
  if (given("--height")) s.height = height;
  if (given("--color-by")) s.color_by = parseColorBy(color_by);
  if (no_grid) s.show_grid = false;
  if (density_cells) s.density_cells = true;
  if (given("--sphere-radius")) s.sphere_radius = sphere_radius;
  if (given("--camera-eye") != given("--camera-target") && !s.camera.custom)
    throw InputError(
        "--camera-eye and --camera-target: give both (or a render.camera in the scene)");
  if (choosesPreset() && placesCamera())
    throw InputError("--camera-preset frames the snow; it cannot go with --camera-eye/target");
  if (choosesPreset()) {
    s.camera.custom = false;
    s.camera.preset = parseCameraPreset(camera_preset, "--camera-preset");
  }
  if (given("--camera-eye")) s.camera.eye = point(camera_eye), s.camera.custom = true;
  if (given("--camera-target")) s.camera.target = point(camera_target), s.camera.custom = true;
  if (given("--camera-up")) s.camera.up = point(camera_up);
  if (given("--fov")) s.camera.fov_degrees = fov;
  if (given("--look")) s.look = parseLook(look);
  if (given("--background")) s.background = point(background);
  if (!shadows) s.shadows = false;
  if (!occlusion) s.occlusion = false;
  if (supersample && no_supersample)
    throw InputError("--supersample and --no-supersample: give one of them");
  if (supersample) s.supersample = true;
  if (no_supersample) s.supersample = false;
  if (givesColourRange()) s.color_range = ColourRange{color_range[0], color_range[1]};
  if (given("--surface-voxel")) s.surface.voxel = surface.voxel;
  if (given("--surface-radius")) s.surface.radius = surface.radius;
  if (given("--surface-erode")) s.surface.erode = surface.erode;
  if (given("--surface-filter"))
    s.surface.filter = parseSurfaceFilter(surface_filter, "--surface-filter");
  if (given("--surface-smoothing")) s.surface.smoothing = surface.smoothing;
  if (given("--surface-adaptivity")) s.surface.adaptivity = surface.adaptivity;
  if (given("--surface-min-neighbours")) s.surface.min_neighbours = surface.min_neighbours;
  validate(s);
  return s;
}

bool RenderOptions::placesCamera() const {
  return given("--camera-eye") || given("--camera-target");
}
bool RenderOptions::choosesPreset() const {
  return given("--camera-preset");
}
bool RenderOptions::givesColourRange() const {
  return given("--color-range");
}
bool RenderOptions::givesFov() const {
  return given("--fov");
}
bool RenderOptions::givesCameraUp() const {
  return given("--camera-up");
}

void RenderOptions::warnAboutUnused(int dimension) const {
  const std::vector<const char*> unused =
      dimension == 2
          ? std::vector<const char*>{"--camera-eye",   "--camera-target", "--camera-up",
                                     "--fov",          "--camera-preset", "--no-shadows",
                                     "--no-occlusion", "--supersample",   "--no-supersample"}
          : std::vector<const char*>{"--density-cells"};
  std::string names;
  for (const char* name : unused)
    if (given(name)) names += (names.empty() ? "" : ", ") + std::string(name);
  if (!names.empty())
    std::fprintf(stderr, "snowsim: warning: %s: not used for %dD frames, ignored\n", names.c_str(),
                 dimension);
}

nlohmann::json cameraJson(const Camera& camera) {
  return {{"eye", camera.eye},
          {"target", camera.target},
          {"up", camera.up},
          {"fov", camera.fov_degrees},
          {"preset", presetName(camera.preset)}};
}

Camera cameraFromJson(const nlohmann::json& json) {
  Camera camera;
  camera.custom = true;
  camera.eye = json.at("eye").get<std::array<double, 3>>();
  camera.target = json.at("target").get<std::array<double, 3>>();
  camera.up = json.at("up").get<std::array<double, 3>>();
  camera.fov_degrees = json.at("fov").get<double>();
  return camera;
}

nlohmann::json drawingJson(const RenderSettings& settings) {
  nlohmann::json j = {
      {"look", lookName(settings.look)},    {"sphere_radius", settings.sphere_radius},
      {"grid", settings.show_grid},         {"density_cells", settings.density_cells},
      {"shadows", settings.shadows},        {"occlusion", settings.occlusion},
      {"supersample", settings.supersample}};
  if (settings.background) j["background"] = *settings.background;
  const SurfaceSettings& surface = settings.surface;
  j["surface"] = {{"voxel", surface.voxel},
                  {"radius", surface.radius},
                  {"erode", surface.erode},
                  {"filter", surfaceFilterName(surface.filter)},
                  {"smoothing", surface.smoothing},
                  {"adaptivity", surface.adaptivity},
                  {"min_neighbours", surface.min_neighbours}};
  return j;
}

namespace {

// json[name] as a T, or an InputError naming where.name and what it holds instead; `fallback`,
// when given, stands for a missing field (one an older run.json did not record).
template <class T>
T field(const nlohmann::json& json, const char* name, const std::string& where,
        std::optional<T> fallback = std::nullopt) {
  if (!json.contains(name)) {
    if (fallback) return *fallback;
    throw InputError(where + "." + name + ": missing");
  }
  try {
    return json.at(name).get<T>();
  } catch (const nlohmann::json::exception&) {
    throw InputError(where + "." + name + ": " + json.at(name).dump() + " is not a " +
                     (std::is_same_v<T, bool>          ? "true or false"
                      : std::is_same_v<T, std::string> ? "string"
                      : std::is_same_v<T, int>         ? "whole number"
                      : std::is_arithmetic_v<T>        ? "number"
                                                       : "list of three numbers"));
  }
}

}  // namespace

void applyDrawing(const nlohmann::json& json, const std::string& where, RenderSettings& settings) {
  settings.look = parseLook(field<std::string>(json, "look", where), where + ".look");
  settings.sphere_radius = field<double>(json, "sphere_radius", where);
  settings.show_grid = field<bool>(json, "grid", where);
  settings.density_cells = field<bool>(json, "density_cells", where);
  settings.shadows = field<bool>(json, "shadows", where);
  settings.occlusion = field<bool>(json, "occlusion", where);
  settings.supersample =
      field<bool>(json, "supersample", where, false);  // not recorded before FXAA
  if (json.contains("background"))
    settings.background = field<std::array<double, 3>>(json, "background", where);
  if (json.contains("surface")) {
    const nlohmann::json& j = json.at("surface");
    const std::string at = where + ".surface";
    SurfaceSettings& surface = settings.surface;
    surface.voxel = field<double>(j, "voxel", at);
    surface.radius = field<double>(j, "radius", at);
    surface.erode = field<double>(j, "erode", at);
    surface.filter = parseSurfaceFilter(field<std::string>(j, "filter", at), at + ".filter");
    surface.smoothing = field<int>(j, "smoothing", at);
    surface.adaptivity = field<double>(j, "adaptivity", at);
    surface.min_neighbours = field<int>(j, "min_neighbours", at);
    validate(surface, at + ".");
  }
}

VideoSettings RenderOptions::videoSettings(double scene_fps, int image_width,
                                           int image_height) const {
  VideoSettings v = video;
  v.fps = given("--mp4-fps") ? video_fps : scene_fps;
  if (mp4) validate(v, image_width, image_height);
  return v;
}

RenderSink::RenderSink(const RenderSettings& settings, std::string png_dir,
                       const std::string& mp4_path, const VideoSettings& video, StageClock* clock)
    : png_dir_(std::move(png_dir)),
      clock_(clock),
      renderer_(settings),
      video_(mp4_path.empty() ? nullptr
                              : std::make_unique<VideoEncoder>(mp4_path, settings.width,
                                                               settings.height, video)),
      writer_(2, video_.get()) {}

void RenderSink::write(const Snapshot& snapshot) {
  Image image = [&] {
    const StageClock::Scope time(clock_, "render");
    return renderer_.render(snapshot);
  }();
  std::string png_path;
  if (!png_dir_.empty()) {
    char name[32];
    std::snprintf(name, sizeof name, "/frame_%05d.png", snapshot.frame);
    png_path = png_dir_ + name;
  }
  const StageClock::Scope time(clock_, "wait for encoding");
  writer_.write(std::move(png_path), std::move(image));  // encoded while the next frame runs
}

void RenderSink::addToVideo(Image image) {
  writer_.write("", std::move(image));
}

void RenderSink::flush() {
  const StageClock::Scope time(clock_, "wait for encoding");
  writer_.finish();
}

void RenderSink::finish() {
  const StageClock::Scope time(clock_, "wait for encoding");
  writer_.finish();
  if (video_) video_->finish();
}

}  // namespace snowsim
