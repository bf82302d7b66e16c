// snowsim figure NAME | SCENE.json: a strip of frames like the report's figures, either one of
// the report's (scenes/figures.json) or of any scene at chosen times.
#include <cstdio>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "app/commands.h"
#include "app/options.h"
#include "app/render_sink.h"
#include "render/colour.h"
#include "render/figure.h"
#include "render/renderer.h"
#include "render/scene_render.h"
#include "sim/core/errors.h"
#include "sim/io/files.h"
#include "sim/scene/json_fields.h"
#include "sim/simulation.h"

namespace snowsim {

namespace {

struct FigureOptions {
  std::string name;  // a figure of figures.json, or a scene file (ending in .json)
  std::string out = "out/figures";
  std::string figures;  // empty: the first of scenesPaths("scenes/figures.json") that exists
  std::vector<double> times;
  std::vector<std::string> overrides;
  std::string title;
  RenderOptions render;
  int threads = 0;  // the solver's threads; 0: the OpenMP default
};

// Panels of the report's size unless the scene or the command line gives one.
constexpr int kPanelWidth = 320, kPanelHeight = 352;

std::string figuresFile(const std::string& given) {
  if (!given.empty()) return given;
  return findInScenes("scenes/figures.json", "figure descriptions",
                      "give their file with --figures");
}

std::string timeLabel(const std::string& prefix, double t) {
  char text[64];
  std::snprintf(text, sizeof text, "%s%st = %.2f s", prefix.c_str(), prefix.empty() ? "" : "  ", t);
  return text;
}

// A figure's frames of one scene: its settings fitted to the scene, so that every panel of a row
// shares the camera and the colour range.
class SceneStrip {
 public:
  SceneStrip(const Scene& scene, const FigureOptions& options,
             const std::optional<ColourRange>& shared_range)
      : scene_(scene) {
    RenderSettings base = renderSettingsFromScene(scene.render);
    if (!scene.render.width) base.width = kPanelWidth;
    if (!scene.render.height) base.height = kPanelHeight;
    settings_ = options.render.settings(base);
    if (shared_range && !options.render.givesColourRange()) settings_.color_range = shared_range;
    if (settings_.color_by == ColorBy::Plastic && scene.solver != SolverType::Mpm)
      throw InputError("--color-by plastic: " + scene.file +
                       " runs the report's method, which has no plastic compression; allowed: "
                       "white, density, speed");
    simulation_ = makeSimulation(scene, options.threads);
    fitToScene(settings_, scene, simulation_->snapshot(0));
  }

  Image frameAt(double t) {
    simulation_->advanceTo(t);
    const Snapshot snapshot = simulation_->snapshot(0);
    if (!renderer_) {
      // A range still open (the report's density against its critical density) is fixed by the
      // first panel.
      if (!settings_.color_range && settings_.color_by != ColorBy::White)
        settings_.color_range = snowsim::colourRange(settings_, snapshot);
      renderer_ = std::make_unique<Renderer>(settings_);
    }
    return renderer_->render(snapshot);
  }

  std::optional<ColourBar> colourBar() const {
    if (settings_.color_by == ColorBy::White || !settings_.color_range) return std::nullopt;
    return ColourBar{colourLabel(settings_.color_by, scene_.dimension), settings_.color_range->low,
                     settings_.color_range->high, settings_.color_by == ColorBy::Plastic};
  }
  const std::optional<ColourRange>& colourRange() const { return settings_.color_range; }

 private:
  const Scene& scene_;
  RenderSettings settings_;
  std::unique_ptr<Simulation> simulation_;
  std::unique_ptr<Renderer> renderer_;
};

void writeFigure(const FigureOptions& options, const std::string& name,
                 const std::vector<std::vector<Panel>>& panels, const std::string& title,
                 const std::optional<ColourBar>& bar) {
  const std::string path = options.out + "/" + name + ".png";
  writePng(path, composeFigure(panels, title, bar));
  std::printf("%s\n", path.c_str());
}

// The strip of one scene file: its frames at the given times (default: four, from the start to
// the end of the run), titled with the scene's name.
void sceneFigure(const FigureOptions& options) {
  const Scene scene = loadScene(options.name, options.overrides);
  std::vector<double> times = options.times;
  if (times.empty())
    for (int i = 0; i < 4; ++i) times.push_back(scene.duration * i / 3);
  for (size_t i = 0; i < times.size(); ++i)
    if (times[i] < 0 || times[i] > scene.duration || (i > 0 && times[i] < times[i - 1]))
      throw InputError("--times: " + numberText(times[i]) +
                       " is not allowed; allowed: ascending times from 0 to the scene's "
                       "duration, " +
                       numberText(scene.duration) + " s");
  options.render.warnAboutUnused(scene.dimension);
  SceneStrip strip(scene, options, std::nullopt);
  prepareOutputDirectory(options.out);
  std::vector<std::vector<Panel>> panels(1);
  for (double t : times) panels[0].push_back({strip.frameAt(t), timeLabel("", t)});
  writeFigure(options, scene.name, panels, options.title.empty() ? scene.name : options.title,
              strip.colourBar());
}

void reportFigure(const FigureOptions& options) {
  if (!options.times.empty())
    throw InputError("--times: the report's figures have their own; give a scene file instead");
  const std::string figures_file = figuresFile(options.figures);
  const Json all = readJsonFile(figures_file);
  if (!all.is_object() || !all.contains(options.name)) {
    std::string names;
    for (auto it = all.begin(); it != all.end(); ++it)
      names += (names.empty() ? "" : ", ") + it.key();
    throw InputError(figures_file + ": no figure \"" + options.name + "\"; allowed: " + names);
  }
  JsonFields figure(all[options.name], options.name, figures_file);
  const std::string title = figure.string("title", "");
  const Json* rows = figure.array("rows", true);
  figure.finish();
  const std::string scene_dir = figures_file.substr(0, figures_file.find_last_of('/') + 1);

  // Every row's scene is read and its times checked before the output directory is made.
  struct Row {
    Scene scene;
    std::string label;
    std::vector<double> times;
  };
  std::vector<Row> strips;
  for (size_t r = 0; r < rows->size(); ++r) {
    JsonFields row((*rows)[r], options.name + ".rows[" + std::to_string(r) + "]", figures_file);
    const std::string scene_name = row.string("scene", std::nullopt);
    const std::string label = row.string("label", "");
    const std::vector<double> times = row.numbers("times", std::nullopt, {1, 2, 3, 4, 5, 6, 7, 8});
    Scene scene = loadScene(scene_dir + scene_name + ".json", options.overrides);
    for (const double t : times)
      if (t < 0 || t > scene.duration)
        row.fail("times", numberText(t) + " is not allowed; allowed: times from 0 to " +
                              scene_name + "'s duration, " + numberText(scene.duration) + " s");
    row.finish();
    strips.push_back({std::move(scene), label, times});
  }
  std::set<int> dimensions;
  for (const Row& row : strips)
    if (dimensions.insert(row.scene.dimension).second)
      options.render.warnAboutUnused(row.scene.dimension);

  prepareOutputDirectory(options.out);
  std::vector<std::vector<Panel>> panels;
  std::optional<ColourBar> bar;
  std::optional<ColourRange> range;  // the first row's, for every row
  for (size_t r = 0; r < strips.size(); ++r) {
    SceneStrip strip(strips[r].scene, options, range);
    panels.emplace_back();
    for (double t : strips[r].times)
      panels.back().push_back({strip.frameAt(t), timeLabel(strips[r].label, t)});
    if (r == 0) bar = strip.colourBar(), range = strip.colourRange();
  }
  writeFigure(options, options.name, panels, options.title.empty() ? title : options.title, bar);
}

void makeFigure(const FigureOptions& options) {
  const bool scene_file =
      options.name.size() > 5 && options.name.compare(options.name.size() - 5, 5, ".json") == 0;
  if (scene_file)
    sceneFigure(options);
  else
    reportFigure(options);
}

}  // namespace

void addFigureCommand(CLI::App& app) {
  auto options = std::make_shared<FigureOptions>();
  CLI::App* cmd = app.add_subcommand(
      "figure",
      "A strip of frames: one of the report's figures (fig1 ... fig8), or any scene's at chosen "
      "times");
  cmd->add_option("name", options->name,
                  "fig1, fig2, ..., fig8, or a scene file (SCENE.json, 2D or 3D)")
      ->required();
  cmd->add_option("-o,--out", options->out, "Output directory")->capture_default_str();
  cmd->add_option("--figures", options->figures,
                  "Figure descriptions (JSON); their scenes are read from the same directory. "
                  "Default: scenes/figures.json in the current directory, else beside the "
                  "executable (EXE_DIR/scenes/figures.json), else in an installation "
                  "(EXE_DIR/../share/snowsim/scenes/figures.json)");
  cmd->add_option("--times", options->times,
                  "A scene's frames: simulated times t1,t2,... in seconds, ascending (default: "
                  "four from the start to the end of the run)")
      ->delimiter(',');
  cmd->add_option("--set", options->overrides,
                  "Override a scene field by its path, as for `snowsim run` (repeatable)");
  cmd->add_option("--title", options->title,
                  "Title above the strip (default: the figure's, or the scene's name)");
  options->render.addImageOptionsTo(*cmd);
  addThreadsOption(*cmd, options->threads);
  cmd->footer(
      "Writes OUT/NAME.png (NAME: the figure's or the scene's name): the title, each row a "
      "scene, each panel a frame with its time under it, and a colour bar with units when "
      "--color-by (or the scene's render.color_by) colours by a value. Panels are 320x352 "
      "unless the scene's render object or --width/--height say otherwise.\n"
      "Exit codes: 0 done, 2 bad input.");
  cmd->callback([options] { makeFigure(*options); });
}

}  // namespace snowsim
