// snowsim figure NAME: regenerates one of the report's figures as a strip of frames from the
// scene files, as described in scenes/figures.json.
#include <cstdio>
#include <filesystem>
#include <memory>

#include "app/commands.h"
#include "render/figure.h"
#include "render/renderer.h"
#include "sim/core/errors.h"
#include "sim/io/files.h"
#include "sim/scene/json_fields.h"
#include "sim/simulation.h"

namespace snowsim {

namespace {

struct FigureOptions {
  std::string name;
  std::string out = "out/figures";
  std::string figures;  // empty: the first of defaultFigurePaths() that exists
};

// Where figures.json is looked for without --figures: the current directory (a checkout of the
// sources), then beside the executable (the build tree, a moved binary with its scenes), then an
// installation's share directory.
std::vector<std::string> defaultFigurePaths() {
  std::vector<std::string> paths = {"scenes/figures.json"};
  std::error_code error;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    paths.push_back((exe.parent_path() / "scenes/figures.json").string());
    paths.push_back(
        (exe.parent_path().parent_path() / "share/snowsim/scenes/figures.json").string());
  }
  return paths;
}

std::string figuresFile(const std::string& given) {
  if (!given.empty()) return given;
  const std::vector<std::string> paths = defaultFigurePaths();
  std::string tried;
  for (const std::string& path : paths) {
    if (std::filesystem::exists(path)) return path;
    tried += (tried.empty() ? "" : ", ") + path;
  }
  throw InputError("no figure descriptions found (looked for " + tried +
                   "); give their file with --figures");
}

std::string timeLabel(const std::string& prefix, double t) {
  char text[64];
  std::snprintf(text, sizeof text, "%s%st = %.2f s", prefix.c_str(), prefix.empty() ? "" : "  ", t);
  return text;
}

void makeFigure(const FigureOptions& options) {
  const std::string figures_file = figuresFile(options.figures);
  const Json all = readJsonFile(figures_file);
  if (!all.is_object() || !all.contains(options.name)) {
    std::string names;
    for (auto it = all.begin(); it != all.end(); ++it)
      names += (names.empty() ? "" : ", ") + it.key();
    throw InputError(figures_file + ": no figure \"" + options.name + "\"; allowed: " + names);
  }
  JsonFields figure(all[options.name], options.name, figures_file);
  figure.string("title", "");
  const Json* rows = figure.array("rows", true);
  figure.finish();
  const std::string scene_dir = figures_file.substr(0, figures_file.find_last_of('/') + 1);

  RenderSettings settings;
  settings.width = 320;
  settings.height = 352;
  validate(settings);
  prepareOutputDirectory(options.out);
  Renderer renderer(settings);
  std::vector<std::vector<Panel>> panels;
  for (size_t r = 0; r < rows->size(); ++r) {
    JsonFields row((*rows)[r], options.name + ".rows[" + std::to_string(r) + "]", figures_file);
    const std::string scene_name = row.string("scene", std::nullopt);
    const std::string label = row.string("label", "");
    const std::vector<double> times = row.numbers("times", std::nullopt, {1, 2, 3, 4, 5, 6, 7, 8});
    row.finish();
    auto simulation = makeSimulation(loadScene(scene_dir + scene_name + ".json"));
    panels.emplace_back();
    for (double t : times) {
      simulation->advanceTo(t);
      panels.back().push_back({renderer.render(simulation->snapshot(0)), timeLabel(label, t)});
    }
  }
  const std::string path = options.out + "/" + options.name + ".png";
  writePng(path, composeFigure(panels));
  std::printf("%s\n", path.c_str());
}

}  // namespace

void addFigureCommand(CLI::App& app) {
  auto options = std::make_shared<FigureOptions>();
  CLI::App* cmd = app.add_subcommand(
      "figure", "Regenerate one of the report's figures (fig1 ... fig8) as a strip of frames");
  cmd->add_option("name", options->name, "Figure name: fig1, fig2, ..., fig8")->required();
  cmd->add_option("-o,--out", options->out, "Output directory")->capture_default_str();
  cmd->add_option("--figures", options->figures,
                  "Figure descriptions (JSON); their scenes are read from the same directory. "
                  "Default: scenes/figures.json in the current directory, else beside the "
                  "executable (EXE_DIR/scenes/figures.json), else in an installation "
                  "(EXE_DIR/../share/snowsim/scenes/figures.json)");
  cmd->footer(
      "Writes OUT/NAME.png: each row a scene, each panel a frame with its time under it.\n"
      "Exit codes: 0 done, 2 bad input.");
  cmd->callback([options] { makeFigure(*options); });
}

}  // namespace snowsim
