// snowsim figure NAME: regenerates one of the report's figures as a strip of frames from the
// scene files, as described in scenes/figures.json.
#include <cstdio>
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
  std::string figures = std::string(SNOWSIM_SOURCE_DIR) + "/scenes/figures.json";
};

std::string timeLabel(const std::string& prefix, double t) {
  char text[64];
  std::snprintf(text, sizeof text, "%s%st = %.2f s", prefix.c_str(), prefix.empty() ? "" : "  ", t);
  return text;
}

void makeFigure(const FigureOptions& options) {
  const Json all = readJsonFile(options.figures);
  if (!all.is_object() || !all.contains(options.name)) {
    std::string names;
    for (auto it = all.begin(); it != all.end(); ++it)
      names += (names.empty() ? "" : ", ") + it.key();
    throw InputError(options.figures + ": no figure \"" + options.name + "\"; allowed: " + names);
  }
  JsonFields figure(all[options.name], options.name, options.figures);
  figure.string("title", "");
  const Json* rows = figure.array("rows", true);
  figure.finish();
  const std::string scene_dir = options.figures.substr(0, options.figures.find_last_of('/') + 1);

  RenderSettings settings;
  settings.width = 320;
  settings.height = 352;
  validate(settings);
  prepareOutputDirectory(options.out);
  Renderer renderer(settings);
  std::vector<std::vector<Panel>> panels;
  for (size_t r = 0; r < rows->size(); ++r) {
    JsonFields row((*rows)[r], options.name + ".rows[" + std::to_string(r) + "]", options.figures);
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
  cmd->add_option("--figures", options->figures, "Figure descriptions (JSON)")
      ->capture_default_str();
  cmd->footer(
      "Writes OUT/NAME.png: each row a scene, each panel a frame with its time under it.\n"
      "Exit codes: 0 done, 2 bad input.");
  cmd->callback([options] { makeFigure(*options); });
}

}  // namespace snowsim
