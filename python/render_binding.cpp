// snowsim.render, write_png and diff: a simulation's frame drawn as `snowsim run` draws it, its
// options those of the command line, and the comparison `snowsim diff` makes.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <CLI/CLI.hpp>

#include "app/render_sink.h"
#include "python/bindings.h"
#include "render/image_diff.h"
#include "render/scene_render.h"

namespace snowsim {

namespace {

// True or False, Python's or numpy's.
bool isBoolean(const py::handle& value) {
  return py::isinstance<py::bool_>(value) ||
         py::isinstance(value, py::module_::import("numpy").attr("bool_"));
}

// A keyword argument as the command line's option: look="figure" is --look figure, a sequence is
// joined with commas (camera_eye=(0.3, 0.2, 0.4)), True is the flag (no_grid=True), False the flag
// that turns it off (shadows=False is --no-shadows).
void appendOption(const CLI::App& app, const std::string& key, const py::handle& value,
                  std::vector<std::string>& args) {
  std::string name = "--" + key;
  std::replace(name.begin(), name.end(), '_', '-');
  const CLI::Option* option = app.get_option_no_throw(name);
  if (isBoolean(value)) {
    const bool on = value.cast<bool>();
    if (option && option->get_items_expected_min() > 0)
      throw py::type_error("render: " + key + ": " + py::repr(value).cast<std::string>() +
                           " is not a value; it takes " + option->get_type_name());
    if (option) {
      if (on) args.push_back(name);
    } else if (app.get_option_no_throw("--no-" + name.substr(2))) {
      if (!on) args.push_back("--no-" + name.substr(2));
    } else {
      args.push_back(name);  // unknown: the parser names it
    }
    return;
  }
  args.push_back(name);
  const auto text = [&](const py::handle& item) {
    if (isBoolean(item))
      throw py::type_error("render: " + key + ": " + py::repr(item).cast<std::string>() +
                           " is not a number");
    // Any number, numpy's among them (float32 is no Python float), as the command line's text.
    const py::module_ numbers = py::module_::import("numbers");
    if (py::isinstance(item, numbers.attr("Integral")))
      return py::str(py::int_(py::reinterpret_borrow<py::object>(item))).cast<std::string>();
    if (py::isinstance(item, numbers.attr("Real"))) {
      const double number = py::float_(py::reinterpret_borrow<py::object>(item)).cast<double>();
      if (!std::isfinite(number))
        throw py::value_error("render: " + key + ": " + py::repr(item).cast<std::string>() +
                              " is not a finite number");
      return py::str(py::float_(number)).cast<std::string>();
    }
    return py::str(item).cast<std::string>();
  };
  if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value) ||
      py::isinstance<py::array>(value)) {
    std::string joined;
    for (const py::handle& item : value) joined += (joined.empty() ? "" : ",") + text(item);
    args.push_back(joined);
  } else {
    args.push_back(text(value));
  }
}

// The settings `snowsim run` would draw this scene's frames with, given these options.
RenderSettings renderSettings(const Scene& scene, const Snapshot& first, int width, int height,
                              const py::kwargs& options) {
  CLI::App app("snowsim.render");
  RenderOptions parsed;
  parsed.addImageOptionsTo(app);
  std::vector<std::string> args{"--width", std::to_string(width), "--height",
                                std::to_string(height)};
  for (const auto& [key, value] : options) appendOption(app, key.cast<std::string>(), value, args);
  std::reverse(args.begin(), args.end());  // CLI11 takes them last first
  try {
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    throw py::value_error(std::string("render: ") + e.what());
  }
  RenderSettings settings = parsed.settings(renderSettingsFromScene(scene.render));
  fitToScene(settings, scene, first);
  return settings;
}

py::array_t<std::uint8_t> rgbOf(const Image& image) {
  py::array_t<std::uint8_t> out({image.height, image.width, 3});
  std::uint8_t* rgb = out.mutable_data();
  for (size_t p = 0; p < size_t(image.width) * image.height; ++p)
    for (int c = 0; c < 3; ++c) rgb[3 * p + c] = image.rgba[4 * p + c];
  return out;
}

// The snapshot drawn with the GIL released.
py::array_t<std::uint8_t> rendered(const RenderSettings& settings, const Snapshot& snapshot) {
  Image image;
  {
    py::gil_scoped_release released;
    Renderer renderer(settings);
    image = renderer.render(snapshot);
  }
  return rgbOf(image);
}

// An image from a (H, W, 3) or (H, W, 4) uint8 array, or from a PNG file's path.
Image imageOf(const py::handle& source, const char* what) {
  if (py::isinstance<py::str>(source) || py::hasattr(source, "__fspath__"))
    return readPng(py::str(source).cast<std::string>());
  if (!py::isinstance<py::array_t<std::uint8_t>>(source))
    throw py::type_error(std::string(what) +
                         ": a uint8 array of shape (height, width, 3 or 4), or a PNG's path");
  const auto array =
      py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>::ensure(source);
  if (array.ndim() != 3 || (array.shape(2) != 3 && array.shape(2) != 4) || array.shape(0) < 1 ||
      array.shape(1) < 1)
    throw py::value_error(std::string(what) +
                          ": an image's shape is (height, width, 3 or 4), not " +
                          py::str(py::getattr(source, "shape")).cast<std::string>());
  Image image;
  image.height = static_cast<int>(array.shape(0));
  image.width = static_cast<int>(array.shape(1));
  const int channels = static_cast<int>(array.shape(2));
  image.rgba.assign(size_t(image.width) * image.height * 4, 255);
  const std::uint8_t* in = array.data();
  for (size_t p = 0; p < size_t(image.width) * image.height; ++p)
    for (int c = 0; c < channels; ++c) image.rgba[4 * p + c] = in[channels * p + c];
  return image;
}

}  // namespace

void bindRender(py::module_& m) {
  const char* render_doc =
      "The simulation's particles now, or a snapshot's, drawn as `snowsim run` draws its frames: "
      "a uint8 array (height, width, 3). Keyword arguments are the run's image options, named "
      "without the dashes: color_by=\"plastic\", look=\"figure\", camera_preset=..., "
      "camera_eye=(x, y, z), camera_target=..., fov=35, background=(r, g, b), "
      "color_range=(low, high), sphere_radius=..., no_grid=True, density_cells=True, "
      "shadows=False, occlusion=False. The scene's render object gives the rest; the camera "
      "frames the first frame's snow.";
  m.def(
      "render",
      [](PySimulation& self, int width, int height, const py::kwargs& options) {
        const Snapshot snapshot = takeSnapshot(self, "render");
        return rendered(renderSettings(self.scene, self.first, width, height, options), snapshot);
      },
      py::arg("simulation"), py::arg("width") = 1280, py::arg("height") = 720, render_doc);
  m.def(
      "render",
      [](const PySnapshot& self, int width, int height, const py::kwargs& options) {
        return rendered(renderSettings(self.scene, self.first, width, height, options),
                        self.snapshot);
      },
      py::arg("snapshot"), py::arg("width") = 1280, py::arg("height") = 720, render_doc);
  m.def(
      "write_png",
      [](const std::string& path, const py::handle& image) {
        writePng(path, imageOf(image, "write_png: image"));
      },
      py::arg("path"), py::arg("image"),
      "Writes a uint8 (height, width, 3 or 4) array as a PNG, atomically.");
  m.def(
      "diff",
      [](const py::handle& a, const py::handle& b, double threshold, const py::object& mask) {
        if (!std::isfinite(threshold) || threshold < 0 || threshold > 1)
          throw py::value_error("diff: threshold: " + std::to_string(threshold) +
                                " is out of range; allowed: 0 to 1");
        const Image image_a = imageOf(a, "diff: a");
        const Image image_b = imageOf(b, "diff: b");
        if (image_a.width != image_b.width || image_a.height != image_b.height)
          throw py::value_error("diff: a is " + std::to_string(image_a.width) + "x" +
                                std::to_string(image_a.height) + " but b is " +
                                std::to_string(image_b.width) + "x" +
                                std::to_string(image_b.height) + ": no pixel compared");
        Image mask_image;
        if (!mask.is_none()) {
          mask_image = imageOf(mask, "diff: mask");
          if (mask_image.width != image_a.width || mask_image.height != image_a.height)
            throw py::value_error("diff: mask: its size is not the images'");
        }
        const ImageDiff diff =
            diffImages(image_a, image_b, threshold, mask.is_none() ? nullptr : &mask_image);
        py::dict figures;
        figures["compared"] = diff.compared;
        figures["differing"] = diff.differing;
        figures["anti_aliased"] = diff.anti_aliased;
        figures["share"] = diff.share;
        figures["largest"] = diff.largest;
        figures["visual"] = rgbOf(diff.visual);
        return figures;
      },
      py::arg("a"), py::arg("b"), py::arg("threshold") = 0.1, py::arg("mask") = py::none(),
      "Compares two images (arrays or PNG paths) as `snowsim diff` does: a dict of the pixels "
      "compared, differing, anti_aliased (ignored), their share (0..1, what --max-share bounds), "
      "the largest difference (0..1) and the visual diff image (uint8, height x width x 3).");
}

}  // namespace snowsim
